"""The cell's constraints of a move that turns the part (optim.turn), as LP rows.

For a FIXED turn schedule (optim.turn.TurnSchedule: the angular acceleration samples of an
n-step move) every quantity of the turning engine is affine in the translation samples a
(jaxflex._turning: the translation enters as R_k^T a_k, the Euler, centrifugal and turned-
gravity loads and the start's sag do not depend on a). At any time t during the move
(between the samples k and k+1, w = t / dt - k) and after it (the part at rest in its
final pose, vibrating freely about its sag there; the [..] terms are then 0):

* an output (cup reactions, stresses; jaxflex._turning_outputs, equation (1)) is
  y(t) = y_0(t) + Q X_q(t) a + V X_v(t) a + A [(1 - w) R_k^T a_k + w R_k+1^T a_k+1], with
  X(t) the straight move's state map (jaxflex.response.state_maps_at) of the turned samples
  R_j^T a_j;
* a point's position (jaxflex._turning_collision, equation (1)) is
  X_p(t) = X_p,0(t) + W(t) a + R(t) (Phi_p X_q(t) a + D_p [(1 - w) R_k^T a_k + ...]),
  W the exact position weights of the pivot's path (jaxflex.response.position_weights).

So the rows of optim.cell_rows carry over unchanged: a convex positively homogeneous load
functional's supporting plane at a violating (time, item) is an exact cut (it never cuts off
a move that meets the limit, for this schedule), and the plane separating a point from a
convex obstacle piece is a restriction (sequential convex programming, as for a straight
move). The constant parts y_0, X_0 come out of the evaluation of the current move (the
cut's value at the current samples minus its linear part), so no second simulation runs.

The turning engine samples its forcing at the move's samples; between them the modal state
is exact for that forcing and the loads' inputs are linear (jaxflex._turning_collision's
definition). The families scan every dt / 8 during the move and, after it, every 1/16 of
the shortest period for two periods of the longest. A move is then checked:

* **distance**: certified by jaxflex.geometry.turning_min_distance (branch and
  bound over the move and the whole settling, every point, both skins);
* **cups and stress**: certified by jaxflex.response.turning_output_peak (branch and
  bound over the move, the settling and the rest in the final pose, every item).

Which turn a family evaluates is the :class:`TurnSource`'s: the search's active schedule of
an n-step move, or, while :meth:`TurnSource.holding` a fixed one, a baseline's or the
chosen move's.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
from threadpoolctl import threadpool_limits

from jaxflex.geometry import distances, rotations_between, turning_min_distance
from jaxflex.response import (
    CupUtilisation,
    Move,
    Peak,
    Turn,
    TurningInputs,
    VonMises,
    free_states,
    kinematics_at,
    output_residual,
    position_weights,
    response_shapes,
    samples_at,
    state_maps_at,
    states_between,
    turning_coordinates,
    turning_forces,
    turning_inputs,
    turning_output_peak,
    turning_shapes,
)
from optim.cell_rows import (
    BOUND_RTOL,
    ITEM_BLOCK,
    ROW_MARGIN,
    SCAN_RTOL,
    SUBSTEPS,
    TAIL_PERIODS,
    DistanceFamily,
    LoadFamily,
    Row,
    _local_peaks,
    _worst_samples,
    certified_distance,
)

TAIL_SAMPLES_PER_PERIOD = 16


class TurnSource:
    """The turn (an optim.turn.TurnSpec) the cell families of a turning move evaluate: the
    search's schedule (``schedule``, an optim.turn.TurnSchedule, set once the search's
    problem exists) or, inside :meth:`holding`, fixed samples."""

    def __init__(self, spec) -> None:
        self.spec = spec
        self.schedule = None
        self._fixed: np.ndarray | None = None

    def angular_acc(self, n_steps: int) -> np.ndarray:
        """(n+1,) rad/s^2 of the turn of an n-step move (padded with zeros to it)."""
        alpha = self._fixed if self._fixed is not None else self.schedule.angular_acc(n_steps)
        alpha = np.asarray(alpha, dtype=np.float64)
        return np.concatenate([alpha, np.zeros(n_steps + 1 - alpha.size)])

    def turn(self, move: Move) -> Turn:
        """The core's turning move (jaxflex.response.Turn) of the translation ``move`` (a
        Move) with the turn of its length (optim.turn.TurnSpec.with_move)."""
        return self.spec.with_move(self.angular_acc(move.n_steps), move)

    def motion(self, model, move: Move, during, tau) -> TurnMotion:
        """The :class:`TurnMotion` of ``model`` for the translation ``move`` (a Move) with the
        turn of its length, at the times ``during`` the move (s from its start) and ``tau``
        after it (s from its end)."""
        return TurnMotion(model, self.turn(move), during, tau)

    @contextmanager
    def holding(self, angular_acc) -> Iterator[None]:
        """Evaluate the families with the turn ``angular_acc`` (n+1,) rad/s^2 meanwhile
        (None: the search's schedule)."""
        if angular_acc is None:  # the search's schedule
            yield
            return
        previous, self._fixed = self._fixed, np.asarray(angular_acc, dtype=np.float64)
        try:
            yield
        finally:
            self._fixed = previous


def tail_times(model, step_s: float | None = None, until_s: float | None = None) -> np.ndarray:
    """(T,) s after the stop: every 1/16 of the shortest period (or ``step_s``) for two
    periods of the longest (or up to ``until_s``)."""
    freq = np.asarray(model.freq_hz)
    step = 1.0 / (TAIL_SAMPLES_PER_PERIOD * freq.max()) if step_s is None else step_s
    until = TAIL_PERIODS / freq.min() if until_s is None else until_s
    return step * np.arange(1, int(np.ceil(until / step)) + 1)


def rest_at_end(model, spec, distance_m) -> np.ndarray:
    """(K, 3) the points of ``model`` at rest after the turning move of ``spec`` (an
    optim.turn.TurnSpec) whose pivot moved by ``distance_m`` (3,): turned about the pivot,
    sagging under gravity in the final pose."""
    pivot = np.asarray(spec.pivot_m, dtype=np.float64)
    rotation = spec.end_rotation
    sag = model.static_displacement(-spec.rest_gravities()[1])
    local = np.asarray(model.points) - pivot + sag
    return pivot + np.asarray(distance_m) + local @ rotation.T


def move_times(n_steps: int, dt_s: float) -> np.ndarray:
    """(n SUBSTEPS + 1,) s: every dt / SUBSTEPS over an n-step move."""
    return dt_s / SUBSTEPS * np.arange(n_steps * SUBSTEPS + 1)


class TurnMotion:
    """The turning move ``turn`` (a jaxflex.response.Turn) of ``model`` at the times
    ``during`` (within the move, s) and ``tau`` (T,) s after the stop: the inputs of the
    turning outputs (jaxflex.response.TurningInputs; between samples the modal state exact
    for the sampled forcing, the loads' inputs linear, as jaxflex._turning_collision), the
    orientation and the pivot's path."""

    def __init__(self, model, turn: Turn, during, tau) -> None:
        self.model, self.turn, self.dt_s = model, turn, turn.dt_s
        self.acc, self.path, dt_s = turn.acc, turn.path, turn.dt_s
        self.n_steps, self.t_end = turn.path.n_steps, turn.path.n_steps * dt_s
        inputs = turning_inputs(model, turn)
        gravity = inputs.gravity_body_m_s2
        states = np.stack([inputs.q, inputs.qd], axis=-1)
        force = turning_forces(model, self.path, inputs.base + gravity, gravity)
        during = np.asarray(during, dtype=np.float64)
        tau = np.asarray(tau, dtype=np.float64)
        between = states_between(model, states, force, dt_s, during, np)
        omega = np.asarray(model.omega_rad_s)
        sag = (gravity[-1] @ np.asarray(model.gamma).T) / omega**2
        end = np.stack([inputs.q[-1] - sag, inputs.qd[-1]], axis=-1)
        free = free_states(model, end, tau, np)
        count = len(tau)
        self.n_during = len(during)
        self.t_s = np.concatenate([during, self.t_end + tau])
        self.inputs = TurningInputs(
            self.t_s,
            np.concatenate([between[..., 0], sag + free[..., 0]]),
            np.concatenate([between[..., 1], free[..., 1]]),
            np.concatenate(
                [samples_at(inputs.base, dt_s, during), np.tile(-gravity[-1], (count, 1))]
            ),
            np.concatenate([samples_at(inputs.coefficients, dt_s, during), np.zeros((count, 9))]),
            np.concatenate([samples_at(gravity, dt_s, during), np.tile(gravity[-1], (count, 1))]),
        )
        self.sample_rotation = np.asarray(self.path.rotation)
        self.rotation = np.concatenate(
            [
                rotations_between(self.path, np.minimum(during, self.t_end)),
                np.repeat(self.sample_rotation[-1:], count, axis=0),
            ]
        )

    def input_weights(self, j: int) -> list[tuple[int, float]]:
        """The samples (k, weight) the frame's acceleration at time index ``j`` interpolates
        (none after the move)."""
        if j >= self.n_during:
            return []
        t = self.t_s[j]
        k = min(int(t // self.dt_s), self.n_steps - 1)
        w = t / self.dt_s - k
        return [(k, 1.0 - w), (k + 1, w)]

    def base_map(self, j: int, along: np.ndarray) -> np.ndarray:
        """(n+1, 3) the derivative of along . (a_O - g_b)(t_j) by the world samples: a_O is
        R_k^T a_k + (independent of a) at the samples, linear between them."""
        coef = np.zeros((self.n_steps + 1, 3))
        for k, w in self.input_weights(j):
            coef[k] += w * (self.sample_rotation[k] @ along)
        return coef

    def state_map(self, j: int) -> np.ndarray:
        """(M, 2, n+1, 3) the modal state at time index ``j`` per unit translation sample
        (world components): the straight move's map of the turned samples R_k^T a_k."""
        straight = state_maps_at(self.model, self.n_steps, self.dt_s, self.t_s[j : j + 1])[0]
        return np.einsum("mikd,kcd->mikc", straight, self.sample_rotation)

    def positions(self, points: np.ndarray) -> np.ndarray:
        """(T, P, 3) world positions of the mid-surface ``points`` (cell coordinates)."""
        model, pivot = self.model, self.turn.pivot_m
        coords = turning_coordinates(
            model, self.inputs.q, self.inputs.base, self.inputs.coefficients
        )
        u = np.einsum("pcm,tm->tpc", turning_shapes(model)[points], coords)
        local = np.asarray(model.points)[points][None] - pivot + u
        path = kinematics_at(self.turn.move, np.minimum(self.t_s, self.t_end))[0]
        return pivot + path[:, None] + np.einsum("tab,tpb->tpa", self.rotation, local)


class TurnLoadFamily(LoadFamily):
    """Cup utilisation or von Mises stress of a turning part (module docstring): the
    outputs of jaxflex._turning_outputs with the static response to the rotational loads
    ``static_rot``; ``source`` the turn (:class:`TurnSource`)."""

    def __init__(self, name, model, outputs, static_rot, functional, limit, source) -> None:
        super().__init__(name, model, outputs, functional, limit, np.zeros(3))
        self.source = source
        self.static_rot = static_rot
        self.a_rot = output_residual(outputs, static_rot, model)  # (Y, 9)

    @classmethod
    def cups(cls, model, safety: float, source) -> TurnLoadFamily:
        functional = CupUtilisation(model.cups, safety)
        static = model.rotation.cup_static
        return cls("cup utilisation", model, model.cups.reaction, static, functional, 1.0, source)

    @classmethod
    def stress(cls, model, limit_pa: float, source) -> TurnLoadFamily:
        functional = VonMises(model.stress.n_points)
        static = model.rotation.stress_static
        return cls(
            "von Mises stress", model, model.stress.stress, static, functional, limit_pa, source
        )

    def motion(self, move: Move, during, tau) -> TurnMotion:
        return self.source.motion(self.model, move, during, tau)

    def outputs_of(self, motion: TurnMotion, rows=None, times=slice(None)) -> np.ndarray:
        """(T, Y) the outputs ``rows`` (default all) at the motion's ``times`` (default all):
        jaxflex._turning_outputs' equation (1), y = Q q + V q' + A (a_O - g_b) + A_rot b."""
        rows = slice(None) if rows is None else rows
        inputs = motion.inputs
        return (
            inputs.q[times] @ self.q_map[rows].T
            + inputs.qd[times] @ self.v_map[rows].T
            + inputs.base[times] @ self.a_map[rows].T
            + inputs.coefficients[times] @ self.a_rot[rows].T
        )

    def evaluate(self, motion: TurnMotion, items: np.ndarray | None = None) -> np.ndarray:
        """(T, I) the functional of ``items`` (default all) at the motion's times, in blocks
        of ITEM_BLOCK items."""
        if items is None:
            items = np.arange(self.functional.n_items)
        r = self.functional.rows_per_item
        out = [np.zeros((len(motion.t_s), 0))]
        with threadpool_limits(limits=1, user_api="blas"):
            for start in range(0, len(items), ITEM_BLOCK):
                block = items[start : start + ITEM_BLOCK]
                y = self.outputs_of(motion, (r * block[:, None] + np.arange(r)).ravel())
                out.append(self.functional.values(y.reshape(len(y), len(block), r), block))
        return np.concatenate(out, axis=1)

    def item_bounds(self, motion: TurnMotion) -> np.ndarray:
        """(I,) each item's bound over the motion's times: f(y) <= W . |y| (f positively
        homogeneous, Lipschitz with the row weights W) and |y_j| <= sum over the inputs of
        |map_j| times the input's largest magnitude over the times. Cheap (no outputs)."""
        inputs = motion.inputs
        size = sum(
            np.abs(m) @ np.abs(x).max(axis=0)
            for m, x in (
                (self.q_map, inputs.q),
                (self.v_map, inputs.qd),
                (self.a_map, inputs.base),
                (self.a_rot, inputs.coefficients),
            )
        )
        items = np.arange(self.functional.n_items)
        weights = self.functional.weights(items)
        return np.einsum("ir,ir->i", weights, size.reshape(weights.shape))

    def scan(self, move: Move, axes) -> list[Row]:
        """Rows at the worst sampled violations of ``move`` (a Move); only the items whose
        bound (:meth:`item_bounds`) reaches the row threshold are evaluated."""
        above = self.limit * (1 - ROW_MARGIN + SCAN_RTOL)
        during = move_times(move.n_steps, move.dt_s)
        motion = self.motion(move, during, tail_times(self.model))
        candidates = np.flatnonzero(self.item_bounds(motion) > above)
        if candidates.size == 0:
            return []
        found = _worst_samples(self.evaluate(motion, candidates), above)
        return [self._turn_row(motion, j, int(candidates[i]), axes) for j, i in found]

    def _turn_row(self, motion: TurnMotion, j: int, item: int, axes) -> Row:
        """The cut at time index ``j`` and ``item`` (module docstring)."""
        rows = self._rows_of(item)
        y = self.outputs_of(motion, rows, slice(j, j + 1))[0]
        g = self.functional.cut(y, item)
        maps = motion.state_map(j)
        coef = np.einsum("m,mkc->kc", g @ self.q_map[rows], maps[:, 0])
        coef += np.einsum("m,mkc->kc", g @ self.v_map[rows], maps[:, 1])
        coef += motion.base_map(j, g @ self.a_map[rows])
        constant = g @ y - np.sum(coef * motion.acc)
        rhs = (self.limit * (1 - ROW_MARGIN) - constant) / self.limit
        return Row(coef[:, list(axes)] / self.limit, float(rhs), float(motion.t_s[j]), item)

    scenario = None  # a robust grid's models are built with their own maps (cell_scenarios)

    def _peak(self, move: Move, limit: float | None) -> Peak:
        """The supremum over ``move`` (a Move), the settling and the rest in the final pose,
        certified by branch and bound (jaxflex._turning_peaks), to 1e-5 of the value or up to
        ``limit`` below it (where the bound stays below it the peak need not be located)."""
        turn = self.source.turn(move)
        return turning_output_peak(
            self.model, self.outputs, self.static_rot, self.functional, turn, rtol=1e-5, limit=limit
        )

    def failure_row(self, peak: Peak, move: Move, axes) -> Row:
        """The cut at the certified worst point of ``move`` (a Move), which failed."""
        motion = self._motion_at(move, peak.time_s)
        return self._turn_row(motion, 0, peak.item, axes)

    def _motion_at(self, move: Move, time_s: float) -> TurnMotion:
        """The motion of ``move`` at the one time ``time_s`` (s from the start; inf: at rest
        at B)."""
        tau = min(time_s, 1e9) - move.n_steps * move.dt_s
        if tau > 0:
            return self.motion(move, np.zeros(0), np.array([tau]))
        return self.motion(move, np.array([time_s]), np.zeros(0))

    def curve(self, move: Move, t) -> np.ndarray:
        """(T,) the largest load of ``move`` (a Move) at times ``t`` (during and after)."""
        return self.evaluate(_plot_motion(self, move, t)).max(axis=1)


def _plot_motion(family, move: Move, t) -> TurnMotion:
    """The motion of ``family``'s turn at the times ``t`` (T,) s (during and after)."""
    t = np.asarray(t, dtype=np.float64)
    t_end = move.n_steps * move.dt_s
    return family.motion(move, t[t <= t_end], t[t > t_end] - t_end)


class TurnDistanceFamily:
    """The turning part (every point, its skins ``half_thickness_m`` off the mid-surface) at
    least ``margin_m`` from every obstacle (module docstring); ``source`` the turn."""

    name = "distance to obstacles"

    def __init__(self, model, obstacles, margin_m: float, half_thickness_m: float, source):
        self.model, self.obstacles, self.limit = model, tuple(obstacles), float(margin_m)
        self.half, self.source = float(half_thickness_m), source
        self.shapes = turning_shapes(model)
        self.points = np.arange(model.n_points)
        self.n_base = response_shapes(model).shape[-1] - model.n_modes  # 3 or 0: D

    def motion(self, move: Move, during, tau) -> TurnMotion:
        return self.source.motion(self.model, move, during, tau)

    def skin_distances(self, motion: TurnMotion) -> np.ndarray:
        """(T, P) every point's skin distance at the motion's times."""
        world = motion.positions(self.points)
        d, _, _ = distances(self.obstacles, world.reshape(-1, 3))
        return d.reshape(world.shape[:2]) - self.half

    def scan(self, move: Move, axes) -> list[Row]:
        """Separating planes at the sampled closest approaches of ``move`` (a Move)."""
        threshold = self.limit * (1 + ROW_MARGIN - SCAN_RTOL)
        during = move_times(move.n_steps, move.dt_s)
        motion = self.motion(move, during, tail_times(self.model))
        d = self.skin_distances(motion)
        rows = (self._row(motion, j, p, axes) for j, p in _local_peaks(-d, -threshold))
        return [r for r in rows if r is not None]

    def _row(self, motion: TurnMotion, j: int, point: int, axes) -> Row | None:
        """The plane separating ``point`` at time index ``j`` from the nearest obstacle."""
        n = motion.n_steps
        p = motion.positions(np.array([point]))[j, 0]
        d, _, c = distances(self.obstacles, p[None])
        gap = p - c[0]
        if np.linalg.norm(gap) < 1e-12:
            return None
        normal = np.sign(d[0]) * gap / np.linalg.norm(gap)
        along = (normal @ motion.rotation[j]) @ self.shapes[point]  # body shapes, world normal
        m = self.model.n_modes
        coef = np.einsum("m,mkc->kc", along[:m], motion.state_map(j)[:, 0])
        if self.n_base:  # D (a_O - g_b)
            coef += motion.base_map(j, along[m : m + 3])
        t = min(motion.t_s[j], motion.t_end)
        coef += np.outer(position_weights(n, motion.dt_s, np.array([t]))[0], normal)
        constant = normal @ (p - c[0]) - np.sum(coef * motion.acc)
        margin = self.limit * (1 + ROW_MARGIN) + self.half
        # n . (p(a) - c) >= margin  <=>  -coef . a <= constant - margin
        rhs = constant - margin
        coef = -coef[:, list(axes)] / self.limit
        return Row(coef, float(rhs / self.limit), float(t), point, restriction=True)

    certify = DistanceFamily.certify
    measure = DistanceFamily.measure

    def _clearance(self, move: Move, limit_m: float | None):
        """The certified clearance over ``move`` (a Move) and the settling, decided against
        ``limit_m`` (None: located everywhere)."""
        return certified_distance(
            self, turning_min_distance, self.source.turn(move), limit_m=limit_m
        )

    def holds(self, found) -> bool:
        return found.bound_m >= self.limit * (1 - BOUND_RTOL)

    def failure_row(self, found, move: Move, axes) -> Row | None:
        """The separating plane at the certified closest point of ``move``, which failed."""
        if not math.isfinite(found.time_s):
            return None  # at rest in the final pose: checked before the search
        tau = found.time_s - move.n_steps * move.dt_s
        if tau > 0:
            motion = self.motion(move, np.zeros(0), np.array([tau]))
        else:
            motion = self.motion(move, np.array([found.time_s]), np.zeros(0))
        return self._row(motion, 0, found.point, axes)

    describe = DistanceFamily.describe

    def curve(self, move: Move, t) -> np.ndarray:
        """(T,) the smallest skin distance of ``move`` (a Move) at times ``t`` (plots)."""
        return self.skin_distances(_plot_motion(self, move, t)).min(axis=1)
