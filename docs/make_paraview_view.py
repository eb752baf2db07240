"""The README's picture of the ParaView series (docs/images/animation_paraview.png), drawn by
ParaView itself from the files `jaxflex optimize ... --animate` writes, as a user opens them:

    jaxflex model --scene plate -o plate.npz
    jaxflex optimize plate.npz --cell examples/press_cell.toml --min-distance 0.01 \\
        --cup-safety 1.5 --max-stress --threshold 5e-4 -o press --animate
    xvfb-run -a -s "-screen 0 1600x1200x24" pvpython docs/make_paraview_view.py press

(ParaView 5.11, Debian's `paraview` package; its pvpython needs an X display to render: a
desktop, or Xvfb as above, package `xvfb`. `pvbatch --force-offscreen-rendering` does not
render with Debian's build: it asks for an X display too. Under Xvfb on a loaded machine
pvpython now and then aborts at its start with "bad X server connection": run it again.)

It opens `press/animation/part.xdmf` (ParaView's Xdmf3 reader), `cell.vtu` and `path.vtu`,
goes to the frame of the certified closest approach to the obstacles (report.json's distance
constraint: its `time_s`), warps the part by its `displacement` (x 20, as the page's picture),
colours it by `distance_m` (Cool to Warm, 0 to 50 mm), draws the obstacles at opacity 0.3 and
the path with its via point, and saves the view. Runs in pvpython only (not in the project's
environment, not in the test suite: ParaView is a docs tool here).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

from paraview import simple as pv

OUT = Path(__file__).resolve().parent / "images" / "animation_paraview.png"
WARP = 20  # the deformation scale of the README's two pictures
DISTANCE_RANGE_M = (0.0, 0.05)
SIZE_PX = (900, 460)


def closest_time(result: Path) -> float:
    """The time of the certified closest approach (report.json's distance constraint)."""
    report = json.loads((result / "report.json").read_text(encoding="utf-8"))
    (distance,) = [c for c in report["constraints"] if "distance" in c["name"]]
    return float(distance["time_s"])


def show_part(folder: Path, view):
    """part.xdmf warped by its displacement, coloured by distance_m; its reader."""
    part = pv.Xdmf3ReaderS(registrationName="part.xdmf", FileName=[str(folder / "part.xdmf")])
    warp = pv.WarpByVector(registrationName="WarpByVector", Input=part)
    warp.Vectors = ["POINTS", "displacement"]
    warp.ScaleFactor = WARP
    shown = pv.Show(warp, view)
    pv.ColorBy(shown, ("POINTS", "distance_m"))
    colours = pv.GetColorTransferFunction("distance_m")
    colours.ApplyPreset("Cool to Warm", True)
    colours.RescaleTransferFunction(*DISTANCE_RANGE_M)
    colours.AutomaticRescaleRangeMode = "Never"
    shown.SetScalarBarVisibility(view, True)
    bar = pv.GetScalarBar(colours, view)
    bar.Title = "distance_m"
    bar.ComponentTitle = ""
    return part


def show_cell(folder: Path, view) -> None:
    """The obstacles at opacity 0.3, the path and its via point in white."""
    cell = pv.Show(pv.XMLUnstructuredGridReader(FileName=[str(folder / "cell.vtu")]), view)
    pv.ColorBy(cell, ("POINTS", ""))
    cell.Opacity = 0.3
    path = pv.Show(pv.XMLUnstructuredGridReader(FileName=[str(folder / "path.vtu")]), view)
    pv.ColorBy(path, ("POINTS", ""))
    path.AmbientColor = path.DiffuseColor = [1.0, 1.0, 1.0]
    path.LineWidth = 2.0
    path.PointSize = 8.0
    path.RenderPointsAsSpheres = 1


def main(argv: list[str]) -> int:
    result = Path(argv[0] if argv else "press")
    out = Path(argv[1]) if len(argv) > 1 else OUT
    folder = result / "animation"
    time_s = closest_time(result)
    view = pv.CreateView("RenderView")
    view.ViewSize = list(SIZE_PX)
    view.OrientationAxesVisibility = 0
    part = show_part(folder, view)
    times = list(part.TimestepValues)
    frame = min(range(len(times)), key=lambda i: abs(times[i] - time_s))
    show_cell(folder, view)
    view.ViewTime = times[frame]
    pv.Render(view)  # the first render places the camera around everything: then ours
    view.CameraFocalPoint = [1.95, 0.05, 0.3]
    view.CameraPosition = [0.45, -3.75, 1.75]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    view.CameraViewAngle = 30
    note = pv.Text(
        Text=f"part.xdmf at {times[frame]:.3f} s (the closest approach), Warp By Vector "
        f"(displacement x {WARP}), coloured by distance_m\ncell.vtu (opacity 0.3), path.vtu"
    )
    label = pv.Show(note, view)
    label.WindowLocation = "Upper Left Corner"
    label.Justification = "Left"
    label.FontSize = 13
    pv.Render(view)
    pv.SaveScreenshot(str(out), view, ImageResolution=list(SIZE_PX), CompressionLevel="9")
    print(f"wrote {out}: ParaView's view of {folder / 'part.xdmf'} at {times[frame]!r} s")
    return 0


if __name__ == "__main__":
    status = main(sys.argv[1:])
    sys.stdout.flush()
    # Debian's pvpython 5.11 crashes in its teardown under Xvfb (SIGSEGV after the picture
    # is written): leave without it
    os._exit(status)
