"""``fem.sizing.request.SizingRequest``: the arguments of ``fem.size_model``, checked once,
and ``Accuracy``, the option object of what a sizing must meet and how it searches.

The constructor resolves a scene name to its part and gripper, checks the move (a
jaxflex.Move: samples at rest at both ends and their step, one object) and every number, and
refuses what no sizing can use with an InputError naming the argument (``tolerance:
...`` for a field of the option object); the stages (fem.sizing.run) take its values as
they are.
"""

from __future__ import annotations

import itertools
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
STAGES = ("mesh", "points", "modes")  # the order of the shares


def _check_shares(shares: Any) -> tuple[float, float, float]:
    name = "shares"
    try:
        values = tuple(float(s) for s in shares)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: three numbers (mesh, points, modes), got {shares!r}") from exc
    if len(values) != 3 or any(not (0 < s <= 1) for s in values) or sum(values) > 1 + 1e-12:
        raise InputError(
            f"{name}: three fractions of the tolerance in (0, 1] for mesh, points and modes, "
            f"summing to at most 1, got {shares!r}"
        )
    return values  # type: ignore[return-value]


def _check_mesh_sizes(sizes: Any) -> tuple[float, ...] | None:
    name = "mesh_sizes_m"
    if sizes is None:
        return None
    if isinstance(sizes, str) or not isinstance(sizes, Sequence | np.ndarray):
        raise InputError(f"{name}: None or element sizes in m, coarse to fine, got {sizes!r}")
    values = tuple(check_positive(f"{name}[{i}]", h) for i, h in enumerate(sizes))
    if len(values) < 2 or any(b >= a for a, b in itertools.pairwise(values)):
        raise InputError(
            f"{name}: give at least two element sizes in m, coarse to fine (strictly "
            f"decreasing), got {list(sizes)}"
        )
    return values


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
class Accuracy:
    """What :func:`fem.size_model` must meet and how it searches (SI units), checked when made
    (InputError naming the field, ``tolerance: ...``).

    ``tolerance``: the accuracy as a fraction (0.01 = 1 %) of the peak deviation and of the
    cycle time, 0 < tolerance < 0.5; ``shares``: the fractions of it for the mesh, points and
    modes stages (each in (0, 1], summing to at most 1); ``mesh_sizes_m``: base element sizes
    to try, coarse to fine, at least two (None: fem.sizing.levels.REFINEMENT, 4 ... 1/2 x the
    part's element size for plates, 4 ... 1 x for thin solids; the cup element size is
    CUP_RATIO x the base size); ``reference_modes`` (>= 2): modes computed at first, raised
    by MODES_GROWTH up to ``max_modes`` (>= reference_modes) while the truncated modes'
    quasi-static residual is too large; ``eval_step_s`` (s): the step of the evaluation grid
    (None: dt / ceil(16 dt f_10), 16 samples per period of the 10th mode, a whole fraction
    of dt)."""

    tolerance: float = 0.01
    shares: tuple[float, float, float] = DEFAULT_SHARES
    mesh_sizes_m: tuple[float, ...] | None = None
    reference_modes: int = 40
    max_modes: int = 160
    eval_step_s: float | None = None

    def __post_init__(self) -> None:
        tolerance = check_positive("tolerance", self.tolerance)
        if tolerance >= 0.5:
            raise InputError(
                f"tolerance: a fraction in (0, 0.5) (0.01 = 1 %), got {tolerance!r}"
                + (f"; did you mean {tolerance / 100:g}?" if tolerance < 50 else "")
            )
        object.__setattr__(self, "tolerance", tolerance)
        object.__setattr__(self, "shares", _check_shares(self.shares))
        object.__setattr__(self, "mesh_sizes_m", _check_mesh_sizes(self.mesh_sizes_m))
        reference_modes = _check_count("reference_modes", self.reference_modes, 2)
        object.__setattr__(self, "reference_modes", reference_modes)
        max_modes = _check_count("max_modes", self.max_modes, reference_modes)
        object.__setattr__(self, "max_modes", max_modes)
        if self.eval_step_s is not None:
            step = check_positive("eval_step_s", self.eval_step_s)
            object.__setattr__(self, "eval_step_s", step)

    def share(self, stage: str) -> float:
        """The part of the tolerance (a fraction of the peak) that ``stage`` ("mesh",
        "points" or "modes") may use."""
        return self.shares[STAGES.index(stage)] * self.tolerance


@dataclass(frozen=True)
class SizingRequest:
    """The arguments of ``fem.size_model`` (see there) in their final form: ``part`` a Part,
    ``supports`` a list, ``move`` a Move ((n+1, 3) m/s^2 at rest at both ends and their
    step, s), ``accuracy`` an :class:`Accuracy`, numbers checked. The defaults are
    size_model's."""

    part: Part | str
    supports: Any
    move: Move
    threshold_m: float | None
    accuracy: Accuracy
    zeta: Any = 0.02
    key_points: Any = None
    allow_rigid_modes: bool = False
    progress: bool | None = None

    def __post_init__(self) -> None:
        part, supports = _part_and_supports(self.part, self.supports)
        self._set("part", part)
        self._set("supports", supports)
        self._check_move()
        if not isinstance(self.accuracy, Accuracy):
            raise InputError(
                "accuracy: an fem.Accuracy (e.g. fem.Accuracy(tolerance=0.01)), got "
                f"{self.accuracy!r}"
            )
        zeta = self.zeta
        if isinstance(zeta, int | float) and not zeta > 0:  # arrays, Rayleigh: fem.modal checks
            raise InputError(f"zeta: must be > 0 for the deviation to settle, got {zeta!r}")
        self._set("allow_rigid_modes", bool(self.allow_rigid_modes))

    def _set(self, field: str, value: Any) -> None:
        object.__setattr__(self, field, value)

    def _check_move(self) -> None:
        if not isinstance(self.move, Move):
            got = "nothing" if self.move is None else f"a {type(self.move).__name__}"
            raise InputError(
                f"move: a jaxflex.Move (the samples and their step together), got {got}; "
                "call fem.size_model(part, supports, jaxflex.as_move(acc, dt_s), threshold_m)"
            )
        move = as_move(self.move, at_rest=True, name="move")
        if not np.any(move.acc):
            raise InputError("move: every sample is 0; the part does not move")
        if self.threshold_m is None:
            raise InputError("threshold_m: the settle threshold in m is required")
        self._set("threshold_m", check_positive("threshold_m", self.threshold_m))
