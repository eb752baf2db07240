"""``jaxflex demo``: the main job on the built-in default part, end to end."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

DEFAULT_DIR = "jaxflex_demo"


COMMAND = "demo"
HELP = "run the whole job on the built-in default part"
ORDER = 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o", "--output", default=DEFAULT_DIR, help=f"output directory (default {DEFAULT_DIR})"
    )
    parser.add_argument(
        "--threshold", type=float, default=5e-4, help="deviation threshold in m (default 0.5 mm)"
    )
    parser.add_argument("--dt", type=float, default=0.01, help="sample step in s (default 0.01)")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    import jaxflex
    from jaxflex.analytic import simply_supported_plate
    from jaxflex.atomic import write_text_atomic
    from jaxflex.plots import plot_deviation
    from jaxflex.settle import analyze_move
    from jaxflex.simulate import upsample
    from jaxflex.validation import check_positive
    from optim.profiles import jerk_limited_move
    from optim.trajectory_io import write_trajectory_csv

    threshold = check_positive("--threshold", args.threshold)
    dt = check_positive("--dt", args.dt)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)

    model = simply_supported_plate(n_modes=20, zeta=0.02, points=600)
    plate = model.meta["plate"]
    print(
        f"part: simply supported steel plate {plate['width_m']} x {plate['height_m']} m x "
        f"{plate['thickness_m'] * 1e3:g} mm (analytic modes), {model.n_modes} modes "
        f"{model.freq_hz[0]:.2f}-{model.freq_hz[-1]:.1f} Hz, {model.n_points} points, zeta 0.02"
    )
    distance = np.array([0.0, 0.0, 1.0])
    limits = {"vmax_m_s": 2.0, "amax_m_s2": 10.0, "jmax_m_s3": 100.0}
    acc = jerk_limited_move(
        distance, limits["vmax_m_s"], limits["amax_m_s2"], limits["jmax_m_s3"], dt
    )
    print(
        f"move: {np.linalg.norm(distance):g} m along z, vmax {limits['vmax_m_s']:g} m/s, "
        f"amax {limits['amax_m_s2']:g} m/s^2, jmax {limits['jmax_m_s3']:g} m/s^3, "
        f"dt {dt * 1e3:g} ms -> jerk-limited move of {(len(acc) - 1) * dt:.3f} s"
    )
    analyze_move(model, acc, dt, threshold)  # compile once, so the timing below is the cost
    start = time.perf_counter()
    report = analyze_move(model, acc, dt, threshold)
    elapsed_ms = (time.perf_counter() - start) * 1e3
    print(
        f"threshold {threshold * 1e3:g} mm: residual at stop {report.residual_m * 1e3:.3f} mm, "
        f"settle time {report.settle_time_s:.3f} s, cycle time {report.cycle_time_s:.3f} s "
        f"(exact; {elapsed_ms:.1f} ms)"
    )

    substeps = 10
    horizon = max(report.cycle_time_s, report.transfer_time_s) * 1.15 - report.transfer_time_s + dt
    fine = jaxflex.simulate(model, upsample(acc, substeps), dt / substeps, extend_s=horizon)
    model.save(out / "model.npz")
    write_trajectory_csv(out / "trajectory.csv", acc, dt)
    plot_deviation(
        out / "deviation.png",
        {
            "jerk-limited move": (
                np.asarray(fine.t),
                np.asarray(fine.deviation),
                report.cycle_time_s,
            )
        },
        threshold,
        title="Deviation of the plate after a 1 m transfer",
    )
    summary = {
        "part": model.meta,
        "move": {"distance_m": distance.tolist(), "dt_s": dt, **limits},
        "result": report.as_dict(),
        "evaluation_ms": elapsed_ms,
    }
    write_text_atomic(out / "report.json", json.dumps(summary, indent=2))
    print(f"wrote {out}/model.npz, trajectory.csv, deviation.png, report.json")
    return 0
