"""Exact settle time and cycle time.

Definitions (docs/design.md): deviation d(t) = max_p |u_p(t)|, settle time
t_s = sup{t : d(t) > threshold} (0 if never), cycle time T_c = max(n dt_s, t_s).

"Exact" means no peak is missed and the search provably ends:

* After the move (t >= t_n) the base is at rest and every mode is a free damped oscillation
  q_i(tau) = R_i e^{-sigma_i tau} cos(omega_d,i tau - theta_i). Its envelope
  E_p(tau) = sum_i |phi_i(p)| R_i e^{-sigma_i tau} >= |u_p(tau)| decreases, so once
  max_p E_p(tau_env) <= threshold nothing can cross again: tau_env is the proof horizon.
* On [t_n, t_n + tau_env] and during the move, d is sampled from the closed-form response on
  a grid, and each grid interval [a, b] is *certified* below the threshold with the
  interpolation bound  sup |u_p| <= max(|u_p(a)|, |u_p(b)|) + (b - a)^2 / 8 sup |u_p''|,
  where sup |u_p''| <= sum_i |phi_i(p)| sup |q_i''| is bounded in closed form: omega_i^2 R_i
  e^{-sigma_i a} after the move, and, during the move (force f_i linear on the step, so the
  energy radius r_i = sqrt(q_i'^2 + omega_i^2 q_i^2) grows at most like |f_i|),
  max|f_i| + (1 + 2 zeta_i) omega_i (r_i(t_k) + dt_s max|f_i|), or where smaller the bound
  of the free vibration about the quasi-static response (jaxflex._engine.derivative_bounds:
  what keeps stiff modes, whose first bound grows with omega dt, cheap). Intervals that cannot be
  certified are subdivided (16-fold) until they are certified, or an exceedance is found and
  the last crossing is located to 1e-9 s.
* Points are first certified a block at a time (jaxflex._blocks: a block's centre and
  per-mode radius bound all its members, and its curvature bound is the per-mode maximum of
  its members' shape norms); only the points of blocks that cannot be certified are
  evaluated one by one, so an all-node model costs little more than its few blocks near the
  threshold.
The search runs backwards in time and stops at the first (= last in time) exceedance.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from jaxflex._decay import amplitudes, envelope, envelope_horizon
from jaxflex._deviation import (
    block_bounds,
    blocks_of,
    point_norms,
    residual_of,
    response_shapes,
    round_off_slack,
    with_acceleration,
)
from jaxflex._engine import (
    derivative_bounds,
    free_states,
    modal_forces,
    modal_states,
    states_between,
)
from jaxflex._grid import grid_time
from jaxflex._profile import acceleration_at, as_move
from jaxflex._scalars import check_positive
from jaxflex.defaults import THRESHOLD_M
from jaxflex.errors import BudgetError
from jaxflex.model import ModalModel, require_model, shape_cache

SUBDIVISIONS = 16  # sub-intervals per refined interval (also jaxflex._peaks' search)
TIME_TOL_S = 1e-9  # intervals this short are not refined further (s)
# Tail grid step: the curvature term of the certification bound is at most this share of the
# threshold, so intervals whose samples stay below (1 - share) * threshold certify at once.
CURVATURE_SHARE = 0.1
CHUNK_STEPS = 256
# Point-time evaluations before the search gives up (a tangent or undamped response): at
# least MAX_EVALUATIONS, more for models with many points, whose honest cost grows with K.
MAX_EVALUATIONS = 50_000_000
MAX_EVALUATIONS_PER_POINT = 50_000


@dataclass(frozen=True)
class SettleReport:
    """Exact timing of one move. Times in s from the start of the move, deviations in m."""

    transfer_time_s: float
    settle_time_s: float
    cycle_time_s: float
    threshold_m: float
    residual_m: float  # d(t_n): deviation when the robot stops
    proof_horizon_s: float  # t_n + tau_env: beyond it the envelope proves d <= threshold
    evaluations: int  # point-time evaluations of the closed-form response

    def as_dict(self) -> dict:
        return asdict(self)

    def times(self) -> dict[str, float]:
        """Transfer, settle and cycle time (s), the part of the report a move is judged by."""
        return {
            "transfer_time_s": self.transfer_time_s,
            "settle_time_s": self.settle_time_s,
            "cycle_time_s": self.cycle_time_s,
        }


class _SearchBudget:
    """Point-time evaluations a search may spend: at least MAX_EVALUATIONS, more for models
    with many points (MAX_EVALUATIONS_PER_POINT each)."""

    def __init__(self, n_points: int) -> None:
        self.count = 0
        self.n_points = n_points
        self.limit = max(MAX_EVALUATIONS, MAX_EVALUATIONS_PER_POINT * n_points)

    @property
    def samples(self) -> int:
        """Time samples of all points the budget pays for."""
        return self.limit // self.n_points

    def spend(self, n: int) -> None:
        self.count += n
        if self.count > self.limit:
            raise BudgetError(
                f"settle-time search exceeded its evaluation budget ({self.limit:.3g} "
                f"point-time evaluations for {self.n_points} points); the deviation stays "
                "within 1e-9 of the threshold over a long span (undamped or tangent response)"
            )


@dataclass(frozen=True)
class PointLayout:
    """The points of a response as the certified search sees them: ``shapes`` (K, C, M') of
    its coordinates, their norms ``weights`` (K, M'), and the blocks (jaxflex._blocks) as
    NumPy: ``members`` (nB, b) with K for padding, ``centres`` (M', C, nB), ``radius``
    (nB, M'), ``block_weights`` (nB, M') the members' largest norm per coordinate."""

    shapes: np.ndarray
    weights: np.ndarray
    members: np.ndarray
    centres: np.ndarray
    radius: np.ndarray
    block_weights: np.ndarray


def point_layout(shapes: np.ndarray, blocks) -> PointLayout:
    """The :class:`PointLayout` of ``shapes`` (K, C, M') and their jaxflex._blocks.PointBlocks."""
    shapes = np.asarray(shapes)
    weights = np.linalg.norm(shapes, axis=1)
    members = np.asarray(blocks.index)
    padded = np.vstack([weights, np.zeros((1, weights.shape[1]))])
    return PointLayout(
        shapes,
        weights,
        members,
        np.asarray(blocks.centres),
        np.asarray(blocks.radius),
        padded[members].max(axis=1),
    )


def _layout(model: ModalModel, moving: bool = False) -> PointLayout:
    """The :class:`PointLayout` of a model's shapes, cached on it; with ``moving`` those of
    jaxflex._deviation.response_shapes (M' = M + 3 where the model has a static residual)."""
    moving = moving and residual_of(model) is not None
    cache = model.__dict__.setdefault("_moving_blocks", {}) if moving else shape_cache(model)
    key = "settle_layout"
    if key not in cache:
        shapes = response_shapes(model) if moving else np.asarray(model.shapes)
        cache[key] = point_layout(shapes, blocks_of(model, moving=moving))
    return cache[key]


class _ModalSignal:
    """Shared data of the closed-form response: per-point shape norms, the point blocks with
    their bounds, modal constants. Subclasses give the modal coordinates q(t); ``layout``
    (a :class:`PointLayout`) replaces the model's own shapes (a turning part's)."""

    def __init__(
        self, model: ModalModel, moving: bool = False, layout: PointLayout | None = None
    ) -> None:
        self.model = model
        layout = _layout(model, moving) if layout is None else layout
        self.shapes, self.weights = layout.shapes, layout.weights  # (K, C, M'), (K, M')
        self.omega = np.asarray(model.omega_rad_s)
        self.sigma = np.asarray(model.zeta) * self.omega
        self.budget = _SearchBudget(self.weights.shape[0])
        self.members, self.centres = layout.members, layout.centres
        self.radius, self.block_weights = layout.radius, layout.block_weights
        self.slack = round_off_slack(self.shapes.shape[2], self.shapes.shape[1], np.float64)

    def modal(self, t: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def curvature(self, a: np.ndarray, b: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """(P, J) bounds of sup |u''| over the intervals [a_j, b_j] for shape-norm rows
        ``weights`` (P, M) (of points or of blocks)."""
        raise NotImplementedError

    def norms(self, t: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """|u_p| for points idx at times t -> (P, T)."""
        self.budget.spend(idx.size * t.size)
        return point_norms(self.shapes[idx], self.modal(t))

    def block_suspects(self, t: np.ndarray, blocks: np.ndarray, threshold_m: float):
        """(upper (T, nb), suspect (nb, J)): the bound of every member of each of ``blocks`` at
        the times ``t`` (centre plus radius) and whether the block may exceed ``threshold_m``
        inside each grid interval (those bounds at the ends plus the largest members'
        curvature in between); where not, none of its points does."""
        _, upper = block_bounds(self.centres[:, :, blocks], self.radius[blocks], self.modal(t), np)
        upper = self.slack * upper
        h = np.diff(t)
        bound = np.maximum(upper[:-1], upper[1:]).T + (h**2 / 8.0) * self.curvature(
            t[:-1], t[1:], self.block_weights[blocks]
        )
        return upper, bound > threshold_m

    def peak(self, t: float) -> float:
        """max_p |u_p(t)| (m), evaluating only the blocks whose bound reaches the largest
        centre value (an attained value)."""
        when = np.array([t])
        centre, upper = block_bounds(self.centres, self.radius, self.modal(when), np)
        idx = self.points_of(np.flatnonzero(self.slack * upper[0] >= centre.max()))
        return float(self.norms(when, idx).max())

    def points_of(self, blocks: np.ndarray) -> np.ndarray:
        """Sorted indices of the points in ``blocks``."""
        members = self.members[blocks].ravel()
        return np.sort(members[members < self.weights.shape[0]])


class _FreeDecay(_ModalSignal):
    """Free vibration after the move, from modal state x_end (M, 2) at time t0."""

    def __init__(self, model: ModalModel, x_end: np.ndarray, t0: float) -> None:
        super().__init__(model)
        self.x_end, self.t0 = x_end, t0
        self.amplitude = amplitudes(model, x_end)  # R_i

    def modal(self, t: np.ndarray) -> np.ndarray:
        return free_states(self.model, self.x_end, t - self.t0, np)[..., 0]

    def envelope(self, tau: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """E(tau) >= |u(t0 + tau)| for shape-norm rows ``weights`` (P, M): (P, T)."""
        return envelope(weights, self.amplitude, self.sigma, tau)

    def curvature(self, a: np.ndarray, b: np.ndarray, weights: np.ndarray) -> np.ndarray:
        decay = np.exp(-np.outer(self.sigma, a - self.t0))
        return weights @ ((self.omega**2 * self.amplitude)[:, None] * decay)


class _ForcedMotion(_ModalSignal):
    """Response during the move from the exact states at the samples (FOH in between), with
    the static residual's share D a(t) (the coordinates of
    jaxflex._deviation.with_acceleration: a is linear within a step, so it adds no curvature
    there)."""

    def __init__(self, model: ModalModel, move, states: np.ndarray, force: np.ndarray, layout=None):
        super().__init__(model, moving=True, layout=layout)
        self.move = move
        self.states, self.force, self.dt_s = states, force, move.dt_s
        self.n_steps = states.shape[0] - 1
        _, acc_bound, _ = derivative_bounds(model, states, force, move.dt_s)  # (n, M): sup |q_i''|
        extra = self.shapes.shape[2] - acc_bound.shape[1]
        self.acc_bound = np.pad(acc_bound, ((0, 0), (0, extra)))  # (n, M')

    def modal(self, t: np.ndarray) -> np.ndarray:
        q = states_between(self.model, self.states, self.force, self.dt_s, t, np)[..., 0]
        return self.coordinates(q, t)

    def coordinates(self, q: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The coordinates of the layout's shapes for the modal q (T, M) at times t (T,):
        here q and the acceleration a(t) of the static residual (linear within a step, so
        that they add no curvature; a subclass may add others that are linear too)."""
        return with_acceleration(self.model, q, acceleration_at(self.move, t))

    def curvature(self, a: np.ndarray, b: np.ndarray, weights: np.ndarray) -> np.ndarray:
        k = np.clip(np.floor(0.5 * (a + b) / self.dt_s).astype(np.int64), 0, self.n_steps - 1)
        return weights @ self.acc_bound[k].T


def _last_exceedance(signal, idx, t, norms, threshold_m) -> float | None:
    """sup{s in [t[0], t[-1]] : max_p |u_p(s)| > threshold} over points ``idx`` (all other
    points are known to stay below on this span), or None if there is none.

    ``t`` is an increasing grid and ``norms`` (P, T) the exact |u_p| on it.
    """
    h = np.diff(t)
    over = norms.max(axis=0) > threshold_m
    bound = np.maximum(norms[:, :-1], norms[:, 1:]) + (h**2 / 8.0) * signal.curvature(
        t[:-1], t[1:], signal.weights[idx]
    )
    suspect = bound > threshold_m  # (P, J): point may exceed inside interval j
    for j in np.flatnonzero(suspect.any(axis=0))[::-1]:
        if over[j + 1]:
            return float(t[j + 1])
        if h[j] <= TIME_TOL_S:
            if over[j]:
                return float(t[j + 1])
            continue  # exceeds by at most (1e-9 s)^2 / 8 * curvature: below resolution
        sub = np.linspace(t[j], t[j + 1], SUBDIVISIONS + 1)
        sub_idx = idx[suspect[:, j]]
        found = _last_exceedance(signal, sub_idx, sub, signal.norms(sub, sub_idx), threshold_m)
        if found is not None:
            return found
    return None


def _last_exceedance_in_blocks(signal, blocks, t, threshold_m) -> float | None:
    """:func:`_last_exceedance` over the points of ``blocks`` (all others stay below on this
    span) on the grid ``t``: intervals are first certified a block at a time, and only the
    points of blocks that stay suspect are evaluated, on those intervals only."""
    _, suspect = signal.block_suspects(t, blocks, threshold_m)  # (nb, J)
    for j in np.flatnonzero(suspect.any(axis=0))[::-1]:
        idx = signal.points_of(blocks[suspect[:, j]])
        ends = t[j : j + 2]
        found = _last_exceedance(signal, idx, ends, signal.norms(ends, idx), threshold_m)
        if found is not None:
            return found
    return None


def _tail_grid_spans(decay: _FreeDecay, horizon: float, threshold_m: float):
    """The grid over [0, horizon] (tau) as spans (start, end, intervals), the step adapted to
    the decaying curvature bound. Only the spans are planned here (three numbers per 256
    intervals); BudgetError as soon as they need more time samples than the evaluation budget
    pays for, before any response is evaluated."""
    spans = []
    tau, total = 0.0, 0
    while tau < horizon:
        curvature = decay.curvature(np.array([decay.t0 + tau]), None, decay.block_weights).max()
        step = (
            math.sqrt(8.0 * CURVATURE_SHARE * threshold_m / curvature) if curvature > 0 else horizon
        )
        n = max(1, min(CHUNK_STEPS, math.ceil((horizon - tau) / step)))
        total += n
        if total > decay.budget.samples:
            raise BudgetError(_tail_budget_message(decay, horizon, threshold_m))
        end = min(horizon, tau + n * step)
        spans.append((tau, end, n))
        tau = end
    return spans


def _tail_budget_message(decay: _FreeDecay, horizon: float, threshold_m: float) -> str:
    """What the free decay's grid needs (a closed-form upper bound: with sqrt(sum) <= sum of
    sqrt, the integral of 1 / step over the horizon, mode by mode) against the budget."""
    top = decay.weights.max(axis=0) * decay.amplitude  # (M,) largest amplitude at a point, m
    rate = np.maximum(decay.sigma, 1.0 / horizon)
    samples = np.sum(decay.omega * np.sqrt(top) * 2.0 / rate * (1 - np.exp(-rate * horizon / 2)))
    samples /= math.sqrt(8.0 * CURVATURE_SHARE * threshold_m)
    return (
        f"settle-time search: the vibration after the move starts at up to {top.sum():.3g} m, "
        f"{top.sum() / threshold_m:.3g} times the threshold {threshold_m:.3g} m, and takes "
        f"{horizon:.4g} s to decay below it; certifying that needs up to ~{samples:.3g} time "
        f"samples of {decay.budget.n_points} points, more than the budget of "
        f"{decay.budget.samples:.3g} ({decay.budget.limit:.3g} point-time evaluations). Raise "
        "the threshold (--threshold) or check the model's participation factors and shapes"
    )


def _tail_settle(decay: _FreeDecay, threshold_m: float) -> tuple[float | None, float]:
    """(last exceedance time after the move or None, proof horizon tau_env) in s from t0."""
    horizon = envelope_horizon(
        decay.weights,
        decay.amplitude,
        decay.sigma,
        threshold_m,
        (decay.members, decay.block_weights),
    )
    if horizon == 0.0:
        return None, 0.0
    if math.isinf(horizon):
        return math.inf, math.inf
    for start, end, n in reversed(_tail_grid_spans(decay, horizon, threshold_m)):
        grid = np.linspace(start, end, n + 1)
        blocks = np.flatnonzero(decay.envelope(grid[:1], decay.block_weights)[:, 0] > threshold_m)
        if blocks.size == 0:
            continue
        found = _last_exceedance_in_blocks(decay, blocks, decay.t0 + grid, threshold_m)
        if found is not None:
            return found - decay.t0, horizon
    return None, horizon


def _prepare(model: ModalModel, acc, dt_s, threshold_m):
    require_model(model)
    move = as_move(acc, dt_s, at_rest=True)
    threshold_m = check_positive("threshold_m", threshold_m)
    states = modal_states(model, move.acc, move.dt_s, xp=np)
    return move, states, modal_forces(model, move.acc, np), threshold_m


def analyze_move(
    model: ModalModel,
    acc,
    dt_s: float | None = None,
    threshold_m: float = THRESHOLD_M,
    *,
    settle: bool = True,
) -> SettleReport:
    """Exact transfer, settle and cycle time of a :class:`~jaxflex._profile.Move` (or of raw
    samples ``acc`` ((n+1, 3) m/s^2) at step ``dt_s`` s; a_0 = a_n = 0) against
    ``threshold_m`` (m). With ``settle=False`` the search during
    the move is skipped (the cycle time does not need it) and settle_time_s is only exact if
    it lies after the move; otherwise it is reported as the transfer time."""
    move, states, force, threshold_m = _prepare(model, acc, dt_s, threshold_m)
    dt_s = move.dt_s
    n_steps = states.shape[0] - 1
    t_n = grid_time(n_steps, dt_s)
    decay = _FreeDecay(model, states[-1], t_n)
    tail, horizon = _tail_settle(decay, threshold_m)
    evaluations = decay.budget.count
    residual = decay.peak(t_n)
    if tail is not None:
        settle_s = t_n + tail
    elif settle:
        motion = _ForcedMotion(model, move, states, force)
        grid = dt_s * np.arange(n_steps + 1)
        all_blocks = np.arange(motion.members.shape[0])
        found = _last_exceedance_in_blocks(motion, all_blocks, grid, threshold_m)
        settle_s = 0.0 if found is None else found
        evaluations += motion.budget.count
    else:
        settle_s = t_n
    return SettleReport(
        transfer_time_s=t_n,
        settle_time_s=settle_s,
        cycle_time_s=max(t_n, settle_s),
        threshold_m=threshold_m,
        residual_m=residual,
        proof_horizon_s=float(t_n + horizon),
        evaluations=evaluations,
    )


def settle_after(
    model: ModalModel, x_end, t_end_s: float, threshold_m: float, during=None
) -> SettleReport:
    """Exact settle and cycle time of a move that ends at ``t_end_s`` (s) in the modal
    deviation state ``x_end`` (M, 2) and leaves the model's free vibration after it (a
    turning move: jaxflex._turning). After the move the search is the one of
    :func:`analyze_move` (certified); a settling inside the move is searched the same way on
    ``during`` (a :class:`_ForcedMotion` of the move from t = 0, its steps ending at
    ``t_end_s``: the last crossing to TIME_TOL_S, never before it), or reported as 0 without
    it (the cycle time does not depend on it)."""
    threshold_m = check_positive("threshold_m", threshold_m)
    decay = _FreeDecay(model, np.asarray(x_end, dtype=np.float64), t_end_s)
    tail, horizon = _tail_settle(decay, threshold_m)
    evaluations = decay.budget.count
    if tail is not None:
        settle_s = t_end_s + tail
    elif during is None:
        settle_s = 0.0
    else:
        grid = during.dt_s * np.arange(during.n_steps + 1)
        all_blocks = np.arange(during.members.shape[0])
        found = _last_exceedance_in_blocks(during, all_blocks, grid, threshold_m)
        settle_s = 0.0 if found is None else found
        evaluations += during.budget.count
    return SettleReport(
        transfer_time_s=t_end_s,
        settle_time_s=settle_s,
        cycle_time_s=max(t_end_s, settle_s),
        threshold_m=threshold_m,
        residual_m=decay.peak(t_end_s),
        proof_horizon_s=float(t_end_s + horizon),
        evaluations=evaluations,
    )


def cycle_time(
    model: ModalModel, acc, dt_s: float | None = None, threshold_m: float = THRESHOLD_M
) -> float:
    """Exact cycle time max(n dt_s, t_s) in s of a Move (or of ``acc`` at step ``dt_s`` s;
    see module docstring); inf if undamped modes keep the deviation above ``threshold_m`` (m)
    forever."""
    return analyze_move(model, acc, dt_s, threshold_m, settle=False).cycle_time_s
