"""``fem.sizing.request.SizingRequest``: the arguments of ``fem.size_model``, checked once.

The constructor resolves a scene name to its part and gripper, checks the move (a
jaxflex.Move: samples at rest at both ends and their step, one object) and every number, and
refuses what no sizing can use with an InputError naming the argument; the stages
(fem.sizing.run) take its values as they are.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from fem.parts import Part
from fem.scenes import SCENES, scene
from jaxflex.errors import InputError
from jaxflex.files import check_positive
from jaxflex.response import Move, as_move

# Shares of the tolerance: mesh, points, modes. The mesh is by far the most expensive to
# refine (offline minutes); points and modes cost little online, so they get less.
DEFAULT_SHARES = (0.7, 0.1, 0.2)


def _check_shares(shares: Any) -> tuple[float, float, float]:
    try:
        values = tuple(float(s) for s in shares)
    except (TypeError, ValueError) as exc:
        raise InputError(f"shares: three numbers (mesh, points, modes), got {shares!r}") from exc
    if len(values) != 3 or any(not (0 < s <= 1) for s in values) or sum(values) > 1 + 1e-12:
        raise InputError(
            f"shares: three fractions of the tolerance in (0, 1] for mesh, points and modes, "
            f"summing to at most 1, got {shares!r}"
        )
    return values  # type: ignore[return-value]


def _check_count(name: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise InputError(f"{name}: must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _part_and_supports(part: Any, supports: Any) -> tuple[Part, list]:
    """The part (a scene name resolved) and its supports as a list."""
    if isinstance(part, str):
        if part not in SCENES:
            raise InputError(f"part: a fem part or a scene in {list(SCENES)}, got {part!r}")
        part, default = scene(part)
        supports = default if supports is None else supports
    elif not isinstance(part, Part):
        raise InputError(
            "part: expected a fem part (rectangular_plate, curved_panel, read_mesh) or a scene "
            f"name, got {type(part).__name__}"
        )
    if supports is None:
        raise InputError("supports: a part needs its gripper (fem.SuctionCup, ...)")
    return part, list(supports) if isinstance(supports, list | tuple) else supports


@dataclass(frozen=True)
class SizingRequest:
    """The arguments of ``fem.size_model`` (see there) in their final form: ``part`` a Part,
    ``supports`` a list, ``move`` a Move ((n+1, 3) m/s^2 at rest at both ends and their
    step, s), ``shares`` three floats, numbers checked. The defaults are size_model's."""

    part: Part | str
    supports: Any
    move: Move
    threshold_m: float | None
    tolerance: float
    zeta: Any
    mesh_sizes_m: Sequence[float] | None
    reference_modes: int
    max_modes: int
    key_points: Any
    shares: Sequence[float]
    eval_step_s: float | None
    allow_rigid_modes: bool
    progress: bool | None

    def __post_init__(self) -> None:
        part, supports = _part_and_supports(self.part, self.supports)
        self._set("part", part)
        self._set("supports", supports)
        self._check_move()
        self._check_tolerance()
        reference_modes = _check_count("reference_modes", self.reference_modes, 2)
        self._set("reference_modes", reference_modes)
        self._set("max_modes", _check_count("max_modes", self.max_modes, reference_modes))
        if self.eval_step_s is not None:
            self._set("eval_step_s", check_positive("eval_step_s", self.eval_step_s))
        zeta = self.zeta
        if isinstance(zeta, int | float) and not zeta > 0:  # arrays, Rayleigh: fem.modal checks
            raise InputError(f"zeta: must be > 0 for the deviation to settle, got {zeta!r}")
        self._set("shares", _check_shares(self.shares))
        self._set("allow_rigid_modes", bool(self.allow_rigid_modes))

    def _set(self, field: str, value: Any) -> None:
        object.__setattr__(self, field, value)

    def _check_move(self) -> None:
        if not isinstance(self.move, Move):
            got = "nothing" if self.move is None else f"a {type(self.move).__name__}"
            raise InputError(
                f"move: a jaxflex.Move (the samples and their step together), got {got}; "
                "call fem.size_model(part, supports, jaxflex.as_move(acc, dt_s), threshold_m, "
                "tolerance) (the separate acc, dt_s arguments are gone)"
            )
        move = as_move(self.move, at_rest=True, name="move")
        if not np.any(move.acc):
            raise InputError("move: every sample is 0; the part does not move")
        if self.threshold_m is None:
            raise InputError("threshold_m: the settle threshold in m is required")
        self._set("threshold_m", check_positive("threshold_m", self.threshold_m))

    def _check_tolerance(self) -> None:
        tolerance = check_positive("tolerance", self.tolerance)
        if tolerance >= 0.5:
            raise InputError(
                f"tolerance: a fraction in (0, 0.5) (0.01 = 1 %), got {tolerance!r}"
                + (f"; did you mean {tolerance / 100:g}?" if tolerance < 50 else "")
            )
        self._set("tolerance", tolerance)
