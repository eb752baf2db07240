"""Deviation curves on a fine time grid and how far two of them differ (used by fem.sizing).

A move is acceleration samples a_k at t_k = k dt (m/s^2), linear in between. The curves are
evaluated on the same profile sampled ``factor`` times finer (jaxflex.upsample, exact) and
continued at rest; the modal coordinates there are exact (first-order hold), so a curve
differs from the continuous deviation only between its samples. Errors are measured on the
samples: the largest difference relative to the reference peak (L-infinity) and R^2. Settle
times are not taken from the curves but from jaxflex.analyze_move (exact, checked densely).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import jax
import jax.numpy as jnp
import numpy as np

import jaxflex
from jaxflex.model import ModalModel

CHUNK_POINTS = 1024  # points per matrix product when curves run over every node
SAMPLE_BUCKET = 512


@dataclass(frozen=True)
class TimeGrid:
    """Evaluation grid: step dt_s / factor (s) from t = 0; the move has n_move steps of dt_s."""

    acc: np.ndarray  # (n_move + 1, 3) m/s^2
    dt_s: float
    factor: int

    @property
    def step_s(self) -> float:
        return self.dt_s / self.factor

    @property
    def n_move(self) -> int:
        return self.acc.shape[0] - 1

    def samples_until(self, t_end_s: float) -> int:
        """Number of samples covering [0, max(t_end_s, end of the move)]."""
        t_end = max(t_end_s, self.n_move * self.dt_s)
        return math.ceil(t_end / self.step_s - 1e-9) + 1

    def fine_acc(self, n_samples: int) -> np.ndarray:
        """(n_samples, 3) the move on the fine grid (the same piecewise-linear profile, as
        jaxflex.upsample), then at rest."""
        n_fine = self.n_move * self.factor + 1
        if n_samples < n_fine:
            raise ValueError(f"n_samples {n_samples} is shorter than the move ({n_fine})")
        t = np.arange(n_fine) / self.factor  # in steps of dt
        fine = np.column_stack([np.interp(t, np.arange(self.n_move + 1), a) for a in self.acc.T])
        return np.concatenate([fine, np.zeros((n_samples - n_fine, 3))])


def _bucket(n: int) -> int:
    """Size class of n: powers of 4 up to 1024 (cheap to pad), powers of 2 above."""
    power = max(0, (n - 1).bit_length())
    if power < 10:
        power += power % 2
    return 1 << power


def padded(model: ModalModel, n_modes: int = 0) -> ModalModel:
    """The same deviation with K rounded up to a power of two and M to one of at least
    ``n_modes``, so that the jitted part of jaxflex.analyze_move compiles once per size class
    instead of once per candidate: extra points repeat the last point (the maximum over
    points is unchanged), extra modes have zero participation and zero shapes (they stay at
    rest and add nothing)."""
    k, m = model.n_points, model.n_modes
    kb, mb = _bucket(k), _bucket(max(m, n_modes))
    take = np.minimum(np.arange(kb), k - 1)
    shapes = np.zeros((kb, 3, mb))
    shapes[:, :, :m] = np.asarray(model.shapes)[take]
    freq = np.concatenate([model.freq_hz, np.full(mb - m, np.max(model.freq_hz))])
    zeta = np.concatenate([model.zeta, np.full(mb - m, model.zeta[-1])])
    gamma = np.concatenate([model.gamma, np.zeros((mb - m, 3))])
    return ModalModel(freq, zeta, gamma, shapes, np.asarray(model.points)[take])


def analyze(model: ModalModel, grid: TimeGrid, threshold_m: float, n_modes: int = 0):
    """jaxflex.analyze_move of ``model`` for the move of ``grid`` (exact settle time), padded
    to at least ``n_modes`` modes (see :func:`padded`)."""
    return jaxflex.analyze_move(padded(model, n_modes), grid.acc, grid.dt_s, threshold_m)


def bare(model: ModalModel) -> ModalModel:
    """The same model without labels and meta: both are static in the model's pytree, so
    jitted functions (jaxflex.analyze_move) would recompile for every distinct meta."""
    return ModalModel(model.freq_hz, model.zeta, model.gamma, model.shapes, model.points)


@jax.jit
def _states(freq_hz, zeta, gamma, acc, step_s):
    probe = ModalModel(freq_hz, zeta, gamma, jnp.zeros((1, 3, freq_hz.shape[0])), jnp.zeros((1, 3)))
    return jaxflex.modal_states(probe, acc, step_s)[..., 0]


def modal_coordinates(model: ModalModel, grid: TimeGrid, n_samples: int) -> np.ndarray:
    """(n_samples, M) modal coordinates q_i(t) (kg^0.5 m) of ``model`` on ``grid``. The
    horizon is padded to a multiple of SAMPLE_BUCKET samples so that few shapes compile."""
    padded = SAMPLE_BUCKET * math.ceil(n_samples / SAMPLE_BUCKET)
    q = _states(model.freq_hz, model.zeta, model.gamma, grid.fine_acc(padded), grid.step_s)
    return np.asarray(q)[:n_samples]


@dataclass(frozen=True)
class Curves:
    """Deviation over every point (``all``, (T,) m, with the point index ``argmax`` (T,)) and
    over each requested subset of points (``subsets`` (S, T) m)."""

    all: np.ndarray
    argmax: np.ndarray
    subsets: np.ndarray


def deviation_curves(
    shapes: np.ndarray, q: np.ndarray, subsets: Sequence[np.ndarray] = ()
) -> Curves:
    """d(t) = max_p |u_p(t)| with u_p = shapes[p] @ q(t) for all points of ``shapes``
    (K, 3, M) and for each index subset, from modal coordinates ``q`` (T, M)."""
    n_points = shapes.shape[0]
    best = np.full(q.shape[0], -1.0)
    where = np.zeros(q.shape[0], dtype=np.int64)
    masks = []
    for idx in subsets:
        mask = np.zeros(n_points, dtype=bool)
        mask[np.asarray(idx, dtype=np.int64)] = True
        masks.append(mask)
    sub = np.zeros((len(masks), q.shape[0]))
    for start in range(0, n_points, CHUNK_POINTS):
        block = shapes[start : start + CHUNK_POINTS]
        u = (block.reshape(-1, block.shape[2]) @ q.T).reshape(block.shape[0], 3, -1)
        norms = np.sqrt(np.einsum("kdt,kdt->kt", u, u))
        local = np.argmax(norms, axis=0)
        value = norms[local, np.arange(norms.shape[1])]
        better = value > best
        best = np.where(better, value, best)
        where = np.where(better, local + start, where)
        for s, mask in enumerate(masks):
            inside = mask[start : start + block.shape[0]]
            if inside.any():
                sub[s] = np.maximum(sub[s], norms[inside].max(axis=0))
    return Curves(all=best, argmax=where, subsets=sub)


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

    def __init__(self, model: ModalModel, grid: TimeGrid, threshold_m: float, n_modes: int = 0):
        self.model, self.grid, self.threshold_m = model, grid, threshold_m
        self.n_modes = n_modes
        self._band: dict[float, tuple[float, float]] = {}

    @cached_property
    def report(self) -> jaxflex.settle.SettleReport:
        return analyze(self.model, self.grid, self.threshold_m, self.n_modes)

    @property
    def settle_s(self) -> float:
        return self.report.settle_time_s

    @property
    def cycle_s(self) -> float:
        return self.report.cycle_time_s

    def band(self, share: float) -> tuple[float, float]:
        if share not in self._band:
            lo = analyze(self.model, self.grid, self.threshold_m * (1 + share), self.n_modes)
            hi = analyze(self.model, self.grid, self.threshold_m * (1 - share), self.n_modes)
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
