"""The SizingResult of a finished ``fem.size_model`` run: what was chosen, the reference, the
errors (measured, and the reference's own estimated error), the physical checks, the move."""

from __future__ import annotations

import time
from typing import Any

from fem.sizing.levels import Final, Level, MeshChoice, SizingRun, cup_element_m
from fem.sizing.result import SizingResult


def _choice(run: SizingRun, level: Level, final: Final) -> dict[str, Any]:
    part, n_modes, idx, voxel = level.part, final.model.n_modes, final.idx, final.voxel
    given = part.mesh_is_given
    return {
        "describe": f"mesh {level.describe()}, {len(idx)} points"
        + (f" (voxel {1e3 * voxel:.3g} mm)" if voxel is not None else " (every node)")
        + f", {n_modes} modes up to {level.result.freq_hz[n_modes - 1]:.4g} Hz",
        "mesh_size_m": None if given else part.element_size_m,
        "cup_element_m": None if given else cup_element_m(part, run.request.supports),
        "cup_fine_fraction": part.cup_fine_fraction,
        "element": part.element,
        "n_dof": level.n_dof,
        "n_modes": n_modes,
        "max_freq_hz": float(level.result.freq_hz[n_modes - 1]),
        "n_points": len(idx),
        "voxel_size_m": voxel,
        "modal_analysis_s": level.wall_s,
    }


def _reference(ref: Level, peak_m: float, given: bool) -> dict[str, Any]:
    return {
        "describe": f"mesh {ref.describe()}, {ref.model.n_points} nodes, "
        f"{ref.result.n_modes} modes",
        "mesh_size_m": None if given else ref.part.element_size_m,
        "cup_fine_fraction": ref.part.cup_fine_fraction,
        "n_dof": ref.n_dof,
        "n_modes": ref.result.n_modes,
        "n_points": ref.model.n_points,
        "peak_m": peak_m,
        "settle_s": ref.settle.settle_s,
        "cycle_s": ref.settle.cycle_s,
        "modal_analysis_s": ref.wall_s,
    }


def _error(run: SizingRun, mesh: MeshChoice, final: Final) -> dict[str, Any]:
    """The measured errors against the reference and the reference's estimated own error
    (mesh: Richardson; modes: the truncated modes' quasi-static residual)."""
    ref, err, settle = mesh.reference, final.err, final.settle
    acc = run.request.move.acc
    modes_estimate = ref.residual.quasi_static_error_m(acc, ref.result.n_modes) / err["peak_m"]
    mesh_est = mesh.estimate["mesh"]
    if mesh_est is None:
        run.notes.append("the mesh error is not estimated (a single mesh)")
    return {
        "linf": err["linf"],
        "r2": err["r2"],
        "settle_s": settle.settle_s,
        "settle_reference_s": settle.reference_s,
        "settle_error_s": settle.error_s,
        "settle_ok": settle.ok,
        "reference_estimate": {
            "mesh": mesh_est,
            "mesh_order": mesh.estimate["order"],
            "mesh_note": mesh.estimate["mesh_note"],
            "modes": modes_estimate,
        },
        "estimated": err["linf"] + (mesh_est or 0.0) + modes_estimate,
    }


def _checks(run: SizingRun, level: Level, final: Final) -> dict[str, float]:
    n_modes, peak = final.model.n_modes, final.err["peak_m"]
    acc = run.request.move.acc
    return {
        "effective_mass_fraction": level.residual.effective_mass_fraction(n_modes),
        "static_residual_fraction": level.residual.static_residual_fraction(n_modes),
        "quasi_static": level.residual.quasi_static_error_m(acc, n_modes, final.idx) / peak,
    }


def sizing_result(run: SizingRun, mesh: MeshChoice, final: Final, start_s: float) -> SizingResult:
    """The result, its model's metadata carrying the sizing record (``start_s``: the
    ``time.perf_counter()`` the total time is counted from)."""
    r, level = run.request, mesh.level
    move = {
        "n_steps": r.move.n_steps,
        "dt_s": r.move.dt_s,
        "threshold_m": r.threshold_m,
        "eval_step_s": run.grid.step_s,
    }
    error = _error(run, mesh, final)
    run.timings["total_s"] = time.perf_counter() - start_s
    out = SizingResult(
        model=final.model,
        result=level.result,
        tolerance=r.accuracy.tolerance,
        met=bool(mesh.ok and final.ok),
        choice=_choice(run, level, final),
        reference=_reference(mesh.reference, final.err["peak_m"], level.part.mesh_is_given),
        error=error,
        checks=_checks(run, level, final),
        rows=run.rows,
        move=move,
        notes=run.notes,
        timings_s=run.timings,
    )
    meta = level.result.meta(n_points=len(final.idx))
    out.model = final.model.with_meta(**meta, sizing=out.as_dict(rows=False))
    return out
