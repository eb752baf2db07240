"""Certified peaks of outputs linear in the modal state, over a move and the settling after it.

For an output y(t) = Q q + V q' + A a (jaxflex._outputs) plus a constant offset (gravity) and
a functional f_g(y) per item g (a cup's utilisation, a point's von Mises stress: convex,
positively homogeneous, and Lipschitz with per-row weights W, |f_g(y + e) - f_g(y)| <=
W_g . |e|), :func:`output_peak` finds max_{t >= 0, g} f_g(y(t)) to within a tolerance, with
where (item) and when:

* the output is evaluated exactly (jaxflex._engine: states at the samples, between them, and
  the free vibration after the move); between two evaluation times a, b of one step the
  value is bounded by max(f(a), f(b)) + W . (b - a)^2 / 8 sup |y''|, with sup |y_j''| <=
  sum_i |Q_ji| sup |q_i''| + |V_ji| sup |q_i'''| (a is linear within a step, so A adds no
  curvature). During the move jaxflex._engine.derivative_bounds bounds |q_i''| and |q_i'''|
  per step (the energy radius r_i = sqrt(q_i'^2 + omega_i^2 q_i^2), which grows at most like
  the modal force |f_i|, or the free vibration about the quasi-static response, whichever is
  smaller);
  after it every mode decays, |q_i^(k)| <= omega_i^k R_i e^{-sigma_i tau};
* after the move f_g(y) <= f_g(offset) + W_g . env(tau) with the decreasing envelope env_j =
  sum_i (|Q_ji| + |V_ji| omega_i) R_i e^{-sigma_i tau}: beyond the horizon where that bound is
  below the best value found, nothing can exceed it;
* intervals whose bound exceeds the best value by more than the tolerance are subdivided
  (16-fold), items whose bound cannot reach it are dropped (branch and bound).

The search makes many small matrix products: BLAS runs on one thread meanwhile (a thread pool
made them ~30x slower on a loaded 2-core machine).

The result is exact in the sense of jaxflex._settle: the reported value is attained, and the
true supremum lies within ``tolerance`` above it (``bound``). :func:`certified_max` is the
generic branch-and-bound search, shared with the minimum distance of jaxflex._collision.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass

import numpy as np
from threadpoolctl import ThreadpoolController

from jaxflex._decay import amplitudes
from jaxflex._engine import (
    derivative_bounds,
    free_states,
    modal_forces,
    modal_states,
    states_between,
)
from jaxflex._profile import Move, acceleration_at, as_move
from jaxflex._settle import SUBDIVISIONS, TIME_TOL_S  # the settle search's refinement

SAMPLES_PER_PERIOD = 16
CHUNK = 256
MAX_EVALUATIONS = 200_000_000  # item-time evaluations before the search reports a bound only


@dataclass(frozen=True)
class Peak:
    """The largest value of a functional found (``value``), attained at ``time_s`` (s from the
    start of the move) by ``item``; the supremum is at most ``bound``."""

    value: float
    time_s: float
    item: int
    bound: float
    evaluations: int

    def as_dict(self) -> dict:
        return asdict(self)


class SearchState:
    """The best value of a branch-and-bound search so far, where and when, and its cost."""

    def __init__(self) -> None:
        self.value, self.time, self.item = -math.inf, math.nan, -1
        self.unresolved = -math.inf  # largest bound left where the time resolution ended
        self.evaluations = 0

    def update(self, values: np.ndarray, times: np.ndarray, items: np.ndarray) -> None:
        if values.size == 0:
            return
        i, j = np.unravel_index(int(np.argmax(values)), values.shape)
        if values[i, j] > self.value:
            self.value, self.time, self.item = float(values[i, j]), float(times[j]), int(items[i])


def certified_max(
    evaluate: Callable[[np.ndarray, np.ndarray], np.ndarray],
    bound: Callable,
    grid: np.ndarray,
    items: np.ndarray,
    tolerance: Callable[[float], float],
    best: SearchState,
) -> None:
    """Branch and bound for max over t in [grid[0], grid[-1]] and ``items`` of g(t).

    ``evaluate(t (T,), items (I,)) -> (I, T)`` exact values; ``bound(a (J,), b (J,), va (I, J),
    vb (I, J), items) -> (I, J)`` upper bounds of g over each interval; ``tolerance(best)``
    the allowed gap. Updates ``best`` in place (module docstring)."""
    if len(items) == 0:
        return
    values = evaluate(grid, items)
    best.evaluations += values.size
    best.update(values, grid, items)
    work = [(grid, items, values)]
    while work:
        t, idx, vals = work.pop()
        upper = bound(t[:-1], t[1:], vals[:, :-1], vals[:, 1:], idx)
        gap = tolerance(best.value)
        suspect = upper > best.value + gap
        order = np.argsort(-np.where(suspect, upper, -np.inf).max(axis=0))
        for j in order[: int(suspect.any(axis=0).sum())][::-1]:
            if upper[suspect[:, j], j].max() <= best.value + tolerance(best.value):
                continue
            if t[j + 1] - t[j] <= TIME_TOL_S or best.evaluations > MAX_EVALUATIONS:
                best.unresolved = max(best.unresolved, float(upper[:, j].max()))
                continue
            sub = np.linspace(t[j], t[j + 1], SUBDIVISIONS + 1)
            sub_idx = idx[suspect[:, j]]
            sub_vals = evaluate(sub, sub_idx)
            best.evaluations += sub_vals.size
            best.update(sub_vals, sub, sub_idx)
            work.append((sub, sub_idx, sub_vals))


_MAGNITUDES: dict = {}  # (kind, id(array)): (weak reference, derived array)
_BLAS: list[ThreadpoolController] = []  # the process's BLAS libraries, looked up once


def one_blas_thread():
    """A context in which BLAS runs on one thread (module docstring): threadpoolctl's limit
    with the libraries looked up once per process (``threadpool_limits`` looks them up on
    every entry, about 1-10 ms, which the many short certificates of a search paid each)."""
    if not _BLAS:
        _BLAS.append(ThreadpoolController())
    return _BLAS[0].limit(limits=1, user_api="blas")


def once_per_array(array: np.ndarray, kind: str, make):
    """``make(array)``, computed once per array and ``kind`` and kept while the array lives
    (data derived from large arrays that many models or certificates share)."""
    key = (kind, id(array))
    entry = _MAGNITUDES.get(key)
    if entry is not None and entry[0]() is array:
        return entry[1]
    found = make(array)
    _MAGNITUDES[key] = (weakref.ref(array), found)
    weakref.finalize(array, _MAGNITUDES.pop, key, None)
    return found


def magnitude(array: np.ndarray) -> np.ndarray:
    """|array|, computed once per array (the output maps' magnitudes, which every bound of
    every certificate of the same outputs takes)."""
    return once_per_array(array, "magnitude", np.abs)


def column_max(array: np.ndarray) -> np.ndarray:
    """(columns,) the largest magnitude of each column of ``array`` (once per array)."""
    return once_per_array(array, "column_max", lambda a: magnitude(a).max(axis=0))


class _Response:
    """The output's pieces for a move: modal states at the samples, forces, per-step bounds.

    ``state_scale`` (q_scale (M,), v_scale (M,)), if given, multiplies each mode's column of
    the maps: y = Q (q_scale q) + V (v_scale q') + A a. A model of a robust grid (frequencies
    scaled by s: Q by s^2, V by s and its damping ratio's change; A and the static response
    unchanged, jaxflex.model.with_frequency_scale) then shares the nominal model's maps,
    which are the large part (rows x modes), instead of copies of them scaled."""

    q_scale: np.ndarray | float = 1.0
    v_scale: np.ndarray | float = 1.0

    def __init__(
        self, model, outputs, functional, move: Move, offset: np.ndarray, state_scale=None
    ) -> None:
        self.model, self.functional = model, functional
        self.q_map, self.v_map = np.asarray(outputs.q_map), np.asarray(outputs.v_map)
        if state_scale is not None:
            self.q_scale, self.v_scale = (np.asarray(x, dtype=np.float64) for x in state_scale)
            if (self.q_scale < 0).any() or (self.v_scale < 0).any():
                raise ValueError("state_scale: the scales of the maps' columns must be >= 0")
        self.a_map = np.asarray(outputs.a_map)
        self.offset = np.asarray(offset, dtype=np.float64)
        self.move, self.dt_s = move, move.dt_s
        self.states = modal_states(model, move.acc, move.dt_s, xp=np)
        self.force = modal_forces(model, move.acc, np)
        self.n_steps = move.n_steps
        self.t_end = move.duration_s
        omega, zeta = np.asarray(model.omega_rad_s), np.asarray(model.zeta)
        self.omega, self.sigma = omega, zeta * omega
        step_force = np.maximum(np.abs(self.force[:-1]), np.abs(self.force[1:]))
        radius = np.hypot(self.states[:-1, :, 1], omega * self.states[:-1, :, 0])
        self.vel = radius + move.dt_s * step_force  # sup |q'| on each step (energy radius)
        _, self.qdd, self.qddd = derivative_bounds(model, self.states, self.force, move.dt_s)
        self.end_state = self.states[-1]  # (M, 2) the free vibration's start
        self.amplitude = amplitudes(model, self.end_state)

    def rows(self, items: np.ndarray) -> np.ndarray | slice:
        """The output rows of ``items`` in order (every row: a slice, no copy)."""
        r = self.functional.rows_per_item
        n = self.functional.n_items
        if n and len(items) == n and items[0] == 0 and np.array_equal(items, np.arange(n)):
            return slice(None)
        return (r * items[:, None] + np.arange(r)).ravel()

    def values(self, states: np.ndarray, acc: np.ndarray, items: np.ndarray) -> np.ndarray:
        """(I, T) functional values of ``items`` for states (T, M, 2), accelerations (T, 3)."""
        rows = self.rows(items)
        y = (
            (states[..., 0] * self.q_scale) @ self.q_map[rows].T
            + (states[..., 1] * self.v_scale) @ self.v_map[rows].T
            + acc @ self.a_map[rows].T
            + self.offset[rows]
        )
        return self.functional.values(y.reshape(len(y), len(items), -1), items).T

    def weighted(self, items: np.ndarray, per_row: np.ndarray) -> np.ndarray:
        """(I, ...) W_g . per_row for per-row bounds ``per_row`` (I r, ...) in the order of
        :meth:`rows`."""
        w = self.functional.weights(items)  # (I, r)
        return np.einsum("ir,ir...->i...", w, per_row.reshape(*w.shape, *per_row.shape[1:]))

    def states_at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(modal states (T, M, 2), accelerations (T, 3)) at times ``t`` (T,) s during the
        move and after it (:meth:`during` and :meth:`after`'s, for any mix of times)."""
        during = t <= self.t_end
        states = np.empty((len(t), self.omega.size, 2))
        acc = np.zeros((len(t), 3))
        if during.any():
            t_in = t[during]
            states[during] = states_between(
                self.model, self.states, self.force, self.dt_s, t_in, np
            )
            acc[during] = acceleration_at(self.move, t_in)
        if not during.all():
            states[~during] = free_states(self.model, self.end_state, t[~during] - self.t_end, np)
        return states, acc

    # -- during the move ----------------------------------------------------------------
    def during(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        states = states_between(self.model, self.states, self.force, self.dt_s, t, np)
        return self.values(states, acceleration_at(self.move, t), items)

    def during_bound(self, a, b, va, vb, items):
        k = np.clip(np.floor(0.5 * (a + b) / self.dt_s).astype(np.int64), 0, self.n_steps - 1)
        rows = self.rows(items)
        curv = (
            magnitude(self.q_map)[rows] @ (self.qdd[k] * self.q_scale).T
            + magnitude(self.v_map)[rows] @ (self.qddd[k] * self.v_scale).T
        )
        return np.maximum(va, vb) + self.weighted(items, curv) * (b - a) ** 2 / 8

    def move_item_bounds(self, items: np.ndarray) -> np.ndarray:
        """(I,) upper bound of each item over the whole move (energy-radius bounds)."""
        vel = self.vel.max(axis=0)
        rows = self.rows(items)
        per_row = (
            magnitude(self.q_map)[rows] @ (vel / self.omega * self.q_scale)
            + magnitude(self.v_map)[rows] @ (vel * self.v_scale)
            + magnitude(self.a_map)[rows] @ np.abs(self.move.acc).max(axis=0)
            + np.abs(self.offset[rows])
        )
        return self.weighted(items, per_row)

    # -- after the move -----------------------------------------------------------------
    def after(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        states = free_states(self.model, self.end_state, t - self.t_end, np)
        return self.values(states, np.zeros((len(t), 3)), items)

    def _tail_rows(self, items: np.ndarray, tau: np.ndarray, power: int) -> np.ndarray:
        """(I r, T) sum_i (|Q_ji| omega_i^p + |V_ji| omega_i^(p+1)) R_i e^{-sigma_i tau}."""
        rows = self.rows(items)
        decay = self.amplitude[:, None] * np.exp(-np.outer(self.sigma, tau))
        q_scale, v_scale = (
            np.broadcast_to(self.q_scale, self.omega.shape),
            np.broadcast_to(self.v_scale, self.omega.shape),
        )
        q_weights = decay * (q_scale * self.omega**power)[:, None]
        v_weights = decay * (v_scale * self.omega ** (power + 1))[:, None]
        return magnitude(self.q_map)[rows] @ q_weights + magnitude(self.v_map)[rows] @ v_weights

    def after_bound(self, a, b, va, vb, items):
        curv = self.weighted(items, self._tail_rows(items, a - self.t_end, 2))
        return np.maximum(va, vb) + curv * (b - a) ** 2 / 8

    def static_values(self, items: np.ndarray) -> np.ndarray:
        """(I,) f(offset) of ``items``: the part at rest after the move (every item's
        computed once per response)."""
        if getattr(self, "_static", None) is None:
            every = np.arange(self.functional.n_items)
            offsets = self.offset[self.rows(every)].reshape(1, len(every), -1)
            self._static = self.functional.values(offsets, every)[0]
        return self._static[items]

    def tail_item_bounds(self, items: np.ndarray, tau: float) -> np.ndarray:
        """(I,) bound of each item from ``tau`` after the move on: f(offset) + W . env."""
        static = self.static_values(items)
        if math.isinf(tau):
            return static
        return static + self.weighted(items, self._tail_rows(items, np.array([tau]), 0))[:, 0]

    def tail_step(self, tolerance: float) -> float:
        """1/16 of the period of the highest mode whose contribution matters (each mode's
        largest share bounded by its column maxima of |Q| and |V|)."""
        share = self.functional.weights(np.arange(self.functional.n_items)).max()
        size = column_max(self.q_map) * self.q_scale + column_max(self.v_map) * (
            self.v_scale * self.omega
        )
        contribution = share * size * self.amplitude
        order = np.argsort(self.omega)[::-1]
        dropped = np.cumsum(contribution[order]) <= 1e-3 * tolerance
        kept = order[~dropped]
        top = self.omega[kept].max() if kept.size else self.omega.min()
        return 2 * np.pi / (SAMPLES_PER_PERIOD * top)


def item_bounds(
    model, outputs, functional, move: Move, *, offset=None, state_scale=None
) -> np.ndarray:
    """(I,) an upper bound of each item of ``functional`` (arguments as :func:`output_peak`)
    over the move and all the settling after it: the energy-radius bound of the move and the
    decay envelope from its end. Cheap (no evaluation of the outputs); an item below a limit
    here cannot reach it."""
    move = as_move(move, at_rest=True)
    offset = np.zeros(outputs.n_rows) if offset is None else offset
    response = _Response(model, outputs, functional, move, offset, state_scale)
    items = np.arange(functional.n_items)
    return np.maximum(response.move_item_bounds(items), response.tail_item_bounds(items, 0.0))


def outputs_above(
    model,
    outputs,
    functional,
    move: Move,
    t_s,
    above: float,
    *,
    offset=None,
    state_scale=None,
    stride: int = 8,
) -> tuple[np.ndarray, np.ndarray]:
    """(items (I,), their values (T, I)): the items of ``functional`` (arguments as
    :func:`output_peak`) whose value may exceed ``above`` at some of the increasing times
    ``t_s`` (T,) s during and after ``move`` (a Move at rest at both ends), with their exact
    values where they may (-inf elsewhere, where the value provably stays at most
    ``above``): the items whose bound over the move and the settling reaches it
    (:func:`item_bounds`), evaluated at every ``stride``-th time (and the end of the move),
    and between two of those only where the curvature bound of the interval (one step of
    the move, or the decay envelope after it) reaches ``above``; of those, the items
    returned are the ones with such an interval (the others provably stay at most
    ``above``: no (T, I) array for them). The values above ``above`` are those of
    evaluating every item at every time."""
    t = np.asarray(t_s, dtype=np.float64)
    offset = np.zeros(outputs.n_rows) if offset is None else offset
    with one_blas_thread():
        response = _Response(model, outputs, functional, move, offset, state_scale)
        every = np.arange(functional.n_items)
        bounds = np.maximum(response.move_item_bounds(every), response.tail_item_bounds(every, 0.0))
        items = every[bounds > above]
        if items.size == 0 or t.size == 0:
            return items, np.full((len(t), len(items)), -np.inf)
        ends = np.searchsorted(t, response.t_end, side="right") - 1
        coarse = np.unique(np.r_[np.arange(0, len(t), stride), len(t) - 1, max(ends, 0)])
        at_coarse = _evaluate(response, t[coarse], items).T  # (C, I)
        a, b = t[coarse[:-1]], t[coarse[1:]]
        va, vb = at_coarse[:-1].T, at_coarse[1:].T
        upper = np.empty_like(va)
        for bound, part in ((response.during_bound, b <= response.t_end),
                            (response.after_bound, b > response.t_end)):  # fmt: skip
            if part.any():
                upper[:, part] = bound(a[part], b[part], va[:, part], vb[:, part], items)
        flagged = upper > above  # (I, C - 1); an interval's bound is >= its ends' values
        keep = flagged.any(axis=1) | (at_coarse > above).any(axis=0)
        values = np.full((len(t), int(keep.sum())), -np.inf)
        values[coarse] = at_coarse[:, keep]
        _fill_between(response, t, coarse, flagged[keep], items[keep], values)
        return items[keep], values


def _fill_between(response: _Response, t, coarse, flagged, items, values) -> None:
    """:func:`outputs_above`'s refinement: ``values`` (T, I) filled at the times strictly
    between the coarse times ``coarse`` where an item's interval bound reaches the threshold
    (``flagged`` (I, C - 1)). The modal states of all those times come from one call (their
    propagators computed once, not once per interval); each interval's flagged items are
    evaluated on its own times, as before."""
    intervals = [j for j in np.flatnonzero(flagged.any(axis=0)) if coarse[j + 1] > coarse[j] + 1]
    if not intervals:
        return
    inside = [np.arange(coarse[j] + 1, coarse[j + 1]) for j in intervals]
    states, acc = response.states_at(t[np.concatenate(inside)])
    start = 0
    for j, times in zip(intervals, inside, strict=True):
        at = slice(start, start + times.size)
        start += times.size
        chosen = np.flatnonzero(flagged[:, j])
        values[np.ix_(times, chosen)] = response.values(states[at], acc[at], items[chosen]).T


def _evaluate(response: _Response, t: np.ndarray, items: np.ndarray) -> np.ndarray:
    """(I, T) the functional of ``items`` at times ``t`` during the move and after it."""
    out = np.empty((len(items), len(t)))
    during = t <= response.t_end
    if during.any():
        out[:, during] = response.during(t[during], items)
    if (~during).any():
        out[:, ~during] = response.after(t[~during], items)
    return out


def output_peak(
    model,
    outputs,
    functional,
    move: Move,
    *,
    offset=None,
    rtol: float = 1e-4,
    atol: float = 0.0,
    limit: float | None = None,
    state_scale=None,
) -> Peak:
    """The largest value of ``functional`` (items of rows of ``outputs``, a
    jaxflex._outputs.LinearOutputs of ``model``) over ``move`` (a jaxflex._profile.Move, at
    rest at both ends) and the settling after it, plus the constant ``offset`` (Y,), to
    within max(rtol * value, atol) (module docstring). With ``limit`` the search
    only decides whether the peak stays below it: where the bound is below the limit it stops
    refining and evaluates only the items whose bound reaches it (the peak reported is then a
    value found, and ``bound`` <= limit certifies); above the limit it locates the peak as
    without one. ``state_scale`` (q_scale (M,), v_scale (M,)): ``model``'s maps are those of
    ``outputs`` with each mode's column scaled (:class:`_Response`; a robust grid's model)."""
    move = as_move(move, at_rest=True)
    offset = np.zeros(outputs.n_rows) if offset is None else offset
    with one_blas_thread():
        response = _Response(model, outputs, functional, move, offset, state_scale)
        return search_peak(response, rtol, atol, limit)


def search_peak(response: _Response, rtol: float, atol: float, limit: float | None) -> Peak:
    """The certified peak of ``response`` (a :class:`_Response` or one with the same
    evaluations and bounds) over the move, the settling and the rest after it, to within
    max(rtol * value, atol), or up to ``limit`` below it (:func:`output_peak`)."""
    best = SearchState()

    def tolerance(value: float) -> float:
        if not math.isfinite(value):
            return math.inf
        gap = max(rtol * abs(value), atol)
        return gap if limit is None else max(gap, limit - value)

    items = np.arange(response.functional.n_items)
    # the limit after the move (the offset: gravity alone) is part of the supremum
    static = response.tail_item_bounds(items, math.inf)
    best.update(static[:, None], np.array([math.inf]), items)
    during = response.move_item_bounds(items)
    grid = response.dt_s * np.arange(response.n_steps + 1)
    # the items in the order of their bound over the move, each chunk searched only for the
    # items whose bound can beat the best value found so far (the first chunk finds it): the
    # same items the branch and bound would drop after evaluating them; with a limit, the
    # items that cannot reach it are never evaluated
    order = np.argsort(-during, kind="stable")
    for chunk in _chunks(order):
        chunk = chunk[during[chunk] > best.value + tolerance(best.value)]
        if chunk.size == 0:
            break
        certified_max(response.during, response.during_bound, grid, chunk, tolerance, best)
    _settling(response, best, tolerance)
    value = best.value
    return Peak(
        value=value,
        time_s=best.time,
        item=best.item,
        bound=max(value + tolerance(value), best.unresolved),
        evaluations=best.evaluations,
    )


def _chunks(items: np.ndarray, size: int = 2048):
    return [items[i : i + size] for i in range(0, len(items), size)]


def settling_windows(
    above: Callable[[float], np.ndarray], sigma: np.ndarray, step_s: float, what: str
) -> Iterator[tuple[float, np.ndarray]]:
    """The windows of the settling still to search: (start, sample times) in s after the
    stop, ``step_s`` apart, CHUNK steps per window, up to the time beyond which ``above(tau)``
    (per item: whether its bound at tau can still beat the best value) is false for every
    item. The horizon is bracketed by doubling from 1 / min(sigma) (decay rates, 1/s) and
    bisected to 1e-6 relative. Nothing if no item is above at the stop."""
    if not above(0.0).any():
        return
    hi = 1.0 / max(sigma.min(), 1e-6) if sigma.size else 1.0
    while above(hi).any():
        hi *= 2.0
        if hi > 1e6:
            raise RuntimeError(f"{what}: the settling does not decay (undamped modes)")
    lo = 0.0
    while hi - lo > max(1e-6, 1e-6 * hi):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if above(mid).any() else (lo, mid)
    start = 0.0
    while start < hi:
        end = min(hi, start + CHUNK * step_s)
        yield start, np.linspace(start, end, max(2, math.ceil((end - start) / step_s) + 1))
        start = end


def _settling(response: _Response, best: SearchState, tolerance) -> None:
    """The part of the search after the move (module docstring): only the items whose bound
    from the stop on can beat the best value found then (the bounds decrease with the time
    after the stop, and the best value only grows)."""
    every = np.arange(response.functional.n_items)
    items = every[response.tail_item_bounds(every, 0.0) > best.value + tolerance(best.value)]

    def above(tau: float) -> np.ndarray:
        return response.tail_item_bounds(items, tau) > best.value + tolerance(best.value)

    sigma = response.sigma[response.amplitude > 0]
    step = response.tail_step(tolerance(best.value))
    for start, times in settling_windows(above, sigma, step, "output_peak"):
        alive = items[above(start)]
        for chunk in _chunks(alive):
            certified_max(
                response.after, response.after_bound, response.t_end + times, chunk, tolerance, best
            )
