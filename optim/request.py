"""``optim.request.Request``: one optimisation request, checked once, where it enters.

Every argument of ``optim.optimize`` is a field, given by keyword; the option objects
(optim.options: Search, Constraints, Rotation, Budget) checked themselves when made. The
constructor converts the loose forms (limits and the robust range as mappings,
``robust=True``), checks what needs the model or more than one option (the model's damping,
the route against the cell's constraints, the turn against the model and the budget) and
refuses what no run can use, with an InputError naming the field and, for the fields the
command sets, its option of ``jaxflex optimize`` (``threshold_m (--threshold): ...``). The
stages after it (optim.stages) take its values as they are. What needs the model posed in
the cell (the move's length, the memory, the clearance) is checked by the plan stage.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from jaxflex.errors import InputError
from jaxflex.model import ModalModel, require_model
from jaxflex.response import require_rotation
from jaxflex.runtime import current_budget
from optim.limits import Limits
from optim.options import Budget, Constraints, RobustSpec, Rotation, Search, check_step
from optim.turn import TurnSpec
from optim.turn_via import with_via_orientations

# the keys of a limits mapping: (required, optional), plain (Limits' fields) or with units
_LIMIT_KEYS = {
    False: (("vmax", "amax", "jmax"), ("vpath", "apath", "jpath")),
    True: (("vmax_m_s", "amax_m_s2", "jmax_m_s3"), ("vpath_m_s", "apath_m_s2", "jpath_m_s3")),
}


def _as_limits(limits: Any) -> Limits:
    if isinstance(limits, Limits):
        return limits
    if isinstance(limits, Mapping):
        json_form = "vmax_m_s" in limits  # Limits.as_dict's keys, with their units
        required, optional = _LIMIT_KEYS[json_form]
        missing = [key for key in required if key not in limits]
        unknown = sorted(set(limits) - set(required) - set(optional), key=str)
        if missing or unknown:
            raise InputError(
                f"limits: a mapping takes {', '.join(required)} and optionally "
                f"{', '.join(optional)}; missing {missing}, unknown {unknown}"
            )
        return Limits.from_dict(dict(limits)) if json_form else Limits(**limits)
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


def _option(name: str, value: Any, kind: type) -> Any:
    """``value`` if it is a ``kind`` (an option object of optim.options), ``kind()`` (its
    defaults) for None; InputError naming the argument otherwise."""
    if value is None:
        return kind()
    if not isinstance(value, kind):
        raise InputError(
            f"{name}: an optim.{kind.__name__}(...) or None, got {type(value).__name__}"
        )
    return value


def _check_model(model: Any, robust: RobustSpec | None) -> None:
    require_model(model)
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


@dataclass(frozen=True, kw_only=True)
class Request:
    """The arguments of ``optim.optimize`` (see there), by keyword, checked and in their
    final form: ``limits`` a Limits, ``robust`` None or a RobustSpec, the option objects
    given (their defaults for None), ``budget.max_memory_bytes`` the process's budget if
    not given, ``turn`` the rotation's optim.turn.TurnSpec in the cell's coordinates (with
    the cell's via orientations), None without a rotation."""

    model: ModalModel
    distance_m: Any  # (3,) m, or None with a cell (then the cell's move)
    limits: Limits
    dt_s: float
    threshold_m: float
    robust: RobustSpec | None = None
    constraints: Constraints | None = None
    rotation: Rotation | None = None
    search: Search | None = None
    budget: Budget | None = None
    turn: TurnSpec | None = field(init=False, default=None)

    def __post_init__(self) -> None:
        robust = _as_robust(self.robust)
        _check_model(self.model, robust)
        self._set("robust", robust)
        self._set("limits", _as_limits(self.limits))
        threshold_m, dt_s = check_step(self.threshold_m, self.dt_s)
        self._set("threshold_m", threshold_m)
        self._set("dt_s", dt_s)
        for name, kind in (("constraints", Constraints), ("search", Search), ("budget", Budget)):
            self._set(name, _option(name, getattr(self, name), kind))
        if self.rotation is not None and not isinstance(self.rotation, Rotation):
            raise InputError(
                f"rotation: an optim.Rotation(axis, angle_deg, ...) or None, got "
                f"{type(self.rotation).__name__}"
            )
        if self.budget.max_memory_bytes is None:
            memory = current_budget().memory_bytes
            self._set("budget", replace(self.budget, max_memory_bytes=memory))
        self._check_route()
        self._check_turn()

    def _set(self, field: str, value: Any) -> None:
        object.__setattr__(self, field, value)

    def _check_route(self) -> None:
        """The gradient route refuses the cell's via points and constraints."""
        c = self.constraints
        if self.search.method == "gradient" and (c.has_via or c.has_cell_limits):
            raise InputError(
                "method: the gradient route does not take via points or the cell's constraints "
                "(min_distance_m, cup_safety, max_stress_pa); the exact route does: "
                "method='exact' (jaxflex optimize --method exact, the default)"
            )

    def _check_turn(self) -> None:
        """The turn (optim.turn.TurnSpec), for a model with the rotation data (both routes
        take it: the turn's fixed schedules make the end state affine in the samples),
        checked against the budget before ruckig or an LP sees it."""
        cell = self.constraints.cell
        if self.rotation is None:
            with_via_orientations(None, cell, self.limits)  # refused without a turn
            return
        require_rotation(self.model)
        turn = with_via_orientations(_in_cell(TurnSpec.of(self.rotation), cell), cell, self.limits)
        turn.check_length(self.dt_s, self.budget.max_duration_s, self.budget.max_steps)
        self._set("turn", turn)

    @property
    def n_scenarios(self) -> int:
        """The models every move is certified on: 1, or the robust grid's."""
        return 1 if self.robust is None else self.robust.n_scenarios
