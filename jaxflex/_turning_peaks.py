"""Certified peaks of a turning part's cup loads and stresses, over the move and the settling
(jaxflex._peaks' search for the outputs of jaxflex._turning_outputs).

During the move an output is (jaxflex._turning_outputs, equation (1))

    y(t) = Q q(t) + V q'(t) + A (a_O - g_b)(t) + A_rot b(t),

with q exact between the samples for the sampled forcing (the forcing's first-order hold,
jaxflex._engine.states_between) and a_O - g_b, b linear between them (their first-order hold,
as jaxflex._turning_collision). Within a step A and A_rot therefore add no curvature, and
between two evaluation times a < b of one step a functional f_g (convex, positively
homogeneous, Lipschitz with the row weights W) is bounded as for a straight move:

    f_g(y(t)) <= max(f_g(a), f_g(b)) + W_g . (b - a)^2 / 8 sup |y''|,
    sup |y_j''| <= sum_i |Q_ji| sup |q_i''| + |V_ji| sup |q_i'''|

(jaxflex._engine.derivative_bounds per step, from the turning forces). An item whose bound
over the whole move, W_g . (|Q| sup |q| + |V| sup |q'| + |A| sup |a_O - g_b| + |A_rot| sup
|b|) with the energy-radius bounds of q and q', cannot beat the best value found is not
searched.

After the move the part rests in its final pose (outputs y_rest: its sag and the load of
gravity there) and vibrates freely about it: f_g(y) <= f_g(y_rest) + W_g . env(tau) with
env_j = sum_i (|Q_ji| + |V_ji| omega_i) R_i e^{-sigma_i tau}, and the curvature bound of
jaxflex._peaks between evaluation times.

So the supremum over the whole move and settling is found to within the tolerance, as
jaxflex._peaks.output_peak does for a straight move; the sampled forcing is the model's
definition of the motion (the turning engine's), and the neglected gyroscopic and
spin-softening terms are bounded separately (jaxflex._turning).
"""

from __future__ import annotations

import numpy as np
from threadpoolctl import threadpool_limits

from jaxflex._engine import derivative_bounds, states_between
from jaxflex._peaks import Peak, _Response, search_peak
from jaxflex._profile import samples_at
from jaxflex._rotation_residual import output_residual
from jaxflex._turning import Turn, turning_motion

__all__ = ["TurningLoadSearch", "turning_output_peak"]


class TurningLoadSearch(_Response):
    """The outputs ``outputs`` (a jaxflex._outputs.LinearOutputs of ``model``, with the
    static response ``static_rot`` (Y, 3, 3) to the rotational loads or None) and the
    functional of their items over the turning move ``turn`` (jaxflex._turning.Turn): the
    evaluations and bounds of the certified
    search (module docstring). After the move it is jaxflex._peaks' straight response: the
    free vibration from the deviation about the final pose's sag, plus the outputs at rest
    there as the constant offset."""

    def __init__(self, model, outputs, static_rot, functional, turn: Turn) -> None:
        self.model, self.functional = model, functional
        self.q_map, self.v_map = np.asarray(outputs.q_map), np.asarray(outputs.v_map)
        self.a_map = np.asarray(outputs.a_map)
        self.a_rot = output_residual(outputs, static_rot, model)  # (Y, 9)
        self.dt_s, self.n_steps = turn.dt_s, turn.path.n_steps
        self.t_end = turn.path.n_steps * turn.dt_s
        motion = turning_motion(model, turn)
        self.inputs = inputs = motion.inputs
        gravity = inputs.gravity_body_m_s2
        self.states, self.force = motion.states, motion.force  # (n+1, M, 2), (n+1, M)
        omega = np.asarray(model.omega_rad_s)
        self.omega, self.sigma = omega, np.asarray(model.zeta) * omega
        self.vel, self.qdd, self.qddd = derivative_bounds(model, self.states, self.force, self.dt_s)
        sag = inputs.q[-1] - motion.end_state[:, 0]
        self.end_state = motion.end_state
        self.amplitude = np.hypot(self.end_state[:, 1], omega * self.end_state[:, 0])
        self.offset = sag @ self.q_map.T - gravity[-1] @ self.a_map.T  # (Y,) at rest at B

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
        r = self.functional.rows_per_item
        return self.functional.values(y.reshape(len(y), len(items), r), items).T

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


def turning_output_peak(
    model,
    outputs,
    static_rot,
    functional,
    turn: Turn,
    *,
    rtol: float = 1e-4,
    limit: float | None = None,
) -> Peak:
    """The largest value of ``functional`` (items of rows of ``outputs``, with the static
    response ``static_rot`` to the rotational loads, as :class:`TurningLoadSearch`) over the
    turning move ``turn`` (jaxflex._turning.Turn), the settling after it and the rest in the
    final pose, to within ``rtol`` of the value (module docstring). With ``limit`` (float or
    None) the search only decides whether the peak stays below it (as
    jaxflex._peaks.output_peak): ``bound`` <= limit certifies."""
    with threadpool_limits(limits=1, user_api="blas"):
        search = TurningLoadSearch(model, outputs, static_rot, functional, turn)
        return search_peak(search, rtol, 0.0, limit)
