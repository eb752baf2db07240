"""``optim.Request``: one optimisation request, checked once, where it enters.

Every argument of ``optim.optimize`` is a field; the constructor converts the loose forms
(limits and the robust range as mappings, ``robust=True``) and refuses what no run can use,
with an InputError naming the field and, for the fields the command sets, its option of
``jaxflex optimize`` (``threshold_m (--threshold): ...``). The stages after it
(optim.stages) take its values as they are. What needs the model posed in the cell (the
move's length, the memory, the clearance) is checked by the plan stage.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from jaxflex.defaults import MAX_DURATION_S
from jaxflex.errors import InputError
from jaxflex.files import check_positive
from jaxflex.model import ModalModel
from jaxflex.response import require_rotation
from jaxflex.runtime import current_budget
from optim.baselines import MAX_SHAPED_MODES
from optim.budget import MAX_STEPS
from optim.gradient import GRADIENT_SOLVERS
from optim.limits import Limits
from optim.lp import LP_SOLVERS
from optim.options import check_numbers, label
from optim.robust import RobustSpec
from optim.turn import TurnSpec
from optim.turn_via import with_via_orientations

METHODS = {"exact": ("highs", LP_SOLVERS), "gradient": ("ipopt", GRADIENT_SOLVERS)}


def _as_limits(limits: Any) -> Limits:
    if isinstance(limits, Limits):
        return limits
    if isinstance(limits, Mapping):
        if "vmax_m_s" in limits:
            return Limits.from_dict(dict(limits))
        return Limits(**limits)
    raise InputError(
        f"limits: expected optim.Limits(vmax, amax, jmax, ...) or a mapping, got {limits!r}"
    )


def _as_robust(robust: Any) -> RobustSpec | None:
    if robust is None or isinstance(robust, RobustSpec):
        return robust
    if robust is True:
        return RobustSpec()
    if isinstance(robust, Mapping):
        return RobustSpec.from_dict(dict(robust))
    raise InputError(f"robust: expected None, True or optim.RobustSpec(...), got {robust!r}")


def _check_model(model: Any, robust: RobustSpec | None) -> None:
    if not isinstance(model, ModalModel):
        raise InputError(f"model: expected a jaxflex.ModalModel, got {type(model).__name__}")
    zeta = np.asarray(model.zeta)
    if robust is None or robust.zeta is None:
        undamped = np.flatnonzero(zeta <= 0)
        if undamped.size:
            i = int(undamped[0])
            raise InputError(
                f"model.zeta: mode {i} ({float(model.freq_hz[i]):.4g} Hz) is undamped (zeta = 0); "
                "its vibration never decays, so no cycle time exists. Set a damping ratio "
                "(model.with_damping) or a robust zeta range"
            )


def _in_cell(turn: TurnSpec, cell: Any) -> TurnSpec:
    """The turn in the cell's coordinates (the model posed there: jaxflex.geometry.Cell.posed):
    its axis turned and its pivot placed with the part, under the cell's gravity; the turn
    itself without a cell."""
    if cell is None:
        return turn
    rotation = np.asarray(cell.rotation, dtype=np.float64)
    pivot = rotation @ np.asarray(turn.pivot_m) + np.asarray(cell.start_m, dtype=np.float64)
    return replace(
        turn,
        axis=tuple(float(v) for v in rotation @ np.asarray(turn.axis)),
        pivot_m=tuple(float(v) for v in pivot),
        gravity_m_s2=tuple(float(v) for v in np.asarray(cell.gravity_m_s2, dtype=np.float64)),
    )


@dataclass(frozen=True)
class Request:
    """The arguments of ``optim.optimize`` (see there), checked and in their final form:
    ``limits`` a Limits, ``robust`` None or a RobustSpec, ``solver`` the method's default if
    not given, ``max_memory_bytes`` the process's budget if not given, numbers as floats."""

    model: ModalModel
    distance_m: Any  # (3,) m, or None with a cell (then the cell's move)
    limits: Limits
    dt_s: float
    threshold_m: float
    method: str = "exact"
    solver: str | None = None
    robust: RobustSpec | None = None
    progress: bool | None = None
    max_duration_s: float = MAX_DURATION_S
    max_shaped_modes: int = MAX_SHAPED_MODES
    clearance_m: float | None = None
    max_steps: int = MAX_STEPS
    max_memory_bytes: int | None = None
    cell: Any = None  # a jaxflex.geometry.Cell
    min_distance_m: float | None = None
    cup_safety: float | None = None
    max_stress_pa: float | str | None = None
    rotate: Any = None  # (axis, angle_deg) or an optim.turn.TurnSpec; a TurnSpec once checked
    angular_limits: Any = None  # (rate rad/s, acc rad/s^2, jerk rad/s^3); ANGULAR_LIMITS
    pivot_m: Any = None  # (3,) m: the point the turn's axis passes through (default origin)

    def __post_init__(self) -> None:
        robust = _as_robust(self.robust)
        _check_model(self.model, robust)
        self._set("robust", robust)
        self._set("limits", _as_limits(self.limits))
        numbers = check_numbers(
            threshold_m=self.threshold_m,
            dt_s=self.dt_s,
            max_duration_s=self.max_duration_s,
            clearance_m=self.clearance_m,
            max_steps=self.max_steps,
        )
        for field, value in numbers.items():
            self._set(field, value)
        self._check_route()
        self._check_turn()
        if self.rotate is not None:  # before ruckig or an LP sees the turn
            self.rotate.check_length(self.dt_s, self.max_duration_s, self.max_steps)
        memory = self.max_memory_bytes
        memory = current_budget().memory_bytes if memory is None else memory
        check_positive(label("max_memory_bytes"), memory)
        self._set("max_memory_bytes", memory)

    def _set(self, field: str, value: Any) -> None:
        object.__setattr__(self, field, value)

    def _check_route(self) -> None:
        """The method and its solver; the gradient route refuses the cell's constraints."""
        if self.method not in METHODS:
            raise InputError(f"method: must be one of {sorted(METHODS)}, got {self.method!r}")
        default_solver, allowed = METHODS[self.method]
        solver = default_solver if self.solver is None else self.solver
        if solver not in allowed:
            raise InputError(f"solver: method {self.method!r} accepts {allowed}, got {solver!r}")
        self._set("solver", solver)
        if self.method == "gradient" and (self.has_via or self.has_cell_limits):
            raise InputError(
                "method: the gradient route does not take via points or the cell's constraints "
                "(min_distance_m, cup_safety, max_stress_pa); the exact route does: "
                "method='exact' (jaxflex optimize --method exact, the default)"
            )

    def _check_turn(self) -> None:
        """The turn (optim.turn.TurnSpec), for a model with the rotation data (both routes
        take it: the turn's fixed schedules make the end state affine in the samples)."""
        rotate = self.rotate
        if rotate is None:
            if self.angular_limits is not None or self.pivot_m is not None:
                raise InputError(
                    "angular_limits (--angular-limits), pivot_m (--pivot): only with rotate "
                    "(--rotate)"
                )
            with_via_orientations(None, self.cell, self.limits)  # refused without a turn
            return
        if not isinstance(rotate, TurnSpec):
            if isinstance(rotate, str) or not hasattr(rotate, "__len__") or len(rotate) != 2:
                raise InputError(
                    "rotate (--rotate AXIS ANGLE_DEG): (axis, angle in degrees), the axis "
                    f"'x', 'y', 'z' or three numbers; got {rotate!r}"
                )
            rotate = TurnSpec.checked(rotate[0], rotate[1], self.angular_limits, self.pivot_m)
        require_rotation(self.model)
        self._set(
            "rotate", with_via_orientations(_in_cell(rotate, self.cell), self.cell, self.limits)
        )

    @property
    def has_via(self) -> bool:
        return bool(getattr(self.cell, "via", ()))

    @property
    def has_cell_limits(self) -> bool:
        """Whether any of the cell's constraints is asked for."""
        limits = (self.min_distance_m, self.cup_safety, self.max_stress_pa)
        return any(limit is not None for limit in limits)

    @property
    def n_scenarios(self) -> int:
        """The models every move is certified on: 1, or the robust grid's."""
        return 1 if self.robust is None else self.robust.n_scenarios
