"""The cell's options of ``optim.optimize``: the posed model, the path, the constraint families.

``optim.optimize(model, None, limits, dt_s, threshold_m, cell=cell, min_distance_m=0.01,
cup_safety=1.5, max_stress_pa="yield")``: the model is posed in the cell (its points at the
part's place at A, accelerations in cell coordinates), the move goes from A through the via
points to B, and each limit becomes a family of optim.cell_rows, for the nominal model and,
with a robust grid, for every model of it (optim.cell_scenarios). What no move can change is
checked first: the part at rest at A and at B (its exact sag under gravity included, its
skins half its thickness off the mid-surface) must keep the distance, and gravity alone must
leave the cups and the stress within their limits.

The distance is that of the part's skins: the sheet's thickness comes from the cell file
([part] thickness_m) or the model (fem writes it into the meta); a model that states none
needs the cell's.
"""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass, field

import numpy as np

from jaxflex.errors import InputError
from jaxflex.files import check_positive
from jaxflex.geometry import (
    DEFAULT_GRAVITY_M_S2,
    Cell,
    distances,
    gravity_offset,
    part_half_thickness,
)
from jaxflex.model import ModalModel
from jaxflex.response import DEFAULT_STRESS_SAFETY, CupSet, Move
from optim.cell_rows import DistanceFamily, LoadFamily
from optim.cell_scenarios import ScenarioFamily, measured
from optim.kinematics import clean_distance
from optim.options import RobustSpec
from optim.turn_cell import TurnDistanceFamily, TurnLoadFamily, TurnSource, rest_at_end


@dataclass
class CellSetup:
    """The posed model, the move, gravity, via points and the constraint families; ``advice``
    (jaxflex._advice pairs) says what the model cannot make exact."""

    model: ModalModel
    distance_m: np.ndarray  # (3,) m, the move from A to B
    gravity_m_s2: np.ndarray
    via: list = field(default_factory=list)  # (offset (3,), mode, tolerance) from the start
    families: list = field(default_factory=list)
    cell: Cell | None = None
    advice: list = field(default_factory=list)
    turn_source: TurnSource | None = None  # the turn the families evaluate (turning moves)

    def describe_move(self, move: Move, angular_acc=None) -> list[dict]:
        """The certified value of every family for ``move`` (with the turn ``angular_acc``
        (n+1,) rad/s^2 of a turning move)."""
        return self.feasible(move, angular_acc)[1]

    def feasible(
        self, move: Move, angular_acc=None, *, every: bool = True
    ) -> tuple[bool, list[dict]]:
        """(every family holds, the families' certified values, the worst located) for
        ``move`` (every model of a robust grid checked, or without ``every`` up to the first
        that fails; a turning move with its turn ``angular_acc``)."""
        with self._turning(angular_acc):
            found = [_measure_all(f, move, every) for f in self.families]
        ok = all(f.holds(x) for f, x in zip(self.families, found, strict=True))
        return ok, [f.describe(x) for f, x in zip(self.families, found, strict=True)]

    def curves(self, move: Move, t: np.ndarray, angular_acc=None) -> dict[str, np.ndarray]:
        """What each family limits at times ``t`` during and after ``move`` (for plots; the
        nominal model)."""
        with self._turning(angular_acc):
            return {f.name: f.curve(move, t) for f in self.families}

    def _turning(self, angular_acc):
        if self.turn_source is None:
            return nullcontext()
        return self.turn_source.holding(angular_acc)


def posed_in(cell: Cell, model: ModalModel) -> ModalModel:
    """``cell.posed(model)``, posed once per model and pose (the last one kept): the plan's
    obstacle pruning (optim.obstacle_reach) and :func:`prepare_cell` share it (posing the
    plate's 10 821 points, cups and stress points costs about 0.4 s of CPU)."""
    cache = model.__dict__.setdefault("_cell_posed", {})
    key = (np.asarray(cell.rotation).tobytes(), np.asarray(cell.start_m).tobytes())
    if key not in cache:
        cache.clear()
        cache[key] = cell.posed(model)
    return cache[key]


def _measure_all(family, move: Move, every: bool):
    """A family's report of ``move`` (a robust family's on every model of its grid, or up to
    the first that fails without ``every``)."""
    if isinstance(family, ScenarioFamily):
        return family.measure(move, every=every)
    return measured(family, move)


def with_cup_rating(
    model: ModalModel, *, friction: float | None = None, vacuum_pa: float | None = None
) -> ModalModel:
    """``model`` with every cup's friction coefficient and/or vacuum (Pa; the holding force
    becomes vacuum x pi r^2) replaced."""
    cups = model.cups
    if cups is None:
        raise InputError("cups: the model has no cup reactions to rate")
    holding = np.asarray(cups.holding_force_n)
    if vacuum_pa is not None:
        holding = check_positive("vacuum_pa", vacuum_pa) * np.pi * np.asarray(cups.radius_m) ** 2
    mu = np.asarray(cups.friction)
    if friction is not None:
        mu = np.full(cups.n_cups, check_positive("friction", friction))
    rated = CupSet(cups.centre_m, cups.normal, cups.radius_m, holding, mu, cups.reaction)
    return model.with_outputs(cups=rated)


def _stress_limit(model: ModalModel, max_stress_pa) -> float:
    if isinstance(max_stress_pa, str):
        if max_stress_pa != "yield":
            raise InputError(f"max_stress_pa: a stress in Pa or 'yield', got {max_stress_pa!r}")
        yield_pa = dict(model.meta).get("material", {}).get("yield_pa")
        if not yield_pa:
            raise InputError(
                "max_stress_pa: the model's material states no yield strength; give the limit "
                "in Pa (--max-stress PA)"
            )
        return float(yield_pa) / DEFAULT_STRESS_SAFETY
    return check_positive("max_stress_pa", max_stress_pa)


def prepare_cell(
    model: ModalModel,
    distance_m,
    *,
    cell: Cell | None = None,
    min_distance_m: float | None = None,
    max_stress_pa: float | str | None = None,
    cup_safety: float | None = None,
    robust: RobustSpec | None = None,
    turn=None,
) -> CellSetup:
    """The :class:`CellSetup` of ``optim.optimize``'s cell options (module docstring); with
    ``robust`` every family holds on every model of its grid; with ``turn`` (an
    optim.turn.TurnSpec in cell coordinates) the families are those of a turning part
    (optim.turn_cell)."""
    if cell is not None:
        if not isinstance(cell, Cell):
            raise InputError(f"cell: expected a jaxflex.geometry.Cell, got {type(cell).__name__}")
        if distance_m is not None and not np.allclose(distance_m, cell.distance_m, atol=1e-9):
            raise InputError(
                f"distance_m: {list(distance_m)} differs from the cell's move "
                f"{cell.distance_m.tolist()} (end_m - start_m); give one of them"
            )
        model = posed_in(cell, model)
        distance = clean_distance(cell.distance_m)
        gravity = cell.gravity_m_s2
        via = cell.via_offsets()
    else:
        if distance_m is None:
            raise InputError("distance_m: required without a cell (the move, m)")
        distance = clean_distance(distance_m)
        gravity = np.array(DEFAULT_GRAVITY_M_S2)
        via = []
    source = None if turn is None else TurnSource(turn)
    setup = CellSetup(model, distance, gravity, via, cell=cell, turn_source=source)
    makers = []
    if min_distance_m is not None:
        if cell is None or not cell.obstacles:
            raise InputError("min_distance_m: needs a cell with obstacles (--cell FILE)")
        margin = check_positive("min_distance_m", min_distance_m)
        half = _half_thickness(model, cell)
        if turn is None:
            makers.append(lambda m: DistanceFamily(m, cell.obstacles, margin, gravity, half))
        else:
            makers.append(lambda m: TurnDistanceFamily(m, cell.obstacles, margin, half, source))
        _check_rest(setup, margin, half)
    if cup_safety is not None:
        if model.cups is None:
            raise InputError(
                "cup_safety: the model has no cup reactions (make it with fem or `jaxflex model`"
                " of this version)"
            )
        safety = check_positive("cup_safety", cup_safety)
        makers.append(_load_maker("cups", safety, gravity, source))
    if max_stress_pa is not None:
        if model.stress is None:
            raise InputError(
                "max_stress_pa: the model has no stresses (make it with fem or `jaxflex model` "
                "of this version)"
            )
        limit = _stress_limit(model, max_stress_pa)
        makers.append(_load_maker("stress", limit, gravity, source))
    if makers:
        setup.advice += _static_advice(model)
    for make in makers:
        family = make(model)
        if isinstance(family, LoadFamily):
            _check_static(family, [gravity] if turn is None else turn.rest_gravities())
        if robust is None:
            setup.families.append(family)
        else:
            loads = isinstance(family, LoadFamily)
            setup.families.append(ScenarioFamily(make, model, robust, outputs=loads))
    return setup


def _load_maker(kind: str, limit: float, gravity, source: TurnSource | None):
    """The family of one model (``kind`` "cups" or "stress"): a straight move's
    (optim.cell_rows) or, with a turn ``source``, a turning move's (optim.turn_cell)."""
    if source is None:
        return lambda m: getattr(LoadFamily, kind)(m, limit, gravity)
    return lambda m: getattr(TurnLoadFamily, kind)(m, limit, source)


def _static_advice(model: ModalModel) -> list:
    """Advice (jaxflex._advice pairs) for a model whose static response is not the FE's."""
    note = str(dict(model.meta).get("static_response", "none recorded"))
    if model.static_shapes is not None and not note.startswith("schema"):
        return []
    return [
        (
            "static_response",
            f"the model's static response is not the FE's ({note}); the cell's constraints "
            "use it as it is. Re-create the model (`jaxflex model`) for the exact sag and "
            "loads under gravity",
        )
    ]


def _half_thickness(model: ModalModel, cell: Cell) -> float:
    """Half the sheet's thickness (m): the cell file's, else the model's (InputError if
    neither states it: the distance is that of the part's skins)."""
    if cell.thickness_m is not None:
        return 0.5 * cell.thickness_m
    half = part_half_thickness(model)
    if half is None:
        raise InputError(
            "min_distance_m: the model does not state the part's thickness (a model from "
            "modal results), and the distance is that of the part's skins; give it in the "
            "cell file: [part] thickness_m = ..."
        )
    return half


def _check_rest(setup: CellSetup, margin: float, half_thickness_m: float) -> None:
    """The part (its skins) at rest at A and at B must keep ``margin`` from every obstacle."""
    base = np.asarray(setup.model.points) + gravity_offset(setup.model, setup.gravity_m_s2)
    if setup.turn_source is None:
        end = base + setup.distance_m
    else:  # turned about the pivot, sagging in the final pose
        end = rest_at_end(setup.model, setup.turn_source.spec, setup.distance_m)
    obstacles = setup.cell.obstacles
    for where, points in (("A (start)", base), ("B (end)", end)):
        d, which, _ = distances(obstacles, points)
        d = d - half_thickness_m
        k = int(np.argmin(d))
        if d[k] < margin:
            name = getattr(obstacles[which[k]], "name", str(which[k]))
            raise InputError(
                f"min_distance_m: at rest at {where} point {k} is {d[k] * 1e3:.3g} mm from "
                f"obstacle {name!r}, less than {margin * 1e3:g} mm; no move can change that"
            )


def _check_static(family: LoadFamily, gravities) -> None:
    """Gravity alone (each of ``gravities`` (3,) m/s^2, model frame: at rest at A, and in a
    turning move's final pose) must stay within the family's limit."""
    items = np.arange(family.functional.n_items)
    offsets = np.stack([family.outputs.offset(g) for g in gravities])
    values = family.functional.values(offsets.reshape(len(offsets), len(items), -1), items)
    k = int(np.argmax(values.max(axis=0)))
    values = values.max(axis=0)
    if values[k] > family.limit:
        raise InputError(
            f"{family.name}: gravity alone gives {values[k]:.4g} at item {k}, more than the limit "
            f"{family.limit:.4g}; no move can change that (more cups, a lower safety factor or "
            "a higher limit)"
        )
