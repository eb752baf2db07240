"""A turning move as fast as a straight one: warm ``simulate_turning`` against ``simulate``.

    python -m fem.bench.turning [--scene panel|plate] [-o turning_bench.json]

The issue's case: the built-in curved panel (fem.default_model("panel"): every node, 20
modes; from the FE store of jaxflex's cache after the first run) swivelled 90 degrees about
the vertical (rate 2 rad/s, 10 rad/s^2, 100 rad/s^3) while the gripper travels 1 m along x
(2 m/s, 10 m/s^2, 100 m/s^3), 181 samples of 10 ms. Measured as CPU seconds of the process
(user + system, every thread; the figures hold on a loaded machine): the median of
``repeats`` warm calls of the public ``jaxflex.simulate_turning`` (the response, the
deviation at every node and the neglected-terms bound; its result on the host) and of
``jaxflex.simulate`` on the same translation samples (its deviation waited for), called in
turn, and the median of their ratios, round by round. The first call of each (compilation
included) is reported too. Target: the ratio at most TARGET_RATIO.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
from collections.abc import Callable

import jax
import numpy as np

import fem
from fem.bench.timing import machine
from jaxflex import jerk_limited_move, simulate
from jaxflex.defaults import DT_S
from jaxflex.files import write_text_atomic
from jaxflex.model import ModalModel
from jaxflex.response import Turn, fixed_axis_path, simulate_turning, turn_acceleration
from jaxflex.runtime import step

TARGET_RATIO = 3.0
N_SAMPLES = 181
TURN = (np.pi / 2, 2.0, 10.0, 100.0)  # rad, rad/s, rad/s^2, rad/s^3
TRAVEL = ((1.0, 0.0, 0.0), 2.0, 10.0, 100.0)  # m, m/s, m/s^2, m/s^3


def cpu_s() -> float:
    """CPU seconds (user + system) of this process so far, every thread."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def cpu_times(functions: list[Callable[[], object]], repeats: int) -> np.ndarray:
    """(1 + repeats, F) CPU seconds of each of ``functions``: their first calls (compilation
    included), then ``repeats`` rounds calling each in turn (the rounds interleaved, so that
    a change of the machine's load falls on every function alike)."""
    times = np.empty((1 + repeats, len(functions)))
    for row in range(1 + repeats):
        for column, fn in enumerate(functions):
            start = cpu_s()
            jax.block_until_ready(fn())
            times[row, column] = cpu_s() - start
    return times


def swivel(n_samples: int = N_SAMPLES, dt_s: float = DT_S) -> Turn:
    """The module docstring's move (a jaxflex.response.Turn about the origin, gravity
    -9.81 m/s^2 along z) of ``n_samples`` samples."""
    alpha = np.zeros(n_samples)
    turn = turn_acceleration(*TURN, dt_s)
    alpha[: turn.size] = turn
    acc = np.zeros((n_samples, 3))
    travel = jerk_limited_move(*TRAVEL, dt_s).acc
    acc[: len(travel)] = travel
    return Turn(fixed_axis_path("z", alpha, dt_s), acc)


def run(model: ModalModel, repeats: int = 30, *, progress: Callable[[str], None] = step) -> dict:
    """The figures of the module docstring for ``model`` (with its rotation data)."""
    turn = swivel()
    acc = turn.acc
    progress(f"turning: simulate and simulate_turning, {model.n_points} points, "
             f"{model.n_modes} modes, {acc.shape[0]} samples ...")  # fmt: skip
    times = cpu_times(
        [
            lambda: simulate(model, acc, DT_S).deviation,
            lambda: simulate_turning(model, turn).deviation_m,
        ],
        repeats,
    )
    response = simulate_turning(model, turn)
    ratio = float(np.median(times[1:, 1] / times[1:, 0]))
    return {
        "n_points": model.n_points,
        "n_modes": model.n_modes,
        "n_samples": acc.shape[0],
        "simulate_first_cpu_s": times[0, 0],
        "simulate_cpu_s": float(np.median(times[1:, 0])),
        "simulate_turning_first_cpu_s": times[0, 1],
        "simulate_turning_cpu_s": float(np.median(times[1:, 1])),
        "ratio": ratio,
        "target_ratio": TARGET_RATIO,
        "meets_target": ratio <= TARGET_RATIO,
        "peak_deviation_m": float(response.deviation_m.max()),
        "neglected_bound_m": response.neglected_bound_m,
        "machine": machine(),
        "load_average": [round(x, 2) for x in os.getloadavg()],
    }


def format_turning(result: dict) -> str:
    """One line of the figures."""
    return (
        f"turning ({result['n_points']} points, {result['n_modes']} modes, "
        f"{result['n_samples']} samples): simulate_turning "
        f"{1e3 * result['simulate_turning_cpu_s']:.2f} ms CPU, simulate "
        f"{1e3 * result['simulate_cpu_s']:.2f} ms: {result['ratio']:.2f} x (target "
        f"<= {result['target_ratio']:g} x{'' if result['meets_target'] else ', NOT met'})"
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", choices=("panel", "plate"), default="panel")
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("-o", "--output", default="turning_bench.json")
    args = parser.parse_args(argv)
    model = fem.default_model(args.scene, progress=False, cache=True)
    result = run(model, args.repeats)
    write_text_atomic(args.output, json.dumps(result, indent=1))
    print(format_turning(result))


if __name__ == "__main__":
    main()
