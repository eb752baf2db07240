"""Model no more than a scene needs: the cheapest mesh, points and modes for a tolerance.

``size_model(part, supports, move, threshold_m, Accuracy(tolerance=0.01))`` builds the modal
model of a part for one move (a jaxflex.Move: acceleration samples (n+1, 3) m/s^2 and their
step dt_s, s) and a settle ``threshold_m`` (m) whose deviation d(t) = max_p |u_p(t)| and
exact settle time agree with a richer model within ``tolerance``:

* deviation: max_t |d(t) - d_ref(t)| <= tolerance x max_t d_ref(t) (L-infinity relative to the
  peak) on a fine grid over the move and the settling (R^2 is reported);
* settle time (jaxflex.analyze_move, exact): within tolerance x the reference cycle time, or
  inside the settle times of the reference for thresholds (1 +- tolerance) x threshold (the
  settle time jumps by about half a period when a peak touches the threshold; there no model
  can do better than its deviation error allows).

Three stages, each with a share of the tolerance (default mesh 0.7, points 0.1, modes 0.2: the
mesh is the expensive part to refine, points and modes cost little). The deviation curves obey
the triangle inequality, so errors within the shares add up to at most the tolerance; a final
check of the combined choice against the richer model confirms it:

1. mesh: a refinement sequence (base element size and cup element size scaled together,
   coarse to fine, default 4 ... 1/2 x the part's element size in steps of sqrt 2 for plates).
   A level is accepted when its difference to the next finer level plus the Richardson
   estimate of that finer level's own error (i.e. its estimated error against the converged
   mesh) is within the mesh share; the finer level is the reference for the later stages.
2. points: the coarsest voxel size (jaxflex._points) whose monitored points reproduce the
   deviation over every node; the nodes where the reference deviation peaks are always kept.
3. modes: the lowest n modes whose deviation matches that of all computed modes. The
   computed count is raised (by MODES_GROWTH, up to ``max_modes``) until the quasi-static residual
   of the truncated modes (fem.sizing.residual) is below half the modes' share.

Every candidate is listed with its cost and errors (SizingResult.summary()).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from fem.parts import Part
from fem.sizing.curves import SettleReference, curve_error, truncation_curves
from fem.sizing.levels import Final, Level, MeshChoice, SizingRun
from fem.sizing.report import sizing_result
from fem.sizing.request import Accuracy, SizingRequest
from fem.sizing.result import Row, SizingResult
from jaxflex.response import Move, analyze_move, deviation_curves, voxel_downsample
from jaxflex.runtime import progress_bar

HOT_POINTS = 8  # nodes where the deviation peaks, always monitored
REFERENCE_MODES_SHARE = 0.5  # quasi-static residual allowed in the modes' share
MODES_GROWTH = 1.5  # eigen solves get dearer with the mode count: do not overshoot by 2x
FINAL_RETRIES = 3
MAX_ORDER = 2.0  # Richardson: displacement order of Morley; the cup clamp converges at 1
DEFAULT_ACCURACY = Accuracy()  # a tolerance of 1 %, the default shares, meshes and modes


def _richardson(deltas: list[float], ratios: list[float]) -> tuple[float, float | None, str]:
    """Estimated error of the finer level of the last pair: delta / (r^p - 1), with the order p
    observed from the last two differences (needs three levels and a converging sequence),
    else p = 1 (conservative for the cup-clamp boundary, which converges at first order)."""
    delta, r = deltas[-1], ratios[-1]
    if len(deltas) >= 2 and 0 < delta < deltas[-2]:
        p = math.log(deltas[-2] / delta) / math.log(ratios[-2])
        p_used = min(max(p, 1.0), MAX_ORDER)
        note = f"Richardson, observed order {p:.2g}" + ("" if p_used == p else f" -> {p_used:g}")
        if p > 2 * MAX_ORDER:
            note += "; faster than the formulation allows: the agreement may be coincidental"
        return delta / (r**p_used - 1.0), p, note
    if len(deltas) >= 2:
        note = "Richardson, order 1 assumed: differences did not decrease (pre-asymptotic)"
    else:
        note = "Richardson, order 1 assumed (two levels)"
    return delta / (r - 1.0), None, note


def _reference_modes(run: SizingRun, level: Level, index: int) -> Level:
    """Raise the computed mode count until the quasi-static residual of the truncated modes
    is within half the modes' share of the tolerance (or max_modes is reached)."""
    r = run.request
    limit = REFERENCE_MODES_SHARE * r.accuracy.share("modes")
    while True:
        peak = run.peak(level)
        residual = level.residual.quasi_static_error_m(r.move.acc, level.result.n_modes) / peak
        enough = residual <= limit
        exhausted = level.result.n_modes < run.n_modes  # the mesh has no more modes
        done = enough or exhausted or run.n_modes >= r.accuracy.max_modes
        run.row(
            Row(
                "modes",
                f"compute {level.result.n_modes} modes",
                f"up to {level.result.freq_hz[-1]:.4g} Hz",
                "quasi-static residual",
                linf=residual,
                accepted=done,
                note=f"limit {100 * limit:.3g} %" + ("" if enough else ", too large"),
            )
        )
        if done:
            if not enough:
                run.notes.append(
                    f"the quasi-static residual of {level.result.n_modes} computed modes is "
                    f"{100 * residual:.3g} % of the peak (limit {100 * limit:.3g} %); raise "
                    "max_modes"
                )
            return level
        run.n_modes = min(math.ceil(MODES_GROWTH * run.n_modes), r.accuracy.max_modes)
        level = run.level(index)


def _mesh_stage(run: SizingRun) -> MeshChoice:
    """Stage 1: the coarsest mesh of the sequence within the mesh share (module docstring)
    and the next finer one, the reference of the later stages."""
    r = run.request
    share = r.accuracy.share("mesh")
    coarse = _reference_modes(run, run.level(0), 0)
    if len(run.parts) == 1:
        run.row(Row("mesh", coarse.describe(), f"{coarse.n_dof} DOFs", "-", note="not refined"))
        estimate = {"mesh": None, "order": None, "mesh_note": "mesh from file, not refined"}
        return MeshChoice(coarse, coarse, estimate, True)
    deltas: list[float] = []
    ratios: list[float] = []
    for index in range(1, len(run.parts)):
        fine = run.level(index)
        n = run.window(coarse, fine)
        err = curve_error(coarse.curves(run.grid, n).all, fine.curves(run.grid, n).all)
        deltas.append(err["linf"])
        ratios.append(coarse.part.element_size_m / fine.part.element_size_m)
        estimate, order, note = _richardson(deltas, ratios)
        # the coarse level's estimated error against the converged mesh
        measured = err["linf"] + estimate
        settle = fine.settle.check(coarse.settle.settle_s, r.accuracy.share("mesh"))
        ok = measured <= share and settle.ok
        run.row(
            Row.compared(
                "mesh",
                coarse.describe(),
                f"{coarse.n_dof} DOFs",
                fine.describe(),
                err,
                settle,
                ok,
                note=f"est. error of the finer {100 * estimate:.3g} %",
            )
        )
        info = {"mesh": estimate, "order": order, "mesh_note": note}
        if ok:
            if "coincidental" in note:
                run.notes.append(
                    f"the mesh differences fell from {100 * deltas[-2]:.3g} % to "
                    f"{100 * deltas[-1]:.3g} % in one step, faster than the formulation "
                    "converges: the agreement may be coincidental; check with finer "
                    "mesh_sizes_m"
                )
            return MeshChoice(coarse, fine, info, True)
        coarse = fine
    run.notes.append(
        f"the mesh sequence did not converge to {100 * share:.3g} % (the mesh share of the "
        "tolerance): the finest mesh is used; give finer mesh_sizes_m"
    )
    return MeshChoice(coarse, coarse, info, False)


def _hot_nodes(curves) -> np.ndarray:
    """Nodes where the deviation has its local maxima (the largest HOT_POINTS)."""
    d = curves.all
    peaks = np.flatnonzero((d[1:-1] >= d[:-2]) & (d[1:-1] >= d[2:])) + 1
    peaks = np.union1d(peaks, [int(np.argmax(d))])
    order = peaks[np.argsort(-d[peaks], kind="stable")]
    hot: list[int] = []
    for t in order:
        node = int(curves.argmax[t])
        if node not in hot:
            hot.append(node)
        if len(hot) == HOT_POINTS:
            break
    return np.asarray(hot, dtype=np.int64)


def _points_stage(run: SizingRun, level: Level, share: float) -> tuple[np.ndarray, float | None]:
    """Stage 2: the coarsest voxel size whose points reproduce the deviation over every
    node (its point indices and voxel size; every node and None if none does)."""
    r = run.request
    nodes = np.asarray(level.model.points)
    n = run.window(level)
    curves = level.curves(run.grid, n)
    keys = _hot_nodes(curves)
    if r.key_points is not None:
        keys = np.union1d(keys, level.result.select_nodes(r.key_points))
    extent = float((nodes.max(axis=0) - nodes.min(axis=0)).max())
    candidates: list[tuple[float, np.ndarray]] = []
    voxel = extent
    while True:
        idx = voxel_downsample(nodes, voxel, key_points=nodes[keys], key_tolerance_m=voxel)
        if len(idx) >= len(nodes) // 2:
            break
        if not candidates or len(idx) > len(candidates[-1][1]):
            candidates.append((voxel, idx))
        voxel /= math.sqrt(2.0)
    sub = deviation_curves(
        np.asarray(level.model.shapes), level.q(run.grid, n), [c[1] for c in candidates]
    ).subsets
    against = f"all {len(nodes)} nodes"
    for (voxel, idx), curve in zip(candidates, sub, strict=True):
        err = curve_error(curve, curves.all)
        settle, ok = None, err["linf"] <= share
        if ok:
            model = level.model.select_points(idx)
            report = analyze_move(model, run.grid.move, threshold_m=r.threshold_m)
            settle = level.settle.check(report.settle_time_s, share)
            ok = settle.ok
        label = f"voxel {1e3 * voxel:.3g} mm"
        run.row(
            Row.compared(
                "points",
                label,
                f"{len(idx)} points",
                against,
                err,
                settle,
                ok,
            )
        )
        if ok:
            return idx, voxel
    run.row(Row("points", "every node", f"{len(nodes)} points", "-", accepted=True))
    return np.arange(len(nodes)), None


def _modes_stage(run: SizingRun, level: Level, idx: np.ndarray, share: float) -> int:
    """Stage 3: the lowest mode count whose deviation matches that of every computed mode."""
    r = run.request
    model = level.model.select_points(idx)
    n = run.window(level)
    q = level.q(run.grid, n)
    curves = truncation_curves(np.asarray(model.shapes), q)
    reference = SettleReference(model, run.grid, r.threshold_m)
    total = level.result.n_modes
    against = f"{total} modes"
    shown = {1, 2, 3, 5, 8, 12, 20, 30, 50, 80, 120, 200}
    for count in range(1, total + 1):
        err = curve_error(curves[count - 1], curves[-1])
        settle, ok = None, err["linf"] <= share
        if ok and count < total:
            truncated = model.truncate_modes(count)
            report = analyze_move(truncated, run.grid.move, threshold_m=r.threshold_m)
            settle = reference.check(report.settle_time_s, share)
            ok = settle.ok
        if ok or settle is not None or count in shown or count == total:
            freq = level.result.freq_hz[count - 1]
            run.row(
                Row.compared(
                    "modes",
                    f"{count} mode" + ("s" if count > 1 else ""),
                    f"up to {freq:.4g} Hz",
                    against,
                    err,
                    settle,
                    ok,
                )
            )
        if ok:
            return count
    return total


def _final(
    run: SizingRun, mesh: MeshChoice, idx: np.ndarray, voxel: float | None, n_modes: int
) -> Final:
    """The combined choice against the reference (the finer mesh, every node and mode)."""
    r, level, ref = run.request, mesh.level, mesh.reference
    model = level.model.select_points(idx).truncate_modes(n_modes)
    report = analyze_move(model, run.grid.move, threshold_m=r.threshold_m)
    n = run.window(ref, level, cycle_s=report.cycle_time_s)
    q = level.q(run.grid, n)[:, :n_modes]
    curve = deviation_curves(np.asarray(model.shapes), q).all
    reference = ref.curves(run.grid, n).all
    err = dict(curve_error(curve, reference), peak_m=float(reference.max()))
    settle = ref.settle.check(report.settle_time_s, r.accuracy.tolerance)
    ok = err["linf"] <= r.accuracy.tolerance and settle.ok
    run.row(
        Row.compared(
            "final",
            f"{level.describe()}, {len(idx)} pts, {n_modes} modes",
            f"{len(idx) * n_modes} K x M",
            f"{ref.describe()}, all",
            err,
            settle,
            ok,
        )
    )
    return Final(model, idx, voxel, err, settle, ok)


def _reduce(run: SizingRun, mesh: MeshChoice) -> Final:
    """Stages 2 and 3 on the chosen mesh, then the final check; on a miss both again with
    half their shares, at last every node and every computed mode."""
    r, level = run.request, mesh.level
    scale = 1.0
    for attempt in range(FINAL_RETRIES + 1):
        tick = time.perf_counter()
        if attempt < FINAL_RETRIES:
            idx, voxel = _points_stage(run, level, scale * r.accuracy.share("points"))
            n_modes = _modes_stage(run, level, idx, scale * r.accuracy.share("modes"))
        else:  # give up reducing: every node, every computed mode
            idx, voxel = np.arange(level.model.n_points), None
            n_modes = level.result.n_modes
        run.timings["points_modes_s"] = time.perf_counter() - tick
        final = _final(run, mesh, idx, voxel, n_modes)
        if final.ok:
            return final
        scale *= 0.5
        run.notes.append(
            "the combined choice missed the tolerance against the reference; points and "
            f"modes were chosen again with {100 * scale:.3g} % of their shares"
        )
    return final


def size(request: SizingRequest, log: Callable[[str], None] | None = None) -> SizingResult:
    """The stages (module docstring) on a checked request: mesh, then points and modes,
    then the final check, and the result."""
    start = time.perf_counter()
    run = SizingRun(request, log)
    with progress_bar(None, "model sizing", request.progress, unit="candidate") as run.bar:
        mesh = _mesh_stage(run)
        run.timings["mesh_s"] = time.perf_counter() - start
        final = _reduce(run, mesh)
    return sizing_result(run, mesh, final, start)


def size_model(
    part: Part | str,
    supports=None,
    move: Move | None = None,
    threshold_m: float | None = None,
    accuracy: Accuracy = DEFAULT_ACCURACY,
    *,
    zeta=0.02,
    key_points=None,
    allow_rigid_modes: bool = False,
    progress: bool | None = None,
    log: Callable[[str], None] | None = None,
) -> SizingResult:
    """The cheapest modal model of ``part`` held by ``supports`` that meets ``accuracy`` for
    ``move`` (a jaxflex.Move: samples (n+1, 3) m/s^2 at rest at both ends and their step,
    e.g. ``jaxflex.as_move(acc, dt_s)``) and the settle ``threshold_m`` (m); see the module
    docstring for the criteria and stages.

    Args:
        part: a fem part, or a built-in scene name ("plate", "panel"; then ``supports`` None
            means the scene's gripper).
        accuracy: the tolerance to meet and the search's knobs (fem.Accuracy: tolerance,
            its shares per stage, mesh sizes, reference and maximum mode counts, evaluation
            step; default a tolerance of 1 %).
        zeta: modal damping (ratio, per mode, or fem.Rayleigh); must be > 0.
        key_points: (Kk, 2|3) points (m) that must be monitored (weld spots).
        allow_rigid_modes: passed to fem.modal_analysis (rigid modes are left out).
        progress: progress bars (None: on a terminal); ``log``: called with one line per
            candidate (e.g. print).
    """
    request = SizingRequest(
        part,
        supports,
        move,
        threshold_m,
        accuracy,
        zeta=zeta,
        key_points=key_points,
        allow_rigid_modes=allow_rigid_modes,
        progress=progress,
    )
    return size(request, log)
