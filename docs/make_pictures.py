"""The README's pictures of the animation (docs/images/animation_page.png and
animation_paraview.png), made from a result animated by `jaxflex optimize ... --animate`:

    jaxflex model --scene plate -o plate.npz
    jaxflex optimize plate.npz --cell examples/press_cell.toml --min-distance 0.01 \\
        --cup-safety 1.5 --max-stress --threshold 5e-4 -o press --animate
    python docs/make_pictures.py press

The page as headless Chromium draws it at the closest approach to the die (the browser test's
command line), and a ParaView-like view of the series' frame there (read with meshio, drawn
with matplotlib in ParaView's default look: the warped skins coloured by the distance to the
obstacles, the dies, the path; ParaView itself is not installed here), each scaled down to a
small PNG.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import meshio
import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from PIL import Image

IMAGES = Path(__file__).resolve().parent / "images"
WIDTH_PX = 900
WARP = 20  # the deformation scale of both pictures


def closest_time(result: Path) -> float:
    """The time of the certified closest approach (report.json's distance constraint)."""
    report = json.loads((result / "report.json").read_text(encoding="utf-8"))
    (distance,) = [c for c in report["constraints"] if "distance" in c["name"]]
    return float(distance["time_s"])


def page_picture(result: Path, time_s: float, out: Path) -> None:
    page = result / "animation" / "animation.html"
    text = page.read_text(encoding="utf-8")
    start = text.index('id="jaxflex-data">') + len('id="jaxflex-data">')
    data = json.loads(text[start : text.index("</script>", start)])
    frame = int(np.argmin(np.abs(np.array(data["t_s"]) - time_s)))
    with tempfile.TemporaryDirectory() as profile:
        shot = Path(profile) / "page.png"
        subprocess.run(
            [
                shutil.which("chromium") or "chromium",
                "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run",
                f"--user-data-dir={profile}/user", "--window-size=1200,820",
                "--virtual-time-budget=8000", f"--screenshot={shot}",
                f"{page.resolve().as_uri()}#frame={frame}&scale={WARP}",
            ],
            check=True, capture_output=True, timeout=600,
        )  # fmt: skip
        _save_small(Image.open(shot), out)


def _save_small(image, out: Path) -> None:
    height = round(image.height * WIDTH_PX / image.width)
    small = image.convert("RGB").resize((WIDTH_PX, height), Image.LANCZOS)
    small.quantize(colors=256).save(out, optimize=True)


PARAVIEW_BACKGROUND = (0.32, 0.34, 0.43)  # ParaView's default background


def series_picture(result: Path, time_s: float, out: Path) -> None:
    """ParaView's look (its background, Cool to Warm, no axes, a legend titled by the
    array) of the part's frame at ``time_s`` warped by its displacement, the dies and the
    path."""
    folder = result / "animation"
    sets = ET.parse(folder / "part.pvd").getroot().iter("DataSet")
    times, files = zip(*((float(d.get("timestep")), d.get("file")) for d in sets), strict=True)
    frame = int(np.argmin(np.abs(np.array(times) - time_s)))
    part = meshio.read(folder / files[frame])
    cell = meshio.read(folder / "cell.vtu")
    path = meshio.read(folder / "path.vtu")
    points = part.points + WARP * part.point_data["displacement"]
    triangles = part.cells_dict["triangle"]
    value = part.point_data["distance_m"][triangles].mean(axis=1)
    fig = plt.figure(figsize=(9, 4.6), dpi=100, facecolor=PARAVIEW_BACKGROUND)
    ax = fig.add_subplot(projection="3d", computed_zorder=False, facecolor=PARAVIEW_BACKGROUND)
    boxes = cell.cells_dict["triangle"][cell.cell_data["obstacle"][0] < 2]
    ax.add_collection3d(
        Poly3DCollection(cell.points[boxes], facecolor="0.85", edgecolor="0.7", lw=0.3, alpha=0.3)
    )
    norm = plt.Normalize(0.0, 0.05)
    colours = plt.get_cmap("coolwarm")(norm(value))
    ax.add_collection3d(Poly3DCollection(points[triangles], facecolors=colours, lw=0, zorder=5))
    line = path.cells_dict["line"]
    track = np.vstack([path.points[line[:, 0]], path.points[line[-1, 1]]])
    ax.plot(*track.T, color="white", lw=1.0, zorder=6)
    ax.set(xlim=(0.4, 3.6), ylim=(-0.9, 0.9), zlim=(0.0, 1.0))
    ax.set_box_aspect((3.2, 1.8, 1.0), zoom=1.35)
    ax.view_init(elev=22, azim=-58)
    ax.set_axis_off()
    bar = fig.colorbar(
        plt.cm.ScalarMappable(cmap="coolwarm", norm=norm), ax=ax, shrink=0.55, pad=0.06
    )
    bar.set_label("distance_m", color="white")
    bar.ax.tick_params(colors="white")
    fig.text(
        0.02, 0.9,
        f"part.pvd at {times[frame]:.3f} s (the closest approach), Warp By Vector "
        f"(displacement x {WARP}), coloured by distance_m\ncell.vtu (opacity 0.3), path.vtu",
        color="white", fontsize=9,
    )  # fmt: skip
    with tempfile.TemporaryDirectory() as folder_tmp:
        shot = Path(folder_tmp) / "series.png"
        fig.savefig(shot, facecolor=PARAVIEW_BACKGROUND)
        plt.close(fig)
        _save_small(Image.open(shot), out)


def main(argv: list[str]) -> int:
    result = Path(argv[0] if argv else "press")
    time_s = closest_time(result)
    IMAGES.mkdir(exist_ok=True)
    page_picture(result, time_s, IMAGES / "animation_page.png")
    series_picture(result, time_s, IMAGES / "animation_paraview.png")
    print(f"wrote {IMAGES / 'animation_page.png'}, {IMAGES / 'animation_paraview.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
