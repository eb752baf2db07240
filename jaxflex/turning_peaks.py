"""Certified peaks of a turning part's cup loads and stresses, over the move and the settling
(jaxflex.peaks' search for the outputs of jaxflex.turning_outputs).

During the move an output is (jaxflex.turning_outputs, equation (1))

    y(t) = Q q(t) + V q'(t) + A (a_O - g_b)(t) + A_rot b(t),

with q exact between the samples for the sampled forcing (the forcing's first-order hold,
jaxflex.engine.states_between) and a_O - g_b, b linear between them (their first-order hold,
as jaxflex.turning_collision). Within a step A and A_rot therefore add no curvature, and
between two evaluation times a < b of one step a functional f_g (convex, positively
homogeneous, Lipschitz with the row weights W) is bounded as for a straight move:

    f_g(y(t)) <= max(f_g(a), f_g(b)) + W_g . (b - a)^2 / 8 sup |y''|,
    sup |y_j''| <= sum_i |Q_ji| sup |q_i''| + |V_ji| sup |q_i'''|

(jaxflex.engine.derivative_bounds per step, from the turning forces). An item whose bound
over the whole move, W_g . (|Q| sup |q| + |V| sup |q'| + |A| sup |a_O - g_b| + |A_rot| sup
|b|) with the energy-radius bounds of q and q', cannot beat the best value found is not
searched.

After the move the part rests in its final pose (outputs y_rest: its sag and the load of
gravity there) and vibrates freely about it: f_g(y) <= f_g(y_rest) + W_g . env(tau) with
env_j = sum_i (|Q_ji| + |V_ji| omega_i) R_i e^{-sigma_i tau}, and the curvature bound of
jaxflex.peaks between evaluation times.

So the supremum over the whole move and settling is found to within the tolerance, as
jaxflex.peaks.output_peak does for a straight move; the sampled forcing is the model's
definition of the motion (the turning engine's), and the neglected gyroscopic and
spin-softening terms are bounded separately (jaxflex.turning).
"""

from __future__ import annotations

import math

import numpy as np
from threadpoolctl import threadpool_limits

from jaxflex.engine import derivative_bounds, free_states, states_between
from jaxflex.peaks import Peak, SearchState, certified_max, settling_windows
from jaxflex.pose import PosePath
from jaxflex.profile import samples_at
from jaxflex.rotation_residual import output_residual
from jaxflex.turning import GRAVITY_M_S2, turning_forces, turning_inputs

__all__ = ["TurningLoadSearch", "turning_output_peak"]

SAMPLES_PER_PERIOD = 16  # the settling's first grid: 1/16 of the shortest period
CHUNK_ITEMS = 2048


class TurningLoadSearch:
    """The outputs ``outputs`` (a jaxflex.outputs.LinearOutputs of ``model``, with the
    static response ``static_rot`` (Y, 3, 3) to the rotational loads or None) and the
    functional of their items over the turning ``path`` while the pivot moves with the world
    accelerations ``acc`` ((n+1, 3) m/s^2): the evaluations and bounds of the certified
    search (module docstring)."""

    def __init__(self, model, outputs, static_rot, functional, path: PosePath, acc,
                 gravity_m_s2=GRAVITY_M_S2, pivot_m=(0.0, 0.0, 0.0)) -> None:  # fmt: skip
        self.model, self.functional = model, functional
        self.q_map, self.v_map = np.asarray(outputs.q_map), np.asarray(outputs.v_map)
        self.a_map = np.asarray(outputs.a_map)
        self.a_rot = output_residual(outputs, static_rot, model)  # (Y, 9)
        self.dt_s, self.n_steps = path.dt_s, path.n_steps
        self.t_end = path.n_steps * path.dt_s
        inputs = turning_inputs(model, path, acc, gravity_m_s2=gravity_m_s2, pivot_m=pivot_m)
        self.inputs = inputs
        gravity = inputs.gravity_body_m_s2
        self.states = np.stack([inputs.q, inputs.qd], axis=-1)  # (n+1, M, 2)
        self.force = turning_forces(model, path, inputs.base + gravity, gravity)
        omega = np.asarray(model.omega_rad_s)
        self.omega, self.sigma = omega, np.asarray(model.zeta) * omega
        self.vel, self.qdd, self.qddd = derivative_bounds(model, self.states, self.force, self.dt_s)
        sag = (gravity[-1] @ np.asarray(model.gamma).T) / omega**2
        self.end_deviation = np.stack([inputs.q[-1] - sag, inputs.qd[-1]], axis=-1)
        self.amplitude = np.hypot(self.end_deviation[:, 1], omega * self.end_deviation[:, 0])
        self.rest = sag @ self.q_map.T - gravity[-1] @ self.a_map.T  # (Y,) at rest at B

    # -- items and rows --------------------------------------------------------------------
    def rows(self, items: np.ndarray) -> np.ndarray:
        r = self.functional.rows_per_item
        return (r * items[:, None] + np.arange(r)).ravel()

    def _values(self, y: np.ndarray, items: np.ndarray) -> np.ndarray:
        """(I, T) the functional of ``items`` for their rows' outputs ``y`` (T, I r)."""
        r = self.functional.rows_per_item
        return self.functional.values(y.reshape(len(y), len(items), r), items).T

    def weighted(self, items: np.ndarray, per_row: np.ndarray) -> np.ndarray:
        """(I, ...) W_g . per_row for per-row bounds (I r, ...) in the order of :meth:`rows`."""
        w = self.functional.weights(items)
        return np.einsum("ir,ir...->i...", w, per_row.reshape(*w.shape, *per_row.shape[1:]))

    # -- during the move -------------------------------------------------------------------
    def during(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        """(I, T) the functional at times ``t`` (T,) s within the move."""
        rows = self.rows(items)
        states = states_between(self.model, self.states, self.force, self.dt_s, t, np)
        base = samples_at(self.inputs.base, self.dt_s, t)
        coefficients = samples_at(self.inputs.coefficients, self.dt_s, t)
        y = (
            states[..., 0] @ self.q_map[rows].T
            + states[..., 1] @ self.v_map[rows].T
            + base @ self.a_map[rows].T
            + coefficients @ self.a_rot[rows].T
        )
        return self._values(y, items)

    def during_bound(self, a, b, va, vb, items):
        """(I, J) bounds over the intervals [a, b] (J,) of one step each (module docstring)."""
        k = np.clip(np.floor(0.5 * (a + b) / self.dt_s).astype(np.int64), 0, self.n_steps - 1)
        rows = self.rows(items)
        curv = np.abs(self.q_map[rows]) @ self.qdd[k].T + np.abs(self.v_map[rows]) @ self.qddd[k].T
        return np.maximum(va, vb) + self.weighted(items, curv) * (b - a) ** 2 / 8

    def move_item_bounds(self, items: np.ndarray) -> np.ndarray:
        """(I,) each item's bound over the whole move (module docstring). Cheap."""
        rows = self.rows(items)
        vel = self.vel.max(axis=0)
        per_row = (
            np.abs(self.q_map[rows]) @ (vel / self.omega)
            + np.abs(self.v_map[rows]) @ vel
            + np.abs(self.a_map[rows]) @ np.abs(self.inputs.base).max(axis=0)
            + np.abs(self.a_rot[rows]) @ np.abs(self.inputs.coefficients).max(axis=0)
        )
        return self.weighted(items, per_row)

    # -- after the move --------------------------------------------------------------------
    def after(self, t: np.ndarray, items: np.ndarray) -> np.ndarray:
        """(I, T) the functional at times ``t`` (T,) s from the start, after the move."""
        rows = self.rows(items)
        p = free_states(self.model, self.end_deviation, t - self.t_end, np)
        y = p[..., 0] @ self.q_map[rows].T + p[..., 1] @ self.v_map[rows].T + self.rest[rows]
        return self._values(y, items)

    def _tail_rows(self, items: np.ndarray, tau: np.ndarray, power: int) -> np.ndarray:
        """(I, T) W_g . sum_i (|Q_ji| omega_i^p + |V_ji| omega_i^(p+1)) R_i e^{-sigma_i tau}."""
        rows = self.rows(items)
        decay = self.amplitude[:, None] * np.exp(-np.outer(self.sigma, tau))
        per_row = (np.abs(self.q_map[rows]) * self.omega**power) @ decay + (
            np.abs(self.v_map[rows]) * self.omega ** (power + 1)
        ) @ decay
        return self.weighted(items, per_row)

    def after_bound(self, a, b, va, vb, items):
        curvature = self._tail_rows(items, a - self.t_end, 2)
        return np.maximum(va, vb) + curvature * (b - a) ** 2 / 8

    def at_rest(self, items: np.ndarray) -> np.ndarray:
        """(I,) the functional at rest in the final pose."""
        return self._values(self.rest[self.rows(items)][None], items)[:, 0]

    # -- the search ------------------------------------------------------------------------
    def search(self, best: SearchState, tolerance) -> None:
        """Update ``best`` with the supremum over the move, the settling and the rest in the
        final pose, to within ``tolerance(best value)``."""
        items = np.arange(self.functional.n_items)
        best.update(self.at_rest(items)[:, None], np.array([math.inf]), items)
        grid = self.dt_s * np.arange(self.n_steps + 1)
        with threadpool_limits(limits=1, user_api="blas"):
            for chunk in _chunks(items):
                values = self.during(grid, chunk)
                best.evaluations += values.size
                best.update(values, grid, chunk)
            keep = items[self.move_item_bounds(items) > best.value + tolerance(best.value)]
            for chunk in _chunks(keep):
                certified_max(self.during, self.during_bound, grid, chunk, tolerance, best)
            self._settling(best, tolerance)

    def _settling(self, best: SearchState, tolerance) -> None:
        items = np.arange(self.functional.n_items)
        static = self.at_rest(items)

        def above(tau: float) -> np.ndarray:
            bound = static + self._tail_rows(items, np.array([tau]), 0)[:, 0]
            return bound > best.value + tolerance(best.value)

        step = 2 * np.pi / (SAMPLES_PER_PERIOD * self.omega.max())
        live = self.sigma[self.amplitude > 0]
        for start, times in settling_windows(above, live, step, "turning loads"):
            for chunk in _chunks(items[above(start)]):
                certified_max(
                    self.after, self.after_bound, self.t_end + times, chunk, tolerance, best
                )


def _chunks(items: np.ndarray) -> list[np.ndarray]:
    return [items[i : i + CHUNK_ITEMS] for i in range(0, len(items), CHUNK_ITEMS)]


def turning_output_peak(
    model,
    outputs,
    static_rot,
    functional,
    path: PosePath,
    acc,
    *,
    gravity_m_s2=GRAVITY_M_S2,
    pivot_m=(0.0, 0.0, 0.0),
    rtol: float = 1e-4,
    limit: float | None = None,
) -> Peak:
    """The largest value of ``functional`` (items of rows of ``outputs``, with the static
    response ``static_rot`` to the rotational loads, as :class:`TurningLoadSearch`) over the
    turning move (``path``, world accelerations ``acc`` (n+1, 3) m/s^2 of the pivot
    ``pivot_m``, gravity ``gravity_m_s2`` world), the settling after it and the rest in the
    final pose, to within ``rtol`` of the value (module docstring). With ``limit`` the
    search only decides whether the peak stays below it (as jaxflex.peaks.output_peak):
    ``bound`` <= limit certifies."""
    response = TurningLoadSearch(
        model, outputs, static_rot, functional, path, acc, gravity_m_s2, pivot_m
    )

    def tolerance(value: float) -> float:
        if not math.isfinite(value):
            return math.inf
        gap = rtol * abs(value)
        return gap if limit is None else max(gap, limit - value)

    best = SearchState()
    response.search(best, tolerance)
    value = best.value
    return Peak(
        value=value,
        time_s=best.time,
        item=best.item,
        bound=max(value + tolerance(value), best.unresolved),
        evaluations=best.evaluations,
    )
