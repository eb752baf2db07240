"""Model no more than a scene needs: the cheapest mesh, points and modes for a tolerance.

``size_model(part, supports, acc, dt_s, threshold_m, tolerance=0.01)`` builds the modal model
of a part for one move (acceleration samples ``acc`` (n+1, 3) m/s^2 every ``dt_s`` s) and a
settle ``threshold_m`` (m) whose deviation d(t) = max_p |u_p(t)| and exact settle time agree
with a richer model within ``tolerance``:

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
2. points: the coarsest voxel size (jaxflex.points) whose monitored points reproduce the
   deviation over every node; the nodes where the reference deviation peaks are always kept.
3. modes: the lowest n modes whose deviation matches that of all computed modes. The
   computed count is raised (by MODES_GROWTH, up to ``max_modes``) until the quasi-static residual
   of the truncated modes (fem.sizing_residual) is below half the modes' share.

Every candidate is listed with its cost and errors (SizingResult.summary()).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from fem.modal import ModalResult, modal_analysis
from fem.parts import CUP_FINE_FRACTION, Part
from fem.scenes import SCENES, scene
from fem.sizing_curves import (
    SettleReference,
    TimeGrid,
    curve_error,
    modal_coordinates,
    truncation_curves,
)
from fem.sizing_residual import TruncationResidual
from fem.sizing_result import Row, SizingResult
from fem.supports import contact_discs
from jaxflex.errors import InputError
from jaxflex.files import check_positive
from jaxflex.model import ModalModel
from jaxflex.response import analyze_move, as_move, deviation_curves, voxel_downsample
from jaxflex.runtime import progress_bar

# Refinement sequence: multiples of the part's element size, coarse to fine (a factor sqrt 2
# per level); the cup element size is CUP_RATIO x the base size (measured on the 1.5 x 0.8 m
# plate: with r/4 cups at 15 mm, the cup clamp dominated the error; base / 3 balances both).
_ROOT2 = math.sqrt(2.0)
REFINEMENT = {
    "morley": (4.0, 2.0 * _ROOT2, 2.0, _ROOT2, 1.0, 1.0 / _ROOT2, 0.5),
    "argyris": (4.0, 2.0 * _ROOT2, 2.0, _ROOT2, 1.0, 1.0 / _ROOT2, 0.5),
    "shell": (4.0, 2.0 * _ROOT2, 2.0, _ROOT2, 1.0, 1.0 / _ROOT2, 0.5),
    "hex2": (4.0, 2.0 * _ROOT2, 2.0, _ROOT2, 1.0),
}
CUP_RATIO = {"morley": 1 / 3, "argyris": 1 / 3, "shell": 1 / 3, "hex2": 1 / 2}
# Shares of the tolerance: mesh, points, modes. The mesh is by far the most expensive to
# refine (offline minutes); points and modes cost little online, so they get less.
DEFAULT_SHARES = (0.7, 0.1, 0.2)
SAMPLES_PER_PERIOD = 16  # evaluation grid: 16 samples per period of the GRID_MODE-th mode
GRID_MODE = 10
TAIL_PERIODS = 2.0  # curves are compared up to the later cycle time + 2 first-mode periods
HOT_POINTS = 8  # nodes where the deviation peaks, always monitored
REFERENCE_MODES_SHARE = 0.5  # quasi-static residual allowed in the modes' share
MODES_GROWTH = 1.5  # eigen solves get dearer with the mode count: do not overshoot by 2x
FINAL_RETRIES = 3
MAX_ORDER = 2.0  # Richardson: displacement order of Morley; the cup clamp converges at 1


class _Level:
    """One mesh of the refinement sequence: modal analysis with every node as a point."""

    def __init__(self, part: Part, supports: list, n_modes: int, options: dict) -> None:
        start = time.perf_counter()
        self.part = part
        self.result: ModalResult = modal_analysis(part, supports, n_modes=n_modes, **options)
        self.model: ModalModel = self.result.to_modal_model(points=None, outputs=False)
        self.wall_s = time.perf_counter() - start
        self.residual = TruncationResidual(self.result)
        self._q: dict[int, np.ndarray] = {}
        self._curves: dict[int, Any] = {}
        self.settle: SettleReference | None = None

    @property
    def n_dof(self) -> int:
        return int(self.result.system.n_dof)

    @property
    def f1_hz(self) -> float:
        return float(self.result.freq_hz[0])

    def describe(self) -> str:
        if self.part.mesh_is_given:
            return "mesh from file"
        cup = _cup_element_m(self.part, self.result.supports)
        text = f"{1e3 * self.part.element_size_m:.3g} mm"
        return text + (f" (cups {1e3 * cup:.3g} mm)" if cup is not None else "")

    def q(self, grid: TimeGrid, n_samples: int) -> np.ndarray:
        if n_samples not in self._q:
            self._q = {n_samples: modal_coordinates(self.model, grid, n_samples)}
        return self._q[n_samples]

    def curves(self, grid: TimeGrid, n_samples: int):
        if n_samples not in self._curves:
            q = self.q(grid, n_samples)
            self._curves = {n_samples: deviation_curves(np.asarray(self.model.shapes), q)}
        return self._curves[n_samples]


def _cup_element_m(part: Part, supports) -> float | None:
    """Element size inside the contact discs (cups) of ``supports``, m (None: no disc)."""
    discs = contact_discs(supports)
    if not discs:
        return None
    fraction = part.cup_fine_fraction or CUP_FINE_FRACTION[part.element]
    return min(part.element_size_m, fraction * min(d.radius for d in discs))


def _refinement_parts(part: Part, mesh_sizes_m, radius_m: float | None) -> list[Part]:
    """The parts of the refinement sequence, coarse to fine, with cup elements of CUP_RATIO x
    the base size (``radius_m``: the smallest cup radius, None without cups); a part read
    from a mesh file is used as is."""
    if part.mesh_is_given:
        if mesh_sizes_m is not None:
            raise InputError("mesh_sizes_m: a part read from a mesh file is used as is")
        return [part]
    if mesh_sizes_m is None:
        sizes = [part.element_size_m * f for f in REFINEMENT[part.element]]
    else:
        sizes = [check_positive(f"mesh_sizes_m[{i}]", h) for i, h in enumerate(mesh_sizes_m)]
        if len(sizes) < 2 or any(b >= a for a, b in itertools.pairwise(sizes)):
            raise InputError(
                f"mesh_sizes_m: give at least two element sizes in m, coarse to fine (strictly "
                f"decreasing), got {list(mesh_sizes_m)}"
            )
    ratio = CUP_RATIO[part.element]
    return [
        dataclasses.replace(
            part,
            mesh_size_m=h,
            cup_fine_fraction=None if radius_m is None else ratio * h / radius_m,
        )
        for h in sizes
    ]


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


class _Sizer:
    def __init__(
        self,
        part: Part,
        supports: list,
        acc: np.ndarray,
        dt_s: float,
        threshold_m: float,
        tolerance: float,
        *,
        zeta,
        mesh_sizes_m,
        reference_modes: int,
        max_modes: int,
        key_points,
        shares: tuple[float, float, float],
        eval_step_s: float | None,
        allow_rigid_modes: bool,
        progress: bool | None,
        log: Callable[[str], None] | None,
    ) -> None:
        self.supports = supports
        self.acc, self.dt_s, self.threshold_m = acc, dt_s, threshold_m
        self.tol, self.shares = tolerance, shares
        self.n_modes, self.max_modes = reference_modes, max_modes
        self.modal_options = {
            "zeta": zeta,
            "allow_rigid_modes": allow_rigid_modes,
            "progress": progress,
        }
        self.key_points, self.eval_step_s = key_points, eval_step_s
        radii = [d.radius for d in contact_discs(supports)]
        self.parts = _refinement_parts(part, mesh_sizes_m, min(radii, default=None))
        self.progress, self.log = progress, log or (lambda text: None)
        self.rows: list[Row] = []
        self.notes: list[str] = []
        self.timings: dict[str, float] = {}
        self.grid: TimeGrid | None = None

    # -- helpers ---------------------------------------------------------------------------
    def _row(self, row: Row) -> None:
        self.rows.append(row)
        verdict = {True: "accepted", False: "rejected", None: ""}[row.accepted]
        settle = f", settle {row.settle.describe()}" if row.settle is not None else ""
        linf = "" if row.linf is None else f": L-inf {100 * row.linf:.3g} % of the peak"
        self.log(
            f"[{row.stage}] {row.candidate} ({row.cost}) vs {row.against}{linf}{settle} "
            f"{verdict}" + (f" ({row.note})" if row.note else "")
        )
        self.bar.update(1)
        self.bar.set_postfix_str(f"{row.stage}: {row.candidate}")

    def _level(self, index: int) -> _Level:
        part = self.parts[index]
        level = _Level(part, self.supports, self.n_modes, self.modal_options)
        if self.grid is None:
            f_grid = level.result.freq_hz[min(GRID_MODE, level.result.n_modes) - 1]
            if self.eval_step_s is None:
                factor = math.ceil(self.dt_s * SAMPLES_PER_PERIOD * f_grid - 1e-9)
            else:
                factor = math.ceil(self.dt_s / self.eval_step_s - 1e-9)
            self.grid = TimeGrid(self.acc, self.dt_s, max(1, factor))
        level.settle = SettleReference(level.model, self.grid, self.threshold_m)
        if not np.isfinite(level.settle.cycle_s):
            raise InputError("zeta: the deviation never settles (undamped modes); give zeta > 0")
        self.log(
            f"[mesh] {level.describe()}: {level.n_dof} DOFs, {level.result.n_modes} modes "
            f"({level.result.freq_hz[0]:.4g}-{level.result.freq_hz[-1]:.4g} Hz), "
            f"{level.model.n_points} nodes, {level.wall_s:.2f} s; settle "
            f"{level.settle.settle_s:.4f} s"
        )
        return level

    def _window(self, *levels: _Level, cycle_s: float = 0.0) -> int:
        """Samples up to the latest cycle time + TAIL_PERIODS periods of the first mode."""
        t_end = max(cycle_s, *(level.settle.cycle_s for level in levels))
        f1 = min(level.f1_hz for level in levels)
        return self.grid.samples_until(t_end + TAIL_PERIODS / f1)

    def _peak(self, level: _Level) -> float:
        n = self._window(level)
        peak = float(level.curves(self.grid, n).all.max())
        if peak <= 0:
            raise InputError(
                "acc: the move does not deflect the part (peak deviation 0); a Kirchhoff plate "
                "(flat part) only responds to acceleration along z"
            )
        return peak

    # -- reference modes ---------------------------------------------------------------------
    def _reference_modes(self, level: _Level, index: int) -> _Level:
        """Raise the computed mode count until the quasi-static residual of the truncated modes
        is within half the modes' share of the tolerance (or max_modes is reached)."""
        limit = REFERENCE_MODES_SHARE * self.shares[2] * self.tol
        while True:
            peak = self._peak(level)
            residual = level.residual.quasi_static_error_m(self.acc, level.result.n_modes) / peak
            enough = residual <= limit
            exhausted = level.result.n_modes < self.n_modes  # the mesh has no more modes
            done = enough or exhausted or self.n_modes >= self.max_modes
            self._row(
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
                    self.notes.append(
                        f"the quasi-static residual of {level.result.n_modes} computed modes is "
                        f"{100 * residual:.3g} % of the peak (limit {100 * limit:.3g} %); raise "
                        "max_modes"
                    )
                return level
            self.n_modes = min(math.ceil(MODES_GROWTH * self.n_modes), self.max_modes)
            level = self._level(index)

    # -- stage 1: mesh ---------------------------------------------------------------------
    def _mesh_stage(self) -> tuple[_Level, _Level, dict[str, Any], bool]:
        share = self.shares[0] * self.tol
        coarse = self._reference_modes(self._level(0), 0)
        if len(self.parts) == 1:
            self._row(
                Row("mesh", coarse.describe(), f"{coarse.n_dof} DOFs", "-", note="not refined")
            )
            estimate = {"mesh": None, "order": None, "mesh_note": "mesh from file, not refined"}
            return coarse, coarse, estimate, True
        deltas: list[float] = []
        ratios: list[float] = []
        for index in range(1, len(self.parts)):
            fine = self._level(index)
            n = self._window(coarse, fine)
            err = curve_error(coarse.curves(self.grid, n).all, fine.curves(self.grid, n).all)
            deltas.append(err["linf"])
            ratios.append(coarse.part.element_size_m / fine.part.element_size_m)
            estimate, order, note = _richardson(deltas, ratios)
            # the coarse level's estimated error against the converged mesh
            measured = err["linf"] + estimate
            settle = fine.settle.check(coarse.settle.settle_s, self.shares[0] * self.tol)
            ok = measured <= share and settle.ok
            self._row(
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
                    self.notes.append(
                        f"the mesh differences fell from {100 * deltas[-2]:.3g} % to "
                        f"{100 * deltas[-1]:.3g} % in one step, faster than the formulation "
                        "converges: the agreement may be coincidental; check with finer "
                        "mesh_sizes_m"
                    )
                return coarse, fine, info, True
            coarse = fine
        self.notes.append(
            f"the mesh sequence did not converge to {100 * share:.3g} % (the mesh share of the "
            "tolerance): the finest mesh is used; give finer mesh_sizes_m"
        )
        return coarse, coarse, info, False

    # -- stage 2: points -------------------------------------------------------------------
    def _hot_nodes(self, curves) -> np.ndarray:
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

    def _points_stage(self, level: _Level, share: float) -> tuple[np.ndarray, float | None]:
        nodes = np.asarray(level.model.points)
        n = self._window(level)
        curves = level.curves(self.grid, n)
        keys = self._hot_nodes(curves)
        if self.key_points is not None:
            keys = np.union1d(keys, level.result.select_nodes(self.key_points))
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
            np.asarray(level.model.shapes), level.q(self.grid, n), [c[1] for c in candidates]
        ).subsets
        against = f"all {len(nodes)} nodes"
        for (voxel, idx), curve in zip(candidates, sub, strict=True):
            err = curve_error(curve, curves.all)
            settle, ok = None, err["linf"] <= share
            if ok:
                model = level.model.select_points(idx)
                report = analyze_move(model, self.grid.acc, self.grid.dt_s, self.threshold_m)
                settle = level.settle.check(report.settle_time_s, share)
                ok = settle.ok
            label = f"voxel {1e3 * voxel:.3g} mm"
            self._row(
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
        self._row(Row("points", "every node", f"{len(nodes)} points", "-", accepted=True))
        return np.arange(len(nodes)), None

    # -- stage 3: modes --------------------------------------------------------------------
    def _modes_stage(self, level: _Level, idx: np.ndarray, share: float) -> int:
        model = level.model.select_points(idx)
        n = self._window(level)
        q = level.q(self.grid, n)
        curves = truncation_curves(np.asarray(model.shapes), q)
        reference = SettleReference(model, self.grid, self.threshold_m)
        total = level.result.n_modes
        against = f"{total} modes"
        shown = {1, 2, 3, 5, 8, 12, 20, 30, 50, 80, 120, 200}
        for count in range(1, total + 1):
            err = curve_error(curves[count - 1], curves[-1])
            settle, ok = None, err["linf"] <= share
            if ok and count < total:
                truncated = model.truncate_modes(count)
                report = analyze_move(truncated, self.grid.acc, self.grid.dt_s, self.threshold_m)
                settle = reference.check(report.settle_time_s, share)
                ok = settle.ok
            if ok or settle is not None or count in shown or count == total:
                freq = level.result.freq_hz[count - 1]
                self._row(
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

    # -- final check and the whole run -------------------------------------------------------
    def _final(self, level: _Level, ref: _Level, idx, n_modes: int):
        model = level.model.select_points(idx).truncate_modes(n_modes)
        report = analyze_move(model, self.grid.acc, self.grid.dt_s, self.threshold_m)
        n = self._window(ref, level, cycle_s=report.cycle_time_s)
        q = level.q(self.grid, n)[:, :n_modes]
        curve = deviation_curves(np.asarray(model.shapes), q).all
        reference = ref.curves(self.grid, n).all
        err = dict(curve_error(curve, reference), peak_m=float(reference.max()))
        settle = ref.settle.check(report.settle_time_s, self.tol)
        ok = err["linf"] <= self.tol and settle.ok
        self._row(
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
        return model, err, settle, ok

    def run(self) -> SizingResult:
        start = time.perf_counter()
        with progress_bar(None, "model sizing", self.progress, unit="candidate") as self.bar:
            level, ref, mesh_estimate, mesh_ok = self._mesh_stage()
            self.timings["mesh_s"] = time.perf_counter() - start
            scale = 1.0
            for attempt in range(FINAL_RETRIES + 1):
                tick = time.perf_counter()
                if attempt < FINAL_RETRIES:
                    idx, voxel = self._points_stage(level, scale * self.shares[1] * self.tol)
                    n_modes = self._modes_stage(level, idx, scale * self.shares[2] * self.tol)
                else:  # give up reducing: every node, every computed mode
                    idx, voxel = np.arange(level.model.n_points), None
                    n_modes = level.result.n_modes
                self.timings["points_modes_s"] = time.perf_counter() - tick
                model, err, settle, ok = self._final(level, ref, idx, n_modes)
                if ok:
                    break
                scale *= 0.5
                self.notes.append(
                    "the combined choice missed the tolerance against the reference; points and "
                    f"modes were chosen again with {100 * scale:.3g} % of their shares"
                )
        return self._result(
            level, ref, mesh_estimate, mesh_ok and ok, model, idx, voxel, err, settle, start
        )

    def _result(self, level, ref, mesh_estimate, met, model, idx, voxel, err, settle, start):
        n_modes = model.n_modes
        ref_peak = err["peak_m"]
        modes_estimate = ref.residual.quasi_static_error_m(self.acc, ref.result.n_modes) / ref_peak
        mesh_est = mesh_estimate["mesh"]
        estimated = err["linf"] + (mesh_est or 0.0) + modes_estimate
        if mesh_est is None:
            self.notes.append("the mesh error is not estimated (a single mesh)")
        if level.part.mesh_is_given:
            mesh_size = cup = None
        else:
            mesh_size = level.part.element_size_m
            cup = _cup_element_m(level.part, self.supports)
        choice = {
            "describe": f"mesh {level.describe()}, {len(idx)} points"
            + (f" (voxel {1e3 * voxel:.3g} mm)" if voxel is not None else " (every node)")
            + f", {n_modes} modes up to {level.result.freq_hz[n_modes - 1]:.4g} Hz",
            "mesh_size_m": mesh_size,
            "cup_element_m": cup,
            "cup_fine_fraction": level.part.cup_fine_fraction,
            "element": level.part.element,
            "n_dof": level.n_dof,
            "n_modes": n_modes,
            "max_freq_hz": float(level.result.freq_hz[n_modes - 1]),
            "n_points": len(idx),
            "voxel_size_m": voxel,
            "modal_analysis_s": level.wall_s,
        }
        reference = {
            "describe": f"mesh {ref.describe()}, {ref.model.n_points} nodes, "
            f"{ref.result.n_modes} modes",
            "mesh_size_m": None if mesh_size is None else ref.part.element_size_m,
            "cup_fine_fraction": ref.part.cup_fine_fraction,
            "n_dof": ref.n_dof,
            "n_modes": ref.result.n_modes,
            "n_points": ref.model.n_points,
            "peak_m": ref_peak,
            "settle_s": ref.settle.settle_s,
            "cycle_s": ref.settle.cycle_s,
            "modal_analysis_s": ref.wall_s,
        }
        error = {
            "linf": err["linf"],
            "r2": err["r2"],
            "settle_s": settle.settle_s,
            "settle_reference_s": settle.reference_s,
            "settle_error_s": settle.error_s,
            "settle_ok": settle.ok,
            "reference_estimate": {
                "mesh": mesh_est,
                "mesh_order": mesh_estimate["order"],
                "mesh_note": mesh_estimate["mesh_note"],
                "modes": modes_estimate,
            },
            "estimated": estimated,
        }
        peak = ref_peak
        checks = {
            "effective_mass_fraction": level.residual.effective_mass_fraction(n_modes),
            "static_residual_fraction": level.residual.static_residual_fraction(n_modes),
            "quasi_static": level.residual.quasi_static_error_m(self.acc, n_modes, idx) / peak,
        }
        move = {
            "n_steps": int(self.acc.shape[0] - 1),
            "dt_s": self.dt_s,
            "threshold_m": self.threshold_m,
            "eval_step_s": self.grid.step_s,
        }
        self.timings["total_s"] = time.perf_counter() - start
        out = SizingResult(
            model=model,
            result=level.result,
            tolerance=self.tol,
            met=bool(met),
            choice=choice,
            reference=reference,
            error=error,
            checks=checks,
            rows=self.rows,
            move=move,
            notes=self.notes,
            timings_s=self.timings,
        )
        meta = level.result.meta(n_points=len(idx))
        out.model = model.with_meta(**meta, sizing=out.as_dict(rows=False))
        return out


def _check_shares(shares) -> tuple[float, float, float]:
    try:
        values = tuple(float(s) for s in shares)
    except (TypeError, ValueError) as exc:
        raise InputError(f"shares: three numbers (mesh, points, modes), got {shares!r}") from exc
    if len(values) != 3 or any(not (0 < s <= 1) for s in values) or sum(values) > 1 + 1e-12:
        raise InputError(
            f"shares: three fractions of the tolerance in (0, 1] for mesh, points and modes, "
            f"summing to at most 1, got {shares!r}"
        )
    return values  # type: ignore[return-value]


def _check_count(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise InputError(f"{name}: must be an integer >= {minimum}, got {value!r}")
    return int(value)


def size_model(
    part: Part | str,
    supports=None,
    acc=None,
    dt_s: float = 0.01,
    threshold_m: float | None = None,
    tolerance: float = 0.01,
    *,
    zeta=0.02,
    mesh_sizes_m: Sequence[float] | None = None,
    reference_modes: int = 40,
    max_modes: int = 160,
    key_points=None,
    shares: Sequence[float] = DEFAULT_SHARES,
    eval_step_s: float | None = None,
    allow_rigid_modes: bool = False,
    progress: bool | None = None,
    log: Callable[[str], None] | None = None,
) -> SizingResult:
    """The cheapest modal model of ``part`` held by ``supports`` that meets ``tolerance`` for
    the move ``acc`` ((n+1, 3) m/s^2 every ``dt_s`` s, at rest at both ends) and the settle
    ``threshold_m`` (m); see the module docstring for the criteria and stages.

    Args:
        part: a fem part, or a built-in scene name ("plate", "panel"; then ``supports`` None
            means the scene's gripper).
        tolerance: accuracy as a fraction (0.01 = 1 %) of the peak deviation and of the cycle
            time; 0 < tolerance < 0.5.
        zeta: modal damping (ratio, per mode, or fem.Rayleigh); must be > 0.
        mesh_sizes_m: base element sizes to try, coarse to fine (default: REFINEMENT, 4 ...
            1/2 x the part's element size for plates, 4 ... 1 x for thin solids); the
            cup element size is CUP_RATIO x the base size.
        reference_modes: modes computed at first (raised by MODES_GROWTH, up to ``max_modes``
            while the truncated modes' quasi-static residual is too large).
        key_points: (Kk, 2|3) points (m) that must be monitored (weld spots).
        shares: fractions of the tolerance for the mesh, points and modes stages.
        eval_step_s: step of the evaluation grid (default: dt / ceil(16 dt f_10), 16 samples
            per period of the 10th mode, a whole fraction of dt).
        allow_rigid_modes: passed to fem.modal_analysis (rigid modes are left out).
        progress: progress bars (None: on a terminal); ``log``: called with one line per
            candidate (e.g. print).
    """
    if isinstance(part, str):
        if part not in SCENES:
            raise InputError(f"part: a fem part or a scene in {list(SCENES)}, got {part!r}")
        part, default = scene(part)
        supports = default if supports is None else supports
    elif not isinstance(part, Part):
        raise InputError(
            "part: expected a fem part (rectangular_plate, curved_panel, read_mesh) or a scene "
            f"name, got {type(part).__name__}"
        )
    if supports is None:
        raise InputError("supports: a part needs its gripper (fem.SuctionCup, ...)")
    if acc is None:
        raise InputError("acc: the move's acceleration samples (n+1, 3) in m/s^2 are required")
    move = as_move(acc, dt_s, at_rest=True)
    acc, dt_s = move.acc, move.dt_s
    if not np.any(acc):
        raise InputError("acc: every sample is 0; the part does not move")
    if threshold_m is None:
        raise InputError("threshold_m: the settle threshold in m is required")
    threshold_m = check_positive("threshold_m", threshold_m)
    tolerance = check_positive("tolerance", tolerance)
    if tolerance >= 0.5:
        raise InputError(
            f"tolerance: a fraction in (0, 0.5) (0.01 = 1 %), got {tolerance!r}"
            + (f"; did you mean {tolerance / 100:g}?" if tolerance < 50 else "")
        )
    reference_modes = _check_count("reference_modes", reference_modes, 2)
    max_modes = _check_count("max_modes", max_modes, reference_modes)
    if eval_step_s is not None:
        eval_step_s = check_positive("eval_step_s", eval_step_s)
    if isinstance(zeta, int | float) and not zeta > 0:  # arrays, Rayleigh: fem.modal checks
        raise InputError(f"zeta: must be > 0 for the deviation to settle, got {zeta!r}")
    sizer = _Sizer(
        part,
        list(supports) if isinstance(supports, list | tuple) else supports,
        acc,
        dt_s,
        threshold_m,
        tolerance,
        zeta=zeta,
        mesh_sizes_m=mesh_sizes_m,
        reference_modes=reference_modes,
        max_modes=max_modes,
        key_points=key_points,
        shares=_check_shares(shares),
        eval_step_s=eval_step_s,
        allow_rigid_modes=bool(allow_rigid_modes),
        progress=progress,
        log=log,
    )
    return sizer.run()
