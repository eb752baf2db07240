"""The state of one ``fem.size_model`` run that its stages share (fem.sizing.run).

* :class:`Level`: one mesh of the refinement sequence, its modal analysis with every node as
  a point, its exact settle time and its deviation curves (cached per window);
* :class:`SizingRun`: the checked request (fem.sizing.request), the refinement sequence, the
  computed mode count, the evaluation grid, and the candidate rows and notes every stage adds.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from fem.modal import ModalResult, modal_analysis
from fem.parts import CUP_FINE_FRACTION, Part
from fem.sizing.curves import SettleReference, TimeGrid, modal_coordinates
from fem.sizing.request import SizingRequest
from fem.sizing.residual import TruncationResidual
from fem.sizing.result import Row
from fem.supports import contact_discs
from jaxflex.errors import InputError
from jaxflex.model import ModalModel
from jaxflex.response import deviation_curves

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
SAMPLES_PER_PERIOD = 16  # evaluation grid: 16 samples per period of the GRID_MODE-th mode
GRID_MODE = 10
TAIL_PERIODS = 2.0  # curves are compared up to the later cycle time + 2 first-mode periods


class Level:
    """One mesh of the refinement sequence: modal analysis with every node as a point."""

    def __init__(self, part: Part, supports: list, n_modes: int, options: dict) -> None:
        start = time.perf_counter()
        self.part = part
        # the sizing's own sequence of meshes measures the mesh error: no second analysis
        self.result: ModalResult = modal_analysis(
            part, supports, n_modes=n_modes, error_estimate=False, **options
        )
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
        cup = cup_element_m(self.part, self.result.supports)
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


def cup_element_m(part: Part, supports) -> float | None:
    """Element size inside the contact discs (cups) of ``supports``, m (None: no disc)."""
    discs = contact_discs(supports)
    if not discs:
        return None
    fraction = part.cup_fine_fraction or CUP_FINE_FRACTION[part.element]
    return min(part.element_size_m, fraction * min(d.radius for d in discs))


def refinement_parts(part: Part, mesh_sizes_m, radius_m: float | None) -> list[Part]:
    """The parts of the refinement sequence, coarse to fine, with cup elements of CUP_RATIO x
    the base size (``radius_m``: the smallest cup radius, None without cups; ``mesh_sizes_m``
    the base sizes of fem.sizing.request.Accuracy or None); a part read from a mesh file is
    used as is."""
    if part.mesh_is_given:
        if mesh_sizes_m is not None:
            raise InputError("mesh_sizes_m: a part read from a mesh file is used as is")
        return [part]
    sizes = mesh_sizes_m  # checked by fem.sizing.request.Accuracy: coarse to fine
    if sizes is None:
        sizes = [part.element_size_m * f for f in REFINEMENT[part.element]]
    ratio = CUP_RATIO[part.element]
    return [
        dataclasses.replace(
            part,
            mesh_size_m=h,
            cup_fine_fraction=None if radius_m is None else ratio * h / radius_m,
        )
        for h in sizes
    ]


class SizingRun:
    """What the stages of one sizing share (module docstring)."""

    def __init__(self, request: SizingRequest, log: Callable[[str], None] | None) -> None:
        self.request = request
        self.n_modes = request.accuracy.reference_modes
        self.modal_options = {
            "zeta": request.zeta,
            "allow_rigid_modes": request.allow_rigid_modes,
            "progress": request.progress,
        }
        radii = [d.radius for d in contact_discs(request.supports)]
        sizes = request.accuracy.mesh_sizes_m
        self.parts = refinement_parts(request.part, sizes, min(radii, default=None))
        self.log = log or (lambda text: None)
        self.rows: list[Row] = []
        self.notes: list[str] = []
        self.timings: dict[str, float] = {}
        self.grid: TimeGrid | None = None
        self.bar: Any = None

    def row(self, row: Row) -> None:
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

    def level(self, index: int) -> Level:
        part, r = self.parts[index], self.request
        level = Level(part, r.supports, self.n_modes, self.modal_options)
        if self.grid is None:
            f_grid = level.result.freq_hz[min(GRID_MODE, level.result.n_modes) - 1]
            if r.accuracy.eval_step_s is None:
                factor = math.ceil(r.move.dt_s * SAMPLES_PER_PERIOD * f_grid - 1e-9)
            else:
                factor = math.ceil(r.move.dt_s / r.accuracy.eval_step_s - 1e-9)
            self.grid = TimeGrid(r.move, max(1, factor))
        level.settle = SettleReference(level.model, self.grid, r.threshold_m)
        if not np.isfinite(level.settle.cycle_s):
            raise InputError("zeta: the deviation never settles (undamped modes); give zeta > 0")
        self.log(
            f"[mesh] {level.describe()}: {level.n_dof} DOFs, {level.result.n_modes} modes "
            f"({level.result.freq_hz[0]:.4g}-{level.result.freq_hz[-1]:.4g} Hz), "
            f"{level.model.n_points} nodes, {level.wall_s:.2f} s; settle "
            f"{level.settle.settle_s:.4f} s"
        )
        return level

    def window(self, *levels: Level, cycle_s: float = 0.0) -> int:
        """Samples up to the latest cycle time + TAIL_PERIODS periods of the first mode."""
        t_end = max(cycle_s, *(level.settle.cycle_s for level in levels))
        f1 = min(level.f1_hz for level in levels)
        return self.grid.samples_until(t_end + TAIL_PERIODS / f1)

    def peak(self, level: Level) -> float:
        n = self.window(level)
        peak = float(level.curves(self.grid, n).all.max())
        if peak <= 0:
            raise InputError(
                "acc: the move does not deflect the part (peak deviation 0); a Kirchhoff plate "
                "(flat part) only responds to acceleration along z"
            )
        return peak


@dataclass(frozen=True)
class MeshChoice:
    """Stage 1's answer: the chosen mesh, the reference (the next finer one, or the chosen
    if it is the finest), the reference's estimated error and whether the sequence met the
    mesh share."""

    level: Level
    reference: Level
    estimate: dict[str, Any]
    ok: bool


@dataclass(frozen=True)
class Final:
    """The combined choice (model, point indices, voxel size) and its check against the
    reference: ``err`` (curve_error with the reference's ``peak_m``), ``settle``, ``ok``."""

    model: ModalModel
    idx: np.ndarray
    voxel: float | None
    err: dict
    settle: Any
    ok: bool
