"""Deviation curves on a fine time grid and how far two of them differ (used by fem.sizing.run).

A move is acceleration samples a_k at t_k = k dt (m/s^2), linear in between. The curves are
evaluated on the same profile sampled ``factor`` times finer (jaxflex.response.upsample, exact) and
continued at rest; the modal coordinates there are exact (first-order hold), so a curve
differs from the continuous deviation only between its samples. Errors are measured on the
samples: the largest difference relative to the reference peak (L-infinity) and R^2. Settle
times are not taken from the curves but from jaxflex.analyze_move (exact, checked densely).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from jaxflex.model import ModalModel
from jaxflex.response import Move, SettleReport, analyze_move, modal_states, upsample


@dataclass(frozen=True)
class TimeGrid:
    """Evaluation grid: step dt_s / factor (s) from t = 0; the move (a Move) has n_move steps
    of dt_s."""

    move: Move
    factor: int

    @property
    def step_s(self) -> float:
        return self.move.dt_s / self.factor

    @property
    def n_move(self) -> int:
        return self.move.n_steps

    def samples_until(self, t_end_s: float) -> int:
        """Number of samples covering [0, max(t_end_s, end of the move)]."""
        t_end = max(t_end_s, self.n_move * self.move.dt_s)
        return math.ceil(t_end / self.step_s - 1e-9) + 1

    def fine_acc(self, n_samples: int) -> np.ndarray:
        """(n_samples, 3) the move on the fine grid (the same piecewise-linear profile,
        jaxflex.response.upsample), then at rest."""
        fine = upsample(self.move.acc, self.factor, np)
        if n_samples < fine.shape[0]:
            raise ValueError(f"n_samples {n_samples} is shorter than the move ({fine.shape[0]})")
        return np.concatenate([fine, np.zeros((n_samples - fine.shape[0], 3))])


def modal_coordinates(model: ModalModel, grid: TimeGrid, n_samples: int) -> np.ndarray:
    """(n_samples, M) modal coordinates q_i(t) (kg^0.5 m) of ``model`` on ``grid``: the exact
    recursion (jaxflex._engine, NumPy) over the finely sampled move, then at rest."""
    return modal_states(model, grid.fine_acc(n_samples), grid.step_s, xp=np)[..., 0]


def truncation_curves(shapes: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(M, T): row n - 1 is the deviation of the lowest n modes (by column order of
    ``shapes`` (K, 3, M) and ``q`` (T, M)), built up one mode at a time."""
    u = np.zeros((shapes.shape[0], 3, q.shape[0]))
    out = np.empty((q.shape[1], q.shape[0]))
    for i in range(q.shape[1]):
        u += shapes[:, :, i, None] * q[None, None, :, i]
        out[i] = np.sqrt(np.einsum("kdt,kdt->kt", u, u)).max(axis=0)
    return out


def curve_error(curve: np.ndarray, reference: np.ndarray) -> dict[str, float]:
    """Largest |curve - reference| relative to max(reference) (``linf``) and the coefficient
    of determination ``r2`` of the curve against the reference (both dimensionless)."""
    n = min(curve.shape[-1], reference.shape[-1])
    curve, reference = curve[..., :n], reference[..., :n]
    peak = float(reference.max())
    spread = float(np.sum((reference - reference.mean()) ** 2))
    err = curve - reference
    return {
        "linf": float(np.abs(err).max() / peak),
        "r2": float(1.0 - np.sum(err**2) / spread) if spread > 0 else 1.0,
    }


@dataclass(frozen=True)
class SettleCheck:
    """A settle time (s) judged against a reference: ``ok`` if within ``allowed_s`` of it, or
    inside ``band_s`` (the reference's settle times for thresholds (1 +- share) x threshold)."""

    settle_s: float
    reference_s: float
    allowed_s: float
    band_s: tuple[float, float] | None
    ok: bool

    @property
    def error_s(self) -> float:
        return self.settle_s - self.reference_s

    def describe(self) -> str:
        text = f"{self.settle_s:.4f} s ({1e3 * self.error_s:+.1f} ms"
        if abs(self.error_s) <= self.allowed_s:
            return text + f", allowed +-{1e3 * self.allowed_s:.1f} ms)"
        if self.band_s is not None:
            lo, hi = self.band_s
            inside = "inside" if self.ok else "outside"
            return text + f", {inside} the threshold band {lo:.4f}-{hi:.4f} s)"
        return text + ")"


class SettleReference:
    """Exact settle time of a reference model for a move, and its sensitivity to the
    threshold (computed on demand): the settle times for (1 + s) x and (1 - s) x threshold."""

    def __init__(self, model: ModalModel, grid: TimeGrid, threshold_m: float):
        self.model, self.grid, self.threshold_m = model, grid, threshold_m
        self._band: dict[float, tuple[float, float]] = {}

    @cached_property
    def report(self) -> SettleReport:
        return self._analyze(self.threshold_m)

    @property
    def settle_s(self) -> float:
        return self.report.settle_time_s

    @property
    def cycle_s(self) -> float:
        return self.report.cycle_time_s

    def _analyze(self, threshold_m: float) -> SettleReport:
        return analyze_move(self.model, self.grid.move, threshold_m=threshold_m)

    def band(self, share: float) -> tuple[float, float]:
        if share not in self._band:
            lo = self._analyze(self.threshold_m * (1 + share))
            hi = self._analyze(self.threshold_m * (1 - share))
            self._band[share] = (lo.settle_time_s, hi.settle_time_s)
        return self._band[share]

    def check(self, settle_s: float, share: float) -> SettleCheck:
        """``settle_s`` agrees if within share x the reference cycle time, or if a deviation
        error of share x threshold explains the difference (the settle time jumps by about
        half a period where an oscillation peak touches the threshold)."""
        allowed = share * self.cycle_s
        if abs(settle_s - self.settle_s) <= allowed:
            return SettleCheck(settle_s, self.settle_s, allowed, None, True)
        lo, hi = self.band(share)
        ok = lo - 1e-9 <= settle_s <= hi + 1e-9
        return SettleCheck(settle_s, self.settle_s, allowed, (lo, hi), ok)
