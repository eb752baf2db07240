"""Accuracy against time of every method on one FE scene (the Pareto data of ``jaxflex bench``).

For a scene (:mod:`fem.bench.fe`) the full-order FE transient is the reference. The
reduced methods (:mod:`fem.bench.methods`) run on the scene's modal model, each at its
own native step, over three sweeps from the base case (all modes, all points, dt = 10 ms):
number of modes, number of points (voxel size) and dt (10, 20, 25 ms). The FE transient
itself is a method too, at coarser steps than the reference. Each run gives one point:
wall time (best of repeats, compiled) and the preprint's errors of its deviation curve at its
own samples against the reference deviation over *all* reference points (so a reduced point
set pays for the peaks it does not monitor), plus the dense errors on the 1 ms reference
grid and the settle-time error of the curve read at the method's samples.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

import fem
from fem.bench.fe import BASE_S, SceneSpec, build_scene, fe_reference, move_of
from fem.bench.methods import METHODS, prepare, stable_substeps
from fem.bench.metrics import compare, curve_errors, settle_from_samples
from fem.bench.timing import best_time_s
from jaxflex import simulate
from jaxflex.response import analyze_move, as_move, upsample, voxel_downsample
from jaxflex.runtime import progress_bar, step

OURS = ("scan64", "scan32")
SETTLE_SHARE_OF_PEAK = 0.05
ROUND_OFF = 1e-9


def settle_threshold(t_s: np.ndarray, deviation_m: np.ndarray, rest_s: float) -> float:
    """5 % of the reference peak, raised (x1.5 of the late deviation) if the reference would
    not settle within the first three quarters of the rest period; m."""
    late = t_s >= t_s[-1] - rest_s / 4
    return float(max(SETTLE_SHARE_OF_PEAK * deviation_m.max(), 1.5 * deviation_m[late].max()))


def _runs(spec: SceneSpec, model, max_modes: int):
    """(sweep, n_modes, voxel_m, dt_s) of every reduced-model run of the scene."""
    base_dt = spec.dt_sweep_s[0]
    out = [("modes", m, None, base_dt) for m in spec.mode_counts if m <= max_modes]
    out += [("points", max_modes, v, base_dt) for v in spec.voxel_sizes_m]
    out += [("dt", max_modes, None, dt_s) for dt_s in spec.dt_sweep_s[1:]]
    return out


def _variants(method: str, model, dt_s: float, spec: SceneSpec) -> list[int]:
    if method == "newmark":
        return list(spec.newmark_substeps)
    if method == "central_difference":
        return [stable_substeps(model, dt_s)]
    return [1]


def run_scene(
    spec: SceneSpec,
    *,
    min_time_s: float = 0.1,
    progress: Callable[[str], None] = step,
    fe_progress: bool | None = None,
) -> dict:
    """Every accuracy-time point of ``spec`` and its FE-agreement figures (JSON-ready)."""
    start = time.perf_counter()
    progress(f"[{spec.key}] modal analysis ...")
    result, damping, modal_s = build_scene(spec, fe_progress)
    progress(
        f"[{spec.key}] full-order FE transient ({result.K_free.shape[0]} DOFs) "
        f"[{time.perf_counter() - start:.0f} s] ..."
    )
    ref = fe_reference(result, damping, spec, fe_progress)
    full = result.to_modal_model(points=ref.points, zeta=damping)
    ref_dev = ref.deviation_m
    threshold_m = settle_threshold(ref.t_s, ref_dev, spec.rest_s)
    settle_ref = settle_from_samples(ref.t_s, ref_dev, threshold_m)
    points = []
    for factor, (disp, seconds) in sorted(ref.runs.items()):
        dev = np.linalg.norm(disp, axis=2).max(axis=1)
        points.append(
            {
                "method": "fe_newmark",
                "sweep": "fe_step",
                "n_modes": None,
                "n_points": len(ref.points),
                "dt_s": ref.h_s * factor,
                "substeps": None,
                "time_s": seconds,
                **compare(ref.t_s, ref_dev, ref.t_s, dev, threshold_m, settle_ref),
            }
        )
    progress(f"[{spec.key}] reduced methods [{time.perf_counter() - start:.0f} s] ...")
    reference = (ref.t_s, ref_dev, threshold_m, settle_ref)
    runs = _runs(spec, full, full.n_modes)
    with progress_bar(len(runs), f"{spec.key}: reduced methods", unit="run") as bar:
        for sweep, n_modes, voxel, dt_s in runs:
            model = full.truncate_modes(n_modes)
            if voxel is not None:
                model = model.select_points(voxel_downsample(model.points, voxel))
            run = {"sweep": sweep, "n_modes": n_modes, "voxel_m": voxel}
            points.extend(_method_points(spec, model, dt_s, run, min_time_s, reference))
            bar.update(1)
    return {
        "scene": spec.describe(),
        "fe": {
            "n_dof": ref.n_dof,
            "formulation": result.system.formulation,
            "modal_analysis_s": modal_s,
            "freq_hz": [float(f) for f in result.freq_hz],
            "damping": damping.describe(),
            "reference_h_s": ref.h_s,
            "reference_integration_s": float(sum(s for _, s in ref.runs.values())),
            "reference_self_error": _self_error(ref),
            "n_points": len(ref.points),
        },
        "threshold_m": threshold_m,
        "settle_reference_s": settle_ref,
        "peak_m": float(ref_dev.max()),
        "agreement": agreement_by_modes(full, ref, spec, threshold_m, settle_ref),
        "points": points,
        "dominance": dominance(points),
    }


def _method_points(spec, model, dt_s: float, run: dict, min_time_s: float, reference) -> list:
    """One accuracy-time point per method (and substep variant) for one model and dt.
    ``reference`` is (t_s, deviation_m, threshold_m, settle_s) of the FE reference."""
    ref_t_s, ref_dev, threshold_m, settle_ref = reference
    move = as_move(move_of(spec, dt_s), dt_s)
    t_s = dt_s * np.arange(move.n_steps + 1)
    points = []
    for method in METHODS:
        for substeps in _variants(method, model, dt_s, spec):
            fn = prepare(method, model, move, substeps)
            seconds = best_time_s(fn, repeats=3, min_total_s=min_time_s)
            dev = np.asarray(fn(), dtype=float)
            point = {
                "method": method,
                **run,
                "n_points": model.n_points,
                "dt_s": dt_s,
                "substeps": substeps,
                "time_s": seconds,
                **compare(ref_t_s, ref_dev, t_s, dev, threshold_m, settle_ref),
            }
            if method == "scan64":
                tick = time.perf_counter()
                report = analyze_move(model, move, threshold_m=threshold_m)
                point["settle_exact_s"] = report.settle_time_s
                point["settle_exact_error_s"] = report.settle_time_s - settle_ref
                point["settle_exact_time_s"] = time.perf_counter() - tick
            points.append(point)
    return points


def _self_error(ref) -> dict:
    """How far the plain fine FE run is from the extrapolated reference (displacements at all
    points; the reference's own error is of higher order in h, far below this)."""
    return fem.agreement(ref.displacement_m, ref.runs[1][0])


TARGETS = {"r2": 0.99999, "linf_rel_peak": 0.002, "settle_error_s": 0.01}


def agreement_by_modes(full, ref, spec: SceneSpec, threshold_m: float, settle_ref_s: float):
    """Reduced (exact scan, output on the reference grid) vs full-order FE for each swept mode
    count: R^2 and L-infinity of the deviation curve and of the displacements, and the exact
    settle time (jaxflex.analyze_move) against the reference's; ``meets_target`` per DESIGN."""
    acc = move_of(spec, BASE_S)
    fine = upsample(acc, spec.output_per_base)
    out_step = BASE_S / spec.output_per_base
    rows = []
    for n_modes in spec.mode_counts:
        if n_modes > full.n_modes:
            continue
        model = full.truncate_modes(n_modes)
        response = simulate(model, fine, out_step, displacement=True)
        dev = curve_errors(ref.deviation_m, np.asarray(response.deviation))
        disp = fem.agreement(ref.displacement_m, np.asarray(response.displacement))
        settle = analyze_move(model, acc, BASE_S, threshold_m).settle_time_s
        row = {
            "n_modes": n_modes,
            "max_freq_hz": float(np.max(model.freq_hz)),
            "deviation_r2": dev["r2"],
            "deviation_linf_rel_peak": dev["linf_rel_peak"],
            "displacement_r2": disp["r2"],
            "displacement_linf_rel_peak": disp["max_error_rel_peak"],
            "settle_error_s": settle - settle_ref_s,
        }
        row["meets_target"] = bool(
            min(row["deviation_r2"], row["displacement_r2"]) >= TARGETS["r2"]
            and max(row["deviation_linf_rel_peak"], row["displacement_linf_rel_peak"])
            <= TARGETS["linf_rel_peak"]
            and abs(row["settle_error_s"]) <= TARGETS["settle_error_s"]
        )
        rows.append(row)
    return rows


def pareto_front(points: list[dict], key: str = "samples_linf_rel_peak") -> list[dict]:
    """The points not dominated by another (lower or equal time and error, one strictly),
    sorted by time; non-finite errors are left out."""
    finite = sorted((p for p in points if np.isfinite(p[key])), key=lambda p: (p["time_s"], p[key]))
    front, best = [], np.inf
    for p in finite:
        if p[key] < best:
            front.append(p)
            best = p[key]
    return front


def dominance(points: list[dict], key: str = "samples_linf_rel_peak") -> dict:
    """Does the exact scan dominate? For each point of another method: is some scan point
    (float64 or float32) at most as slow *and* at most as wrong? Lists the exceptions."""
    ours = [p for p in points if p["method"] in OURS and np.isfinite(p[key])]
    others = [p for p in points if p["method"] not in OURS]
    exceptions = []
    for p in others:
        # errors equal to round-off (the convolution is the same linear map) count as equal
        if not any(q["time_s"] <= p["time_s"] and q[key] <= p[key] * (1 + ROUND_OFF) for q in ours):
            exceptions.append(
                {k: p[k] for k in ("method", "sweep", "n_modes", "dt_s", "substeps", "time_s")}
                | {key: p[key]}
            )
    return {
        "metric": key,
        "other_points": len(others),
        "dominated": len(others) - len(exceptions),
        "exceptions": exceptions,
    }
