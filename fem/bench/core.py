"""Speed and accuracy figures of the core, measured in one run.

Case (docs/design.md targets): K = 1099 points, M = 40 modes, N = 1000 steps of 10 ms, float64,
on a synthetic model with full 3-D mode shapes (a curved part's shapes have all three
components; frequencies 5-300 Hz, zeta 0.02) and a smooth vertical move. Measured:

* forward: the jitted deviation d_k = max_p |u_p(t_k)| from the samples (modal scan plus one
  matrix product), and the public ``jaxflex.simulate`` call around it;
* gradient: jax.grad of the peak deviation with respect to the samples;
* float32 forward and its deviation error against float64;
* the preprint's direct convolution of R1 (numpy), and its agreement with the scan;
* exact cycle time (jaxflex._settle) and the smooth surrogate with its gradient.

Timings are the best of several repeats of ``jax.block_until_ready`` loops after compilation.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from fem.bench.timing import best_time_s, machine
from jaxflex import cycle_time, cycle_time_smooth, simulate
from jaxflex.defaults import DT_S, THRESHOLD_M
from jaxflex.model import ModalModel
from jaxflex.reference import convolve_unit_response, deviation_from_displacement, unit_response
from jaxflex.response import move_deviation, on_device
from jaxflex.runtime import step


@dataclass(frozen=True)
class BenchCase:
    n_points: int = 1099
    n_modes: int = 40
    n_steps: int = 1000
    dt_s: float = DT_S
    threshold_m: float = THRESHOLD_M
    seed: int = 0


QUICK = BenchCase(n_points=200, n_modes=10, n_steps=200)


def synthetic_model(case: BenchCase) -> ModalModel:
    """Random but physical-looking model: 3-D shapes, ascending frequencies 5-300 Hz."""
    rng = np.random.default_rng(case.seed)
    m = case.n_modes
    freq = np.sort(rng.uniform(5.0, 300.0, m))
    freq[0] = 5.0
    # Mass-normalised amplitudes of a ~10 kg part: |phi| ~ 0.5 m/kg^0.5, Gamma ~ 2 kg^0.5.
    shapes = rng.normal(size=(case.n_points, 3, m)) * 0.5
    gamma = 2.0 * rng.normal(size=(m, 3)) / np.arange(1, m + 1)[:, None]
    points = rng.uniform([0, 0, 0], [1.5, 0.8, 0.05], size=(case.n_points, 3))
    return ModalModel(
        freq_hz=freq,
        zeta=np.full(m, 0.02),
        gamma=gamma,
        shapes=shapes,
        points=points,
        meta={"source": "fem.bench.core synthetic model"},
    )


def sine_move(n_steps: int, dt_s: float, distance_m: float = 1.0) -> np.ndarray:
    """A vertical rest-to-rest move of ``distance_m`` with one full sine of acceleration over
    n_steps samples, a(t) = A sin(2 pi t / T), A = 2 pi distance / T^2: (n_steps + 1, 3)."""
    duration = n_steps * dt_s
    t = np.arange(n_steps + 1) * dt_s
    acc = np.zeros((n_steps + 1, 3))
    acc[:, 2] = 2 * np.pi * distance_m / duration**2 * np.sin(2 * np.pi * t / duration)
    acc[[0, -1]] = 0.0
    return acc


def run_bench(case: BenchCase = BenchCase(), *, progress: Callable[[str], None] = step) -> dict:
    """Measure everything listed in the module docstring; returns a JSON-ready dict."""
    model = synthetic_model(case)
    dt_s = case.dt_s
    acc = sine_move(case.n_steps, dt_s, distance_m=25.0)  # long horizon: peak 1.6 m/s^2
    device_model, blocks = on_device(model)
    acc_j = jnp.asarray(acc)

    @jax.jit
    def forward(m, s, a):
        return move_deviation(m, s, a, dt_s)

    grad_peak = jax.jit(jax.grad(lambda a, m, s: jnp.max(forward(m, s, a))))
    model32, blocks32 = on_device(model, "float32")
    acc32 = acc_j.astype(jnp.float32)
    results: dict = {}

    progress("forward (jit, float64) ...")
    results["forward_ms"] = 1e3 * best_time_s(lambda: forward(device_model, blocks, acc_j))
    results["simulate_public_ms"] = 1e3 * best_time_s(lambda: simulate(model, acc, dt_s).deviation)
    progress("gradient ...")
    results["gradient_ms"] = 1e3 * best_time_s(lambda: grad_peak(acc_j, device_model, blocks))
    results["gradient_over_forward"] = results["gradient_ms"] / results["forward_ms"]
    progress("float32 ...")
    results["forward_float32_ms"] = 1e3 * best_time_s(lambda: forward(model32, blocks32, acc32))
    d64 = np.asarray(forward(device_model, blocks, acc_j))
    d32 = np.asarray(forward(model32, blocks32, acc32), dtype=np.float64)
    results["float32_max_rel_error"] = float(np.max(np.abs(d32 - d64)) / np.max(d64))

    progress("direct convolution of R1 (numpy) ...")
    r1 = unit_response(model, dt_s, case.n_steps)[2:3]  # z axis: the move is vertical
    start = time.perf_counter()
    disp = convolve_unit_response(r1, acc, axes=(2,))
    results["direct_convolution_ms"] = 1e3 * (time.perf_counter() - start)
    d_conv = deviation_from_displacement(disp)
    results["convolution_vs_scan_max_rel_diff"] = float(np.max(np.abs(d_conv - d64)) / np.max(d64))
    results["speedup_vs_direct_convolution"] = (
        results["direct_convolution_ms"] / results["forward_ms"]
    )

    progress("exact cycle time and surrogate (1 m move in 0.8 s) ...")
    move = sine_move(round(0.8 / dt_s), dt_s)
    threshold_m = case.threshold_m
    results["cycle_time_s"] = cycle_time(model, move, dt_s, threshold_m)
    results["cycle_time_exact_ms"] = 1e3 * best_time_s(
        lambda: cycle_time(model, move, dt_s, threshold_m), repeats=3
    )
    smooth_vg = jax.jit(
        jax.value_and_grad(lambda a: cycle_time_smooth(model, a, dt_s, threshold_m))
    )
    move_j = jnp.asarray(move)
    results["cycle_time_smooth_s"] = float(smooth_vg(move_j)[0])
    results["smooth_value_and_grad_ms"] = 1e3 * best_time_s(lambda: smooth_vg(move_j))
    return {
        "case": {
            "n_points": case.n_points,
            "n_modes": case.n_modes,
            "n_steps": case.n_steps,
            "dt_s": dt_s,
            "threshold_m": case.threshold_m,
            "dtype": "float64",
        },
        "machine": machine(),
        "targets": {"forward_ms": 5.0, "gradient_over_forward": 3.0},
        "results": results,
    }


def format_table(report: dict) -> str:
    """Human-readable summary of :func:`run_bench` output."""
    r, c = report["results"], report["case"]
    rows = [
        (
            f"forward deviation, K={c['n_points']} M={c['n_modes']} N={c['n_steps']}",
            f"{r['forward_ms']:.2f} ms",
        ),
        ("jaxflex.simulate (public call)", f"{r['simulate_public_ms']:.2f} ms"),
        (
            "gradient of peak deviation",
            f"{r['gradient_ms']:.2f} ms ({r['gradient_over_forward']:.2f}x forward)",
        ),
        (
            "forward float32",
            f"{r['forward_float32_ms']:.2f} ms (max rel. error {r['float32_max_rel_error']:.1e})",
        ),
        ("direct convolution of R1 (numpy)", f"{r['direct_convolution_ms']:.1f} ms"),
        ("speed-up of the scan", f"{r['speedup_vs_direct_convolution']:.0f}x"),
        ("convolution vs scan", f"max rel. diff {r['convolution_vs_scan_max_rel_diff']:.1e}"),
        ("exact cycle time", f"{r['cycle_time_s']:.4f} s in {r['cycle_time_exact_ms']:.2f} ms"),
        (
            "smooth cycle time + gradient",
            f"{r['cycle_time_smooth_s']:.4f} s in {r['smooth_value_and_grad_ms']:.2f} ms",
        ),
    ]
    width = max(len(a) for a, _ in rows)
    return "\n".join(f"{a:<{width}}  {b}" for a, b in rows)
