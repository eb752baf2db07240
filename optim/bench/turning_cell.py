"""The cell's constraints and the robust grid on turning moves (optim.turn_cell), as JSON.

    python -m optim.bench.turning_cell [-o turning_cell_bench.json]

The scenes of tests/test_optim_turning_cell.py on the same part (a 1.2 x 0.8 m, 1 mm steel
plate on four cups, 4 modes, 54 points; limits 2 / 10 / 100, 10 ms, 0.5 mm, turns within 3
rad/s, 20 rad/s^2, 200 rad/s^3 about the cups' middle): each constraint made active (its
limit 15 % below what the unconstrained optimum reaches; the distance: a post 5.5 mm from the
unconstrained swivel's corner, 10 mm required), the cycle time without and with it, the
certified value, the independent dense check (turning_loads on the profiles sampled 10 x
finer over the move and 2 s after it; the distance by turning_min_distance on the path
sampled 8 x finer) and the wall time of the constrained optimisation (after one untimed
run that compiles). Plus the robust tilt (21 x 3 grid): the nominal optimum's worst case
against the robust optimum's.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import fem
import optim
from fem.scenes import default_gripper
from jaxflex.defaults import DT_S, THRESHOLD_M
from jaxflex.files import write_text_atomic
from jaxflex.geometry import Box, Cell, turning_min_distance
from jaxflex.response import Turn, fixed_axis_path, turning_loads, upsample
from optim.turn_baselines import turn_worst_case

DT, THRESHOLD = DT_S, THRESHOLD_M
LIMITS = optim.Limits(vmax=2.0, amax=10.0, jmax=100.0)
PIVOT = (0.6, 0.4, 0.0)
TILT = {
    "rotation": optim.Rotation("x", 30.0, pivot_m=PIVOT),
    "search": optim.Search(progress=False),
}
SWIVEL = {
    "rotation": optim.Rotation("z", 90.0, pivot_m=PIVOT),
    "search": optim.Search(progress=False),
}


def _plate():
    part = fem.rectangular_plate(1.2, 0.8, 1e-3, "steel", 0.1)
    result = fem.modal_analysis(part, default_gripper(1.2, 0.8), n_modes=4, zeta=0.02)
    return result.to_modal_model(points=60)


def _fine_turn(result, factor: int) -> Turn:
    """The optimised turning move of ``result``, its samples upsampled ``factor`` x (linear
    between them, as the engine takes them)."""
    spec, fine = result.turn, DT / factor
    path = fixed_axis_path(np.asarray(spec.axis), upsample(result.angular_acc, factor, np), fine)
    acc = upsample(result.acc, factor, np)
    return Turn(path, acc, pivot_m=spec.pivot_m, gravity_m_s2=spec.gravity_m_s2)


def _dense_loads(model, result, safety: float) -> tuple[float, float]:
    loads = turning_loads(model, _fine_turn(result, 10), extend_s=2.0, cup_safety=safety)
    return float(loads.utilisation.max()), float(loads.von_mises_pa.max())


def _timed(model, distance, constraints=None, **options):
    start = time.perf_counter()
    limits = optim.Constraints(**(constraints or {}))
    result = optim.optimize(model, distance, LIMITS, DT, THRESHOLD, constraints=limits, **options)
    return result, time.perf_counter() - start


def _load_case(model, kind: str) -> dict:
    probe = {"cup_safety": 1.0} if kind == "cups" else {"max_stress_pa": 1e12}
    plain, _ = _timed(model, (0, 0, 1.0), probe, **TILT)
    peak = plain.constraints[0]["peak"]
    limit = {"cup_safety": 1 / (0.85 * peak)} if kind == "cups" else {"max_stress_pa": 0.85 * peak}
    result, wall = _timed(model, (0, 0, 1.0), limit, **TILT)
    (constraint,) = result.constraints
    dense = _dense_loads(model, result, limit.get("cup_safety", 1.0))[kind != "cups"]
    return {
        "scene": f"tilt 30 deg, lift 1 m, {kind} 15 % below the unconstrained peak",
        "cycle_without_s": plain.cycle_time_s,
        "cycle_with_s": result.cycle_time_s,
        "limit": constraint["limit"],
        "certified_peak": constraint["peak"],
        "certified_bound": constraint["bound"],
        "dense_check": dense,
        "wall_s": wall,
    }


def _distance_case(model) -> dict:
    plain, _ = _timed(model, (1.0, 0.0, 0.0), **SWIVEL)
    far = Box(np.array([1.27, -0.73, 0.0]), np.array([0.05, 1.0, 0.3]), name="post")

    def dense(result, obstacles) -> float:
        turn = _fine_turn(result, 8)
        return turning_min_distance(model, obstacles, turn, half_thickness_m=5e-4).distance_m

    start = dense(plain, (far,))
    post = Box(far.centre_m + np.array([0.0, start - 0.0055, 0.0]), far.size_m, name="post")
    cell = Cell(obstacles=(post,), end_m=np.array([1.0, 0.0, 0.0]), thickness_m=1e-3)
    result, wall = _timed(model, None, {"cell": cell, "min_distance_m": 0.01}, **SWIVEL)
    (constraint,) = result.constraints
    return {
        "scene": "swivel 90 deg about z, 1 m along x, a post 5.5 mm from the corner's path",
        "cycle_without_s": plain.cycle_time_s,
        "cycle_with_s": result.cycle_time_s,
        "limit": 0.01,
        "unconstrained_distance_m": dense(plain, (post,)),
        "certified_peak": constraint["peak"],
        "certified_bound": constraint["bound"],
        "dense_check": dense(result, (post,)),
        "wall_s": wall,
    }


def _robust_case(model) -> dict:
    robust = optim.RobustSpec()
    nominal, _ = _timed(model, (0, 0, 1.0), **TILT)
    nominal_worst = turn_worst_case(
        model, nominal.turn, nominal.move, nominal.angular_acc, THRESHOLD, robust.grid()
    )[0]
    result, wall = _timed(model, (0, 0, 1.0), robust=robust, **TILT)
    return {
        "scene": "tilt 30 deg, lift 1 m, robust 21 x 3 grid",
        "nominal_optimum_s": nominal.cycle_time_s,
        "nominal_optimum_worst_s": nominal_worst,
        "robust_optimum_s": result.cycle_time_s,
        "robust_optimum_worst_s": result.worst_case["cycle_time_s"],
        "best_baseline_worst_s": min(b.score() for b in result.baselines.entries),
        "wall_s": wall,
    }


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("-o", "--output", default="turning_cell_bench.json")
    args = parser.parse_args(argv)
    model = _plate()
    _timed(model, (0, 0, 1.0), {"cup_safety": 1.0}, **TILT)  # compile
    cases = [
        _load_case(model, "cups"),
        _load_case(model, "stress"),
        _distance_case(model),
        _robust_case(model),
    ]
    for case in cases:
        print(json.dumps(case))
    write_text_atomic(args.output, json.dumps(cases, indent=1))


if __name__ == "__main__":
    main()
