"""``jaxflex demo``: the whole job on the built-in default part.

Finite elements (the steel plate on four suction cups) -> modal model -> robust minimum
cycle-time move against the baselines -> FMI 2.0 and 3.0 FMUs with the optimised trajectory,
verified with fmpy. Everything lands in one directory.

The turning scenes (issue 26) optimise a move that turns the part (``optimize --rotate``,
optim.turn), nominal model, no FMU (the FMU does not take the pose yet): ``swivel``, the flat
plate carried upright (its long side horizontal, its normal horizontal, as a door or a side
panel in a rack) and swivelled 90 degrees about the vertical axis through the middle of its
cups while it moves 1 m along x: the Euler load of the turn is normal to the sheet, so
vibration limits the cycle; ``tilt``, the flat plate tilted 30 degrees about its long (x)
axis through the middle of its cups under gravity while it is lifted 1 m.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import fem
import optim
from fmu.export import export_fmu
from fmu.verify import verify
from jaxflex.defaults import DT_S, THRESHOLD_M
from jaxflex.files import check_output_dir, check_positive, make_output_dir, write_text_atomic
from jaxflex.runtime import step

COMMAND = "demo"
HELP = "run the whole job on the built-in default part (FE model, optimised move, FMUs)"
ORDER = 0

DEFAULT_DIR = "jaxflex_demo"
DISTANCE_M = (0.0, 0.0, 1.0)
LIMITS = {"vmax": 2.0, "amax": 10.0, "jmax": 100.0}
PIVOT_M = (0.75, 0.4, 0.0)  # the middle of the default gripper's cups (fem.scenes)
# the plate carried upright: its model frame turned 90 degrees about x (y up, z horizontal)
UPRIGHT = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
# turning scenes: (part, its pose (rotation of its model frame), distance m, axis, angle in
# degrees)
TURNS = {
    "swivel": ("plate", UPRIGHT, (1.0, 0.0, 0.0), "z", 90.0),
    "tilt": ("plate", np.eye(3), (0.0, 0.0, 1.0), "x", 30.0),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o", "--output", default=DEFAULT_DIR, help=f"output directory (default {DEFAULT_DIR})"
    )
    parser.add_argument(
        "--scene",
        choices=("plate", "panel", *TURNS),
        default="plate",
        help="built-in part: flat steel plate (default; its FE ~3 s of CPU) or curved panel "
        "(~15 s of CPU); or a move that turns the part (nominal optimum, no FMU): swivel (the "
        "plate carried upright, turned 90 deg about the vertical while it moves 1 m along x) "
        "or tilt (the plate tilted 30 deg about its long axis under gravity while it is "
        "lifted 1 m)",
    )
    parser.add_argument(
        "--threshold",
        type=float,
        default=THRESHOLD_M,
        help=f"deviation threshold in m (default {THRESHOLD_M * 1e3:g} mm)",
    )
    parser.add_argument(
        "--dt", type=float, default=DT_S, help=f"sample step in s (default {DT_S:g})"
    )
    parser.add_argument(
        "--nominal",
        action="store_true",
        help="optimise for the nominal model only (default: robust over +-10 %% frequency "
        "and damping 0.01-0.03)",
    )
    parser.add_argument("--no-fmu", action="store_true", help="skip the FMU export")


def run(args: argparse.Namespace) -> int:
    threshold_m = check_positive("--threshold", args.threshold)
    dt_s = check_positive("--dt", args.dt)
    out = make_output_dir(check_output_dir("-o/--output", args.output))
    timings: dict[str, float] = {}
    scene = TURNS.get(args.scene, (args.scene, np.eye(3), DISTANCE_M, None, 0))
    part, pose, distance_m, axis, angle_deg = scene

    start = time.perf_counter()
    model = fem.default_model(part, n_modes=20, zeta=0.02, cache=True)
    if axis is not None and not np.array_equal(pose, np.eye(3)):
        model = model.posed(pose, np.zeros(3))
    timings["fe_model_s"] = time.perf_counter() - start
    print(
        f"part: {fem.describe_model(model)} -> {model.n_modes} modes "
        f"{model.freq_hz[0]:.2f}-{model.freq_hz[-1]:.1f} Hz at {model.n_points} points "
        f"({timings['fe_model_s']:.1f} s)"
    )
    model.save(out / "model.npz")

    limits = optim.Limits(**LIMITS)
    robust = None if args.nominal or axis is not None else optim.RobustSpec()
    along = "xyz"[int(np.argmax(np.abs(distance_m)))]
    upright = "" if np.array_equal(pose, np.eye(3)) else " (the part carried upright)"
    turn = "" if axis is None else f", turned {angle_deg:g} deg about {axis}{upright}"
    print(
        f"move: {np.linalg.norm(distance_m):g} m along {along}{turn}, vmax {LIMITS['vmax']:g} "
        f"m/s, amax {LIMITS['amax']:g} m/s^2, jmax {LIMITS['jmax']:g} m/s^3, dt {dt_s * 1e3:g} "
        f"ms, threshold {threshold_m * 1e3:g} mm, "
        f"{'nominal' if robust is None else 'robust'} optimum"
    )
    pivot_m = tuple(pose @ np.asarray(PIVOT_M))
    turning = {} if axis is None else {"rotate": (axis, angle_deg), "pivot_m": pivot_m}
    start = time.perf_counter()
    result = optim.optimize(model, distance_m, limits, dt_s, threshold_m, robust=robust, **turning)
    timings["optimize_s"] = time.perf_counter() - start
    print(result.summary())
    result.save(out / "optimized")

    fmus = {}
    if axis is not None:
        print("FMU: not for turning moves yet (the FMU takes the translation only)")
    elif not args.no_fmu:
        case = result.report()
        for version in (2, 3):
            path = out / f"part_fmi{version}.fmu"
            step(f"FMI {version}.0: building {path.name} with gcc, then simulating it with fmpy")
            start = time.perf_counter()
            export_fmu(model, path, version, (result.acc, dt_s), threshold_m, case)
            check = verify(path)
            timings[f"fmi{version}_export_and_verify_s"] = time.perf_counter() - start
            fmus[path.name] = {"max_rel_diff": check.max_rel_diff, "ok": check.ok}
            print(
                f"FMI {version}.0: {path} - fmpy validation "
                f"{'clean' if not check.validation else check.validation}, max relative "
                f"difference to jaxflex {check.max_rel_diff:.1e} ({'ok' if check.ok else 'FAILED'})"
            )
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
    fmu_note = ", FMUs" if fmus else ""
    print(f"wrote {out}/: model.npz, optimized/ (trajectory.csv, report.json, plots){fmu_note}")
    return 0 if all(f["ok"] for f in fmus.values()) else 1
