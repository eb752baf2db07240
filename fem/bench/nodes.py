"""Every node, no reduction: the deviation and cycle time at full-mesh size, and what voxel
reduction of the monitored points costs.

``scale``: a synthetic curved part (the analytic simply supported plate's bending modes,
1.5 x 0.8 m, carried along the normal of a doubly curved surface, radii 2.5 m / 1.2 m, so
every shape has three components) at K grid nodes, M = 40 modes. Timed: the jitted forward
deviation (modal scan plus the pruned blocked evaluation of jaxflex._deviation) at K = 1 099
(the preprint's voxel count) and K = 66 308 (its fender mesh), N = 1 000 steps, and at
K = 1 000 000, N = 300 (its largest case) with float64 and float32 shapes; the exact cycle
time (jaxflex.cycle_time) at K = 66 308; the one-off preparation of the blocks; the peak
resident memory of the process after each size.

``reduction``: a built-in FE scene at all nodes against its voxel reductions to about
1 099, 300 and 100 points (fem's ``to_modal_model(points=N)``): the error of the peak
deviation and of the exact settle time, next to the time each evaluation takes.
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from collections.abc import Callable
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from fem.bench.core import sine_move
from fem.bench.timing import best_time_s
from fem.modal import modal_analysis
from fem.scenes import scene as built_in
from jaxflex import cycle_time
from jaxflex.defaults import DT_S, THRESHOLD_M
from jaxflex.files import write_text_atomic
from jaxflex.model import ModalModel
from jaxflex.reference import simply_supported_plate
from jaxflex.response import analyze_move, as_move, move_deviation, on_device
from jaxflex.runtime import step

RADII_M = (2.5, 1.2)
TARGETS = {
    "forward_1099_ms": 2.5,
    "forward_66308_over_1099": 10.0,
    "cycle_time_66308_s": 0.3,
    "forward_1000000_s": 5.0,
}


@dataclass(frozen=True)
class ScaleCase:
    n_points: int
    n_steps: int
    n_modes: int = 40
    dt_s: float = DT_S
    dtype: str = "float64"


def curved_part(n_points: int, n_modes: int = 40, seed: int = 0) -> ModalModel:
    """The analytic plate's modes on a doubly curved surface (shapes along its normal):
    smooth 3-component shapes at ``n_points`` nodes scattered uniformly over the part (an
    unstructured mesh's nodes: no grid symmetry, no ties)."""
    xy = np.random.default_rng(seed).uniform([0.0, 0.0], [1.5, 0.8], size=(n_points, 2))
    flat = simply_supported_plate(n_modes=n_modes, points=xy)
    x, y = xy[:, 0] - 0.75, xy[:, 1] - 0.4
    rx, ry = RADII_M
    normal = np.stack([-x / rx, -y / ry, np.ones_like(x)], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    shapes = normal[:, :, None] * np.asarray(flat.shapes)[:, 2:3, :]
    gamma = np.asarray(flat.gamma).copy()
    gamma[:, 0] = 0.2 * gamma[:, 2]  # a curved part also moves with in-plane acceleration
    points = np.column_stack([xy[:, 0], xy[:, 1], x**2 / (2 * rx) + y**2 / (2 * ry)])
    return ModalModel(
        freq_hz=flat.freq_hz,
        zeta=flat.zeta,
        gamma=gamma,
        shapes=shapes,
        points=points,
        meta={"source": "fem.bench.nodes curved analytic part"},
    )


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _device() -> str:
    device = jax.devices()[0]
    return f"{device.platform}:{getattr(device, 'device_kind', '')}"


def time_forward(model: ModalModel, case: ScaleCase, repeats: int = 5) -> dict:
    """Blocks preparation (once per model) and the jitted forward deviation of the bench move
    (a 25 m vertical sine over N steps); seconds and milliseconds as the keys say."""
    start = time.perf_counter()
    device_model, blocks = on_device(model, case.dtype)
    jax.block_until_ready(blocks)
    prepare_s = time.perf_counter() - start
    acc = jnp.asarray(sine_move(case.n_steps, case.dt_s, 25.0), device_model.freq_hz.dtype)
    dt = case.dt_s

    @jax.jit
    def forward(m, b, a):
        return move_deviation(m, b, a, dt)

    start = time.perf_counter()
    d = jax.block_until_ready(forward(device_model, blocks, acc))
    first_s = time.perf_counter() - start
    forward_s = best_time_s(lambda: forward(device_model, blocks, acc), repeats=repeats)
    return {
        "n_points": model.n_points,
        "n_modes": model.n_modes,
        "n_steps": case.n_steps,
        "dtype": case.dtype,
        "prepare_blocks_s": prepare_s,
        "compile_and_first_s": first_s,
        "forward_ms": 1e3 * forward_s,
        "peak_deviation_m": float(jnp.max(d)),
        "peak_rss_mb": _peak_rss_mb(),
    }


def run_scale(
    sizes: tuple[int, ...] = (1_099, 66_308),
    large: int | None = 1_000_000,
    *,
    progress: Callable[[str], None] = print,
) -> dict:
    """Forward times at ``sizes`` (N = 1 000), the cycle time at the largest of them and the
    ``large`` case (N = 300, float64 and float32)."""
    out: dict = {"device": _device(), "targets": TARGETS, "forward": []}
    for n_points in sizes:
        progress(f"all-node scale: forward deviation K={n_points} ...")
        model = curved_part(n_points)
        out["forward"].append(time_forward(model, ScaleCase(n_points=model.n_points, n_steps=1000)))
    progress(f"all-node scale: exact cycle time K={model.n_points} ...")
    move = sine_move(80, DT_S)
    threshold_m = THRESHOLD_M
    report = analyze_move(model, move, DT_S, threshold_m, settle=False)
    out["cycle_time"] = {
        "n_points": model.n_points,
        "cycle_time_s": report.cycle_time_s,
        "evaluations": report.evaluations,
        "time_s": best_time_s(lambda: cycle_time(model, move, DT_S, threshold_m), repeats=3),
    }
    del model
    if large:
        for dtype in ("float64", "float32"):
            progress(f"all-node scale: forward deviation K={large} N=300 {dtype} ...")
            model = curved_part(large)
            case = ScaleCase(n_points=model.n_points, n_steps=300, dtype=dtype)
            out["forward"].append(time_forward(model, case, repeats=2))
            del model
    small, full = out["forward"][0], out["forward"][len(sizes) - 1]
    out["ratio_full_over_reduced"] = full["forward_ms"] / small["forward_ms"]
    return out


def run_reduction(
    scene: str = "plate",
    counts: tuple[int, ...] = (1_099, 300, 100),
    *,
    n_modes: int = 40,
    mesh_size_m: float | None = None,
    progress: Callable[[str], None] = print,
) -> dict:
    """All nodes of the FE ``scene`` against voxel reductions to about ``counts`` points: peak
    deviation and exact settle time of a 1 m vertical sine move in 0.8 s (threshold 10 % of
    the all-node peak), their errors, and the time of the forward deviation and of the exact
    settle time at each size."""
    progress(f"reduction study: FE modes of the {scene} ...")
    part, supports = built_in(scene, mesh_size=mesh_size_m)
    result = modal_analysis(part, supports, n_modes=n_modes, zeta=0.02, progress=False)
    dt = DT_S
    move = as_move(sine_move(80, dt), dt)
    acc_j = jnp.asarray(np.concatenate([move.acc, np.zeros((120, 3))]))

    def settle_s(model: ModalModel, threshold_m: float) -> float:
        return analyze_move(model, move, threshold_m=threshold_m).settle_time_s

    @jax.jit
    def forward(m, b, a):
        return move_deviation(m, b, a, dt)

    def measure(model: ModalModel, threshold_m: float | None) -> dict:
        device_model, blocks = on_device(model)
        peak = float(jnp.max(forward(device_model, blocks, acc_j)))
        threshold_m = 0.1 * peak if threshold_m is None else threshold_m
        return {
            "n_points": model.n_points,
            "peak_deviation_m": peak,
            "threshold_m": threshold_m,
            "settle_time_s": settle_s(model, threshold_m),
            "forward_ms": 1e3 * best_time_s(lambda: forward(device_model, blocks, acc_j)),
            "settle_ms": 1e3 * best_time_s(lambda: settle_s(model, threshold_m), repeats=3),
        }

    progress(f"reduction study: {scene} at every node ...")
    reference = measure(result.to_modal_model(points=None), None)
    rows = [{"points": "all", **reference}]
    for count in counts:
        progress(f"reduction study: {scene} at about {count} points ...")
        row = measure(result.to_modal_model(points=count), reference["threshold_m"])
        row["peak_error_rel"] = row["peak_deviation_m"] / reference["peak_deviation_m"] - 1.0
        row["settle_error_s"] = row["settle_time_s"] - reference["settle_time_s"]
        rows.append({"points": count, **row})
    rows[0].update(peak_error_rel=0.0, settle_error_s=0.0)
    return {
        "scene": scene,
        "n_modes": result.n_modes,
        "mesh_nodes": len(result.system.nodes),
        "move": f"1 m vertical sine in 0.8 s, dt {DT_S:g} s, 1.2 s rest in the forward",
        "threshold_m": reference["threshold_m"],
        "rows": rows,
    }


def format_nodes(report: dict) -> str:
    """The figures of :func:`run_scale` and :func:`run_reduction` as text lines."""
    lines = [f"all-node evaluation on {report['scale']['device']}:"]
    for row in report["scale"]["forward"]:
        lines.append(
            f"  forward deviation K={row['n_points']:>9,d} M={row['n_modes']} "
            f"N={row['n_steps']} {row['dtype']}: {row['forward_ms']:.2f} ms "
            f"(blocks once: {row['prepare_blocks_s']:.2f} s, peak RSS {row['peak_rss_mb']:.0f} MB)"
        )
    lines.append(f"  full over reduced: {report['scale']['ratio_full_over_reduced']:.1f}x")
    ct = report["scale"]["cycle_time"]
    lines.append(
        f"  exact cycle time K={ct['n_points']:,d}: {ct['cycle_time_s']:.4f} s in "
        f"{1e3 * ct['time_s']:.0f} ms ({ct['evaluations']:,d} point evaluations)"
    )
    for study in report["reduction"]:
        lines.append(
            f"voxel reduction, {study['scene']} ({study['mesh_nodes']} nodes, "
            f"{study['n_modes']} modes):"
        )
        for row in study["rows"]:
            lines.append(
                f"  {row['n_points']:>6d} points: peak {1e3 * row['peak_deviation_m']:.3f} mm "
                f"({100 * row['peak_error_rel']:+.2f} %), settle {row['settle_time_s']:.4f} s "
                f"({1e3 * row['settle_error_s']:+.1f} ms); forward {row['forward_ms']:.2f} ms, "
                f"exact settle {row['settle_ms']:.0f} ms"
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """``python -m fem.bench.nodes [--large K] [--scenes plate panel]``: this section alone,
    figures as text and JSON (``-o FILE``)."""
    parser = argparse.ArgumentParser(prog="python -m fem.bench.nodes", description=__doc__)
    parser.add_argument("--large", type=int, default=1_000_000, help="points of the large case")
    parser.add_argument("--no-large", action="store_true", help="skip the large case")
    parser.add_argument("--scenes", nargs="*", default=["plate"], choices=["plate", "panel"])
    parser.add_argument("-o", "--output", help="also write the figures as JSON to this file")
    args = parser.parse_args(argv)
    report = {
        "scale": run_scale(large=None if args.no_large else args.large, progress=step),
        "reduction": [run_reduction(name, progress=step) for name in args.scenes],
    }
    print(format_nodes(report))
    if args.output:
        write_text_atomic(args.output, json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
