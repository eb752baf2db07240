"""Benchmarks of the fem package: speed, memory and accuracy figures as JSON.

    .venv/bin/python -m fem.bench.solves [--cases plate solid scenes transient] [-o fem_bench.json]

Each case runs in its own process so that its peak memory (max RSS) is its own.
Targets (docs/design.md): plate ~25k DOFs, 20 modes <= 10 s; thin solid ~50k DOFs, 30 modes <= 30 s
and <= 4 GB; reduced vs full-order transient R^2 >= 0.9999, max error <= 0.5 % of the peak.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import numpy as np

import fem
import jaxflex
from jaxflex.defaults import DT_S
from jaxflex.files import write_text_atomic
from jaxflex.response import upsample

CASES = ("plate", "solid", "scenes", "transient")


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _modal_case(part, supports, n_modes: int) -> dict:
    start = time.perf_counter()
    result = fem.modal_analysis(part, supports, n_modes)
    wall = time.perf_counter() - start
    return {
        "n_dof": result.system.n_dof,
        "n_free_dof": int(result.basis.shape[1]),
        "n_elements": result.system.stats["n_elements"],
        "n_modes": result.n_modes,
        "freq_hz_first_last": [float(result.freq_hz[0]), float(result.freq_hz[-1])],
        "wall_s": wall,
        "timings_s": result.timings_s,
        "cumulative_mass_fraction": [
            None if np.isnan(v) else float(v) for v in result.cumulative_fraction
        ],
    }


def case_plate() -> dict:
    """Morley plate, 1.5 x 0.8 m, 4 cups, 15 mm elements (~26k DOFs), 20 modes."""
    part, cups = fem.scene("plate", mesh_size=0.015)
    return {"target": "<= 10 s", **_modal_case(part, cups, 20)}


def case_solid() -> dict:
    """Curved panel, one-layer Hex2 thin solid, 4 cups, 60 mm base elements refined to 13 mm
    at the cups (~55k DOFs), 30 modes."""
    part, cups = fem.scene("panel", mesh_size=0.06)
    return {"target": "<= 30 s, <= 4 GB", **_modal_case(part, cups, 30)}


def case_scenes() -> dict:
    """fem.default_model for both scenes (what `jaxflex demo` calls)."""
    out = {}
    for name in ("plate", "panel"):
        start = time.perf_counter()
        model = fem.default_model(name)
        out[name] = {
            "wall_s": time.perf_counter() - start,
            "n_dof": model.meta["mesh"]["n_dof"],
            "n_points": model.n_points,
            "freq_hz": np.round(model.freq_hz, 3).tolist(),
        }
    return out


def case_transient() -> dict:
    """Reduced modal model vs the full-order Newmark transient: error against mode count."""
    dt_s, n_move, n_rest = DT_S, 30, 30
    t = np.arange(n_move + 1) * dt_s
    shape = 2 * np.pi / (n_move * dt_s) ** 2 * np.sin(2 * np.pi * t / (n_move * dt_s))
    acc = np.outer(shape, [0.3, 0.0, 1.0])
    acc[[0, -1]] = 0.0
    part = fem.rectangular_plate(0.6, 0.4, mesh_size=0.025)
    cups = fem.default_gripper(0.6, 0.4, 0.03)
    damping = fem.Rayleigh.from_zeta(0.02, 40.0, 400.0)
    result = fem.modal_analysis(part, cups, 160, zeta=damping)
    start = time.perf_counter()
    full = fem.transient_reference(
        result,
        jaxflex.as_move(acc, dt_s),
        points=1000,
        extend_s=n_rest * dt_s,
        substeps=200,
        output_substeps=10,
    )
    full_s = time.perf_counter() - start
    fine = upsample(np.concatenate([acc, np.zeros((n_rest, 3))]), 10)
    threshold_m = 0.05 * full.deviation_m.max()

    def settle(t_s, deviation):
        above = np.flatnonzero(deviation > threshold_m)
        return float(t_s[above[-1] + 1]) if above.size else 0.0

    curve = []
    for n_modes in (5, 10, 20, 40, 80, 160):
        model = result.to_modal_model(points=full.points).truncate_modes(n_modes)
        response = jaxflex.simulate(model, fine, dt_s / 10, displacement=True)
        agreement = fem.agreement(full.displacement_m, np.asarray(response.displacement))
        agreement["settle_difference_s"] = settle(full.t_s, np.asarray(response.deviation)) - (
            settle(full.t_s, full.deviation_m)
        )
        curve.append({"n_modes": n_modes, **agreement})
    return {
        "setup": "0.6 x 0.4 m steel plate, 4 cups r=30 mm, Morley 25 mm, Rayleigh 2 % at "
        "40/400 Hz, 0.3 s sine move + 0.3 s rest, Newmark h = 5e-5 s, 1 ms output",
        "n_dof": result.system.n_dof,
        "n_points": len(full.points),
        "full_order_s": full_s,
        "settle_threshold_m": threshold_m,
        "curve": curve,
    }


def _child(case: str) -> None:
    out = globals()[f"case_{case}"]()
    out["peak_rss_mb"] = _peak_rss_mb()
    print(json.dumps(out))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m fem.bench.solves", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    parser.add_argument("-o", "--output", help="write the figures as JSON here")
    parser.add_argument("--child", choices=CASES, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        _child(args.child)
        return 0
    figures = {}
    for case in args.cases:
        proc = subprocess.run(
            [sys.executable, "-m", "fem.bench.solves", "--child", case],
            capture_output=True,
            text=True,
            check=False,
        )
        if proc.returncode != 0:
            print(proc.stderr, file=sys.stderr)
            return proc.returncode
        figures[case] = json.loads(proc.stdout.strip().splitlines()[-1])
        print(f"{case}: {json.dumps(figures[case], indent=1)}", flush=True)
    if args.output:
        write_text_atomic(args.output, json.dumps(figures, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
