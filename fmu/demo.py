"""``jaxflex demo``: the whole job on the built-in default part.

Finite elements (the steel plate on four suction cups) -> modal model -> robust minimum
cycle-time move against the baselines -> FMI 2.0 and 3.0 FMUs with the optimised trajectory,
verified with fmpy. Everything lands in one directory.

The turning scenes (issue 26) optimise a move that turns the part (``optimize --rotate``,
optim.turn; nominal model) about the middle of its cups, against the turning baselines, and
export the turning FMUs of the optimum (the pose as inputs, the move of poses embedded),
each replayed by fmpy against jaxflex.simulate_turning (fmu.verify_turning):

* ``swivel``: the curved panel swivelled 90 degrees about the vertical while it moves 1 m
  along x (the issue's scene). At the demo's limits and threshold the fastest move is below
  the threshold throughout (peak 0.24 mm): the kinematic floor sets the cycle.
* ``swivel-upright``: the flat plate carried upright (its long side horizontal, its normal
  horizontal, as a door or a side panel in a rack) and swivelled the same way: the Euler
  load of the turn is normal to the sheet, so vibration limits the cycle.
* ``tilt``: the flat plate tilted 30 degrees about its long (x) axis under gravity while it
  is lifted 1 m (its sag changes with the pose).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import fem
import optim
from jaxflex.defaults import DT_S, THRESHOLD_M
from jaxflex.files import (
    check_output_dir,
    check_output_file,
    check_positive,
    check_set_dir,
    make_output_dir,
    write_text_atomic,
)
from jaxflex.runtime import step

if TYPE_CHECKING:
    from jaxflex.model import ModalModel

COMMAND = "demo"
HELP = "run the whole job on the built-in default part (FE model, optimised move, FMUs)"
ORDER = 0

DEFAULT_DIR = "jaxflex_demo"
DISTANCE_M = (0.0, 0.0, 1.0)
LIMITS = {"vmax": 2.0, "amax": 10.0, "jmax": 100.0}
# the plate carried upright: its model frame turned 90 degrees about x (y up, z horizontal)
UPRIGHT = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
# turning scenes: (part, its pose (rotation of its model frame), distance m, axis, angle in
# degrees); the turn's pivot is the middle of the part's cups
TURNS = {
    "swivel": ("panel", np.eye(3), (1.0, 0.0, 0.0), "z", 90.0),
    "swivel-upright": ("plate", UPRIGHT, (1.0, 0.0, 0.0), "z", 90.0),
    "tilt": ("plate", np.eye(3), (0.0, 0.0, 1.0), "x", 30.0),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o",
        "--output",
        default=DEFAULT_DIR,
        metavar="DIR",
        help=f"output directory (default {DEFAULT_DIR})",
    )
    parser.add_argument(
        "--scene",
        choices=("plate", "panel", *TURNS),
        default="plate",
        help="built-in part: flat steel plate (default; its FE ~5 s of CPU) or curved panel "
        "(~30 s of CPU); or a move that turns the part about the middle of its cups (nominal "
        "optimum, turning FMUs): swivel (the panel turned 90 deg about the vertical while it "
        "moves 1 m along x), swivel-upright (the same with the plate carried upright, where "
        "vibration limits the cycle) or tilt (the plate tilted 30 deg about its long axis "
        "under gravity while it is lifted 1 m)",
    )
    parser.add_argument(
        "--threshold",
        type=float,
        default=THRESHOLD_M,
        metavar="M",
        help=f"deviation threshold in m (default {THRESHOLD_M * 1e3:g} mm)",
    )
    parser.add_argument(
        "--dt", type=float, default=DT_S, metavar="S", help=f"sample step in s (default {DT_S:g})"
    )
    parser.add_argument(
        "--nominal",
        action="store_true",
        help="optimise for the nominal model only (default: robust over +-10 %% frequency "
        "and damping 0.01-0.03; turning scenes are always nominal)",
    )
    parser.add_argument("--no-fmu", action="store_true", help="skip the FMU export")


def _part(part: str, pose: np.ndarray, timings: dict[str, float]) -> ModalModel:
    """The built-in ``part``'s modal model (20 modes, zeta 0.02) with its model frame turned
    by ``pose`` (3, 3)."""
    start = time.perf_counter()
    model = fem.default_model(part, n_modes=20, zeta=0.02, cache=True)
    if not np.array_equal(pose, np.eye(3)):
        model = model.posed(pose, np.zeros(3))
    timings["fe_model_s"] = time.perf_counter() - start
    print(
        f"part: {fem.describe_model(model)} -> {model.n_modes} modes "
        f"{model.freq_hz[0]:.2f}-{model.freq_hz[-1]:.1f} Hz at {model.n_points} points "
        f"({timings['fe_model_s']:.1f} s)"
    )
    accuracy = _discretisation_line(model.meta.get("discretisation"))
    if accuracy:
        print(accuracy)
    return model


def _discretisation_line(found) -> str:
    """One line on the FE's estimate of its discretisation error (the model's
    ``meta["discretisation"]``, fem.discretisation), or "" where the model has none."""
    if not isinstance(found, dict):
        return ""
    freq = 100 * found["max_freq_error"]
    line = f"  FE discretisation error (estimate): frequencies <= {freq:.2g} %"
    if found.get("max_stress_error") is not None:
        line += f", peak stress {100 * found['max_stress_error']:.2g} %"
    return line


def _export(model, result, path: Path, version: int, threshold_m: float):
    """Export ``result``'s move as an FMI ``version`` FMU of ``model`` at ``path`` and replay
    it with fmpy against jaxflex: a turning move's FMU takes the pose, its move of poses
    embedded (fmu.verify_turning), a straight move's the translation (fmu.verify). Returns
    (the export's fmu.export.ExportResult, the replay's report)."""
    from fmu.export import export_fmu
    from fmu.options import Fmi, Turning
    from fmu.verify import verify
    from fmu.verify_turning import after_move_s, verify_turning

    trajectory, fmi = result.move, Fmi(version)
    options = {"fmi": fmi, "threshold_m": threshold_m, "case": result.report()}
    if result.turn is None:
        written = export_fmu(model, path, trajectory, **options)
        return written, verify(path)
    turn = result.turn.with_move(result.angular_acc, trajectory)
    written = export_fmu(model, path, trajectory, turning=Turning.of(turn), **options)
    extend_s = after_move_s(written.case)
    return written, verify_turning(path, model, turn, extend_s=extend_s)


def _fmus(model, result, out: Path, threshold_m: float, timings: dict[str, float]) -> dict:
    """The FMI 2.0 and 3.0 FMUs of ``result``'s move, each verified; {file name: figures}."""
    fmus = {}
    kind = "" if result.turn is None else " (a turning part: the pose as inputs)"
    for version in (2, 3):
        path = out / f"part_fmi{version}.fmu"
        step(f"FMI {version}.0: exporting {path.name}{kind}, then simulating it with fmpy")
        start = time.perf_counter()
        written, check = _export(model, result, path, version, threshold_m)
        timings[f"fmi{version}_export_and_verify_s"] = time.perf_counter() - start
        fmus[path.name] = {
            "validation": check.validation,
            "max_abs_diff_m": check.max_abs_diff_m,
            "max_rel_diff": check.max_rel_diff,
            "ok": check.ok,
        }
        binary = "from the cache" if written.from_cache else "compiled with gcc"
        print(
            f"FMI {version}.0: {path} - fmpy validation "
            f"{'clean' if not check.validation else check.validation}, max relative "
            f"difference to jaxflex {check.max_rel_diff:.1e} "
            f"({'ok' if check.ok else 'FAILED'}); FMU binary {binary}"
        )
    return fmus


def _check_members(out: Path, *, fmus: bool) -> None:
    """InputError naming the file unless every file the demo writes into ``out`` may be
    written there (absent or a regular file: never a link, FIFO, device or directory)."""
    from fmu.export import sidecar_paths
    from optim.result import RESULT_FILES

    names = ["model.npz", "demo.json"]
    for version in (2, 3) if fmus else ():
        fmu_path = out / f"part_fmi{version}.fmu"
        names += [fmu_path.name, *(side.name for side in sidecar_paths(fmu_path))]
    for name in names:
        check_output_file("-o/--output", out / name)
    check_set_dir("-o/--output", out / "optimized", RESULT_FILES)


def _move_line(distance_m, turn, threshold_m: float, dt_s: float, robust) -> str:
    """The move of the scene in words; ``turn``: (pose, axis, angle in degrees) or None."""
    along = "xyz"[int(np.argmax(np.abs(distance_m)))]
    turned = ""
    if turn is not None:
        pose, axis, angle_deg = turn
        upright = "" if np.array_equal(pose, np.eye(3)) else " (the part carried upright)"
        turned = f", turned {angle_deg:g} deg about {axis}{upright}"
    return (
        f"move: {np.linalg.norm(distance_m):g} m along {along}{turned}, vmax {LIMITS['vmax']:g} "
        f"m/s, amax {LIMITS['amax']:g} m/s^2, jmax {LIMITS['jmax']:g} m/s^3, dt {dt_s * 1e3:g} "
        f"ms, threshold {threshold_m * 1e3:g} mm, "
        f"{'nominal' if robust is None else 'robust'} optimum"
    )


def run(args: argparse.Namespace) -> int:
    threshold_m = check_positive("--threshold", args.threshold)
    dt_s = check_positive("--dt", args.dt)
    out = make_output_dir(check_output_dir("-o/--output", args.output))
    _check_members(out, fmus=not args.no_fmu)
    timings: dict[str, float] = {}
    part, pose, distance_m, axis, angle_deg = TURNS.get(
        args.scene, (args.scene, np.eye(3), DISTANCE_M, None, 0.0)
    )
    model = _part(part, pose, timings)
    model.save(out / "model.npz")

    robust = None if args.nominal or axis is not None else optim.RobustSpec()
    turn = None if axis is None else (pose, axis, angle_deg)
    print(_move_line(distance_m, turn, threshold_m, dt_s, robust))
    turning = {}
    if axis is not None:  # about the middle of the part's cups
        pivot_m = tuple(float(c) for c in model.cups.centre_m.mean(axis=0))
        turning = {"rotation": optim.Rotation(axis, angle_deg, pivot_m=pivot_m)}
    start = time.perf_counter()
    result = optim.optimize(
        model, distance_m, optim.Limits(**LIMITS), dt_s, threshold_m, robust=robust, **turning
    )
    timings["optimize_s"] = time.perf_counter() - start
    print(result.summary())
    written = result.save(out / "optimized")
    plots = [p for p in written if p.suffix == ".png"]

    fmus = {} if args.no_fmu else _fmus(model, result, out, threshold_m, timings)
    summary = {
        "scene": args.scene,
        "threshold_m": threshold_m,
        "dt_s": dt_s,
        "cycle_time_s": result.cycle_time_s,
        "baselines_cycle_time_s": {b.name: b.cycle_time_s for b in result.baselines.entries},
        "fmus": fmus,
        "timings_s": timings,
    }
    write_text_atomic(out / "demo.json", json.dumps(summary, indent=2))
    fmu_note = ", part_fmi2.fmu, part_fmi3.fmu (with their input CSV and case JSON)"
    print(
        f"wrote {out}/: model.npz, demo.json, optimized/ (trajectory.csv, report.json)"
        f"{fmu_note if fmus else ''}"
    )
    print(f"plots: {', '.join(str(p) for p in plots)}")
    return 0 if all(f["ok"] for f in fmus.values()) else 1
