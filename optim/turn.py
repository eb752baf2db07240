"""A turn about a fixed axis with the move: its schedule per move length, and the affine
map from the translation samples to the end state that the search's LP uses.

The turn (``TurnSpec``: the axis through the gripper origin, the angle and the angular
rate, acceleration and jerk limits) gets, for every move length of n steps, a FIXED
schedule: ruckig's time-optimal turn stretched to n dt (synchronised with the translation
as ruckig synchronises axes) and put on the grid by the closest grid profile that meets the
angular limits and the angle exactly (optim.ruckig_move, the angle as a one-axis move).
For that schedule the modal end state of the turning move (jaxflex._turning: the translation
acts in the body frame as R_k^T a_k, the Euler, centrifugal and turned-gravity loads and
the sag at the current pose are fixed) is affine in the translation samples:

    x_end = E_R a + x_turn,   E_R[m, i, k, c] = sum_j E[m, i, k, j] R_k[c, j],

E the straight move's end-state map (jaxflex.response.end_state_map) and x_turn the end
state of the turn alone (jaxflex.simulate_turning with the translation at rest).
So the search's LP over the translation is exact for the schedule; the schedule itself
(stretched to the move) is the heuristic.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jaxflex.errors import InputError
from jaxflex.response import (
    GRAVITY_M_S2,
    Move,
    PosePath,
    SettleReport,
    Turn,
    TurningResponse,
    as_move,
    axis_rotation,
    fixed_axis_path,
    require_rotation,
    simulate_turning,
    turning_settle,
    unit_axis,
)
from optim.budget import kinematic_lower_bound_s
from optim.defaults import ANGULAR_LIMITS
from optim.limits import Limits
from optim.options import Rotation
from optim.ruckig_move import fit_to_grid, grid_steps, shaped_acceleration, time_optimal_move
from optim.shapers import Shaper
from optim.turn_clearance import turning_move_deviation


@dataclass(frozen=True)
class TurnSpec:
    """A turn by ``angle_rad`` about the unit ``axis`` (3,) (model frame, through the gripper
    origin) within ``rate_rad_s``, ``acc_rad_s2``, ``jerk_rad_s3``, under ``gravity_m_s2``
    (3,) m/s^2 (world = model frame at the start); the axis passes through ``pivot_m`` (3,)
    m (model frame), the point whose acceleration the translation samples are."""

    axis: tuple[float, float, float]
    angle_rad: float
    rate_rad_s: float = ANGULAR_LIMITS[0]
    acc_rad_s2: float = ANGULAR_LIMITS[1]
    jerk_rad_s3: float = ANGULAR_LIMITS[2]
    gravity_m_s2: tuple[float, float, float] = GRAVITY_M_S2
    pivot_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @classmethod
    def of(cls, rotation: Rotation) -> TurnSpec:
        """The turn of a checked optim.options.Rotation (its axis a unit vector, its angle in
        radians), under gravity -9.81 m/s^2 along z, in the model frame."""
        rate, acc, jerk = rotation.angular_limits
        return cls(
            tuple(float(v) for v in unit_axis(rotation.axis)),
            float(np.radians(rotation.angle_deg)),
            rate,
            acc,
            jerk,
            pivot_m=rotation.pivot_m,
        )

    def check_length(self, dt_s: float, max_duration_s: float, max_steps: int) -> None:
        """InputError naming the options unless the turn can fit in ``max_duration_s`` and
        ``max_steps`` steps of ``dt_s``: its closed-form lower bound (optim.budget,
        the angle as a one-axis move) is checked before ruckig or an LP sees the turn."""
        floor_s = kinematic_lower_bound_s(self.angle_move, self.limits)
        allowed_s = min(max_duration_s, max_steps * dt_s)
        if floor_s > allowed_s:
            raise InputError(
                f"rotate / angular_limits (--rotate, --angular-limits W A J): the turn of "
                f"{np.degrees(self.angle_rad):.4g} degrees needs at least {floor_s:.4g} s at "
                f"the angular limits {self.rate_rad_s:g} rad/s, {self.acc_rad_s2:g} rad/s^2, "
                f"{self.jerk_rad_s3:g} rad/s^3, more than the {allowed_s:g} s a move may last "
                "(--max-duration, --max-steps x --dt); raise the limits or turn less"
            )

    @property
    def limits(self) -> Limits:
        """The angular limits as those of a one-axis move (the angle along x)."""
        return Limits(vmax=self.rate_rad_s, amax=self.acc_rad_s2, jmax=self.jerk_rad_s3)

    @property
    def angle_move(self) -> np.ndarray:
        return np.array([self.angle_rad, 0.0, 0.0])

    def as_dict(self) -> dict:
        return {
            "axis": list(self.axis),
            "angle_deg": float(np.degrees(self.angle_rad)),
            "rate_rad_s": self.rate_rad_s,
            "acc_rad_s2": self.acc_rad_s2,
            "jerk_rad_s3": self.jerk_rad_s3,
            "gravity_m_s2": list(self.gravity_m_s2),
            "pivot_m": list(self.pivot_m),
        }

    @property
    def turns(self) -> bool:
        """Whether the part turns at all."""
        return self.angle_rad != 0.0

    @property
    def end_rotation(self) -> np.ndarray:
        """(3, 3) the part's orientation at the end of the turn (body to world)."""
        return axis_rotation(np.asarray(self.axis), np.array([self.angle_rad]))[0]

    def rest_gravities(self) -> list[np.ndarray]:
        """Gravity in body components at rest at the start and in the final pose (m/s^2)."""
        gravity = np.asarray(self.gravity_m_s2, dtype=np.float64)
        return [gravity, self.end_rotation.T @ gravity]

    def fastest_s(self) -> float:
        """Ruckig's time-optimal duration of the turn alone (s; 0 for no turn)."""
        if self.angle_rad == 0.0:
            return 0.0
        return time_optimal_move(self.angle_move, self.limits).duration_s

    def stretched(self, n_steps: int, dt_s: float, train: Shaper | None = None):
        """(n+1,) angular acceleration samples (rad/s^2) of the turn stretched by ruckig to
        n dt (with ``train``: to n dt minus the train's duration, then convolved with it),
        put on the grid within the angular limits (module docstring), or None if no grid
        turn of n steps exists (shorter than the turn's time-optimal duration)."""
        if self.angle_rad == 0.0:
            return np.zeros(n_steps + 1)
        shaping = 0.0 if train is None else train.duration_s
        if n_steps < grid_steps(self.fastest_s() + shaping, dt_s):
            return None
        motion = time_optimal_move(
            self.angle_move, self.limits, minimum_duration_s=n_steps * dt_s - shaping
        )
        times = dt_s * np.arange(n_steps + 1)
        if train is None:
            reference = motion.acceleration(times)
        else:
            reference = shaped_acceleration(motion, train)(times)
        acc = fit_to_grid(reference, dt_s, self.angle_move, self.limits)
        return None if acc is None else acc[:, 0]

    def path(self, angular_acc: np.ndarray, dt_s: float) -> PosePath:
        return fixed_axis_path(np.asarray(self.axis), angular_acc, dt_s)

    def with_move(self, angular_acc: np.ndarray, move: Move) -> Turn:
        """The core's turning move (jaxflex.response.Turn) of the translation ``move`` (a
        Move: samples (n+1, 3) m/s^2 and their step) with the turn ``angular_acc`` (rad/s^2
        at the move's step, padded with zeros to its length), about this pivot under this
        gravity."""
        move = as_move(move, name="move")
        path = self.path(_padded(angular_acc, move.n_steps), move.dt_s)
        return Turn(path, move, pivot_m=self.pivot_m, gravity_m_s2=self.gravity_m_s2)

    def response(
        self, model, angular_acc: np.ndarray, move: Move, extend_s: float = 0.0
    ) -> TurningResponse:
        """jaxflex.simulate_turning of the translation ``move`` (a Move) with the turn
        ``angular_acc`` (:meth:`with_move`)."""
        return simulate_turning(model, self.with_move(angular_acc, move), extend_s=extend_s)

    def timing(
        self, model, angular_acc: np.ndarray, move: Move, threshold_m: float
    ) -> tuple[SettleReport, TurningResponse]:
        """Exact settle and cycle time of the turning move (the translation ``move``, a Move,
        with the turn ``angular_acc``; jaxflex.response.turning_settle) and its response (with
        the neglected terms' bound)."""
        turn = self.with_move(angular_acc, move)
        response = simulate_turning(model, turn)
        return turning_settle(model, turn, threshold_m, response=response), response


def _padded(angular_acc, n_steps: int) -> np.ndarray:
    """(n+1,) the turn's samples ``angular_acc`` padded with zeros to an n-step move."""
    angular_acc = np.asarray(angular_acc, dtype=np.float64)
    return np.concatenate([angular_acc, np.zeros(n_steps + 1 - angular_acc.size)])


class TurnSchedule:
    """The fixed turns of every move length the search tries, the rotated end-state maps
    and the turn's own end state (module docstring), cached. The schedules are tried in
    turn (``variant`` selects one): the turn stretched to the move (variant 0), then the
    turn shaped by each of ``trains`` (the input shapers of the best shaped baselines) and
    stretched to the move: the translation cannot cancel the modes it does not load (those
    a turn about an axis of symmetry excites), the turn's shaping can."""

    def __init__(self, spec: TurnSpec, dt_s: float, trains: list[Shaper] = ()) -> None:
        self.spec = spec
        self.dt_s = dt_s
        self.trains = [None] if spec.angle_rad == 0.0 else [None, *trains]
        self.variant = 0
        # called with each length before it is tested (optim.turn_plan.LengthPlanner)
        self.planner: Callable[[int], None] | None = None
        self._alpha: dict[tuple[int, int], np.ndarray | None] = {}
        self._cache: dict[tuple, np.ndarray] = {}
        self._cell_rows: dict[int, dict] = {}

    def cell_rows(self) -> dict:
        """The pool of the cell's rows (optim.turn_cell: n_steps -> rows) of the active
        schedule: their constant parts are that schedule's."""
        return self._cell_rows.setdefault(self.variant, {})

    def variants(self, n_steps: int) -> list[int]:
        """The schedules that exist for an n-step move (at least the turn's floor), asked
        once per length the search tests (its :attr:`planner` first)."""
        if self.planner is not None:
            self.planner(n_steps)
        return [v for v in range(len(self.trains)) if self._schedule(n_steps, v) is not None]

    def _schedule(self, n_steps: int, variant: int) -> np.ndarray | None:
        key = (n_steps, variant)
        if key not in self._alpha:
            self._alpha[key] = self.spec.stretched(n_steps, self.dt_s, self.trains[variant])
        return self._alpha[key]

    def angular_acc(self, n_steps: int) -> np.ndarray:
        """(n+1,) rad/s^2: the active variant's schedule of an n-step move."""
        return self._schedule(n_steps, self.variant)

    def _cached(self, key: tuple, make) -> np.ndarray:
        if key not in self._cache:
            if len(self._cache) > 64:  # the search tests one length at a time
                self._cache.clear()
            self._cache[key] = make()
        return self._cache[key]

    def rotated_map(self, end_map: np.ndarray, n_steps: int, scenario: int) -> np.ndarray:
        """E_R (M, 2, n+1, 3) from the straight map ``end_map`` (same shape)."""

        def make():
            rotation = self.spec.path(self.angular_acc(n_steps), self.dt_s).rotation
            return np.einsum("mikj,kcj->mikc", end_map, rotation)

        return self._cached(("map", scenario, n_steps, self.variant), make)

    def end_offset(self, model, n_steps: int, scenario: int) -> np.ndarray:
        """(M, 2) end state of the turn with the translation at rest."""

        def make():
            require_rotation(model)
            alpha = self.angular_acc(n_steps)
            zero = as_move(np.zeros((n_steps + 1, 3)), self.dt_s)
            return self.spec.response(model, alpha, zero).end_state

        return self._cached(("offset", scenario, n_steps, self.variant), make)

    def timing(self, model, move: Move, threshold_m: float) -> SettleReport:
        """The exact timing of ``move`` (a Move) with the active schedule of its length."""
        alpha = self.angular_acc(move.n_steps)
        return self.spec.timing(model, alpha, move, threshold_m)[0]


def turn_deviation(model, spec: TurnSpec, angular_acc, move: Move) -> dict:
    """Peak deviation during the turning move (the translation ``move``, a Move, with the
    turn ``angular_acc`` of ``spec``; exact samples every dt_s / 8, about the current pose's
    sag: optim.turn_clearance, the samples a clearance is held at) and at the stop, m. The
    bound on the neglected terms comes with the move's timing (:meth:`TurnSpec.timing`'s
    response), not simulated again here."""
    t, d = turning_move_deviation(model, spec, angular_acc, move)
    return {
        "peak_during_move_m": float(d.max()),
        "peak_time_s": float(t[np.argmax(d)]),
        "at_stop_m": float(d[-1]),
        "sampling_s": float(t[1] - t[0]),
    }
