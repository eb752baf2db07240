"""The cell's constraints and the robust grid on moves that turn the part (optim.turn_cell).

Each constraint family is made active on a turning scene (its limit below what the
unconstrained optimum reaches) and the returned move is checked independently: the cups
and stresses by the turning engine's outputs (jaxflex._turning_outputs.turning_loads) on the
same continuous profiles sampled 10 x finer, over the move and 2 s of settling; the
distance by every node's world position written here (the turn's angle integrated in closed
form by jaxflex._pose on the refined grid, the pivot's path by tests/independent.py's own
integration, the elastic displacement from the refined turning response) on a grid 8 x
finer than the samples. The robust optimum is re-timed on every model of its grid."""

from __future__ import annotations

import numpy as np
import pytest
from independent import path_positions

import jaxflex
import optim
from jaxflex._cell import Box, Cell
from jaxflex._engine import upsample
from jaxflex._pose import fixed_axis_path
from jaxflex._rotation_residual import rotation_residual
from jaxflex._turning import Turn, turning_inputs
from jaxflex._turning_outputs import turning_loads
from optim.cell_file import cell_from_dict
from optim.search import make_problem
from optim.turn import TurnSchedule, TurnSpec
from optim.turn_baselines import turn_worst_case
from optim.turn_cell import TurnDistanceFamily, TurnLoadFamily, TurnSource, move_times

DT = 0.01
THRESHOLD = 5e-4
LIMITS = optim.Limits(vmax=2.0, amax=10.0, jmax=100.0)
PIVOT = (0.6, 0.4, 0.0)  # the middle of the cups
TILT = {"rotation": optim.Rotation("x", 30.0, pivot_m=PIVOT)}
LIFT = ((0, 0, 1.0), LIMITS, DT, THRESHOLD)  # lifted 1 m while it tilts (TILT)
SWIVEL = {"rotation": optim.Rotation("z", 90.0, pivot_m=PIVOT)}


@pytest.fixture(scope="module")
def plate(turning_plate):
    return turning_plate


def _fine_turn(result, factor: int) -> Turn:
    """The optimised turning move with its profiles sampled ``factor`` x finer (the same
    linear profiles)."""
    spec = result.turn
    fine = upsample(result.angular_acc, factor, np)
    path = fixed_axis_path(np.asarray(spec.axis), fine, DT / factor)
    acc = upsample(result.acc, factor, np)
    return Turn(path, acc, pivot_m=spec.pivot_m, gravity_m_s2=spec.gravity_m_s2)


def _dense_loads(model, result, safety: float = 1.0, factor: int = 10, settle_s: float = 2.0):
    """(largest cup utilisation, largest von Mises) of the turning engine's outputs on the
    profiles sampled ``factor`` x finer, over the move and ``settle_s`` after it."""
    turn = _fine_turn(result, factor)
    loads = turning_loads(model, turn, extend_s=settle_s, cup_safety=safety)
    return float(loads.utilisation.max()), float(loads.von_mises_pa.max())


def _dense_distance(model, result, obstacles, half_m: float, factor: int = 8) -> float:
    """The smallest skin distance of every node on a grid ``factor`` x finer than the
    samples, over the move and 1 s after it (module docstring)."""
    turn = _fine_turn(result, factor)
    path, pivot = turn.path, turn.pivot_m
    inputs = turning_inputs(model, turn, extend_s=1.0)
    u = (
        np.einsum("kcm,tm->tkc", np.asarray(model.shapes), inputs.q)
        + np.einsum("kcm,tm->tkc", np.asarray(model.static_residual), inputs.base)
        + np.einsum("kcm,tm->tkc", rotation_residual(model), inputs.coefficients)
    )
    rotation = np.asarray(path.rotation)
    rotation = np.concatenate(
        [rotation, np.repeat(rotation[-1:], len(inputs.t_s) - len(rotation), 0)]
    )
    local = np.asarray(model.points)[None] - pivot + u
    world = pivot + path_positions(result.acc, DT, inputs.t_s)[:, None]
    world = world + np.einsum("tab,tkb->tka", rotation, local)
    best = np.inf
    for obstacle in obstacles:
        d, _ = obstacle.closest(world.reshape(-1, 3))
        best = min(best, float(d.min()))
    return best - half_m


def test_rows_are_exact_for_the_schedule(plate):
    """For a fixed turn schedule a load row (the cut at one time and cup) and a distance row
    are affine in the translation samples: built at one move, they give the cut's value
    and the plane's distance of another random move (evaluated anew) to round-off."""
    spec = TurnSpec.of(optim.Rotation("x", 30.0, pivot_m=PIVOT))
    problem = make_problem(plate, np.array([0, 0, 1.0]), LIMITS, DT, THRESHOLD, 200, None)
    problem.turn = TurnSchedule(spec, DT)
    source = TurnSource(spec)
    source.schedule = problem.turn
    n = 90
    rng = np.random.default_rng(3)
    first, second = rng.normal(size=(2, n + 1, 3))
    cups = TurnLoadFamily.cups(plate, 1.0, source)
    axes = (0, 1, 2)
    during = move_times(n, DT)
    j, item = 333, 2  # a time between samples, within the move
    motion = cups.motion(jaxflex.as_move(first, DT), during, [])
    row = cups._turn_row(motion, j, item, axes)
    g = cups.functional.cut(cups.outputs_of(motion)[j, cups._rows_of(item)], item)
    again = cups.motion(jaxflex.as_move(second, DT), during, [])
    value = g @ cups.outputs_of(again)[j, cups._rows_of(item)]
    linear = np.sum(row.coef * second) + (cups.limit * (1 - 1e-3) - row.rhs * cups.limit)
    assert linear == pytest.approx(value, rel=1e-9, abs=1e-12)
    box = Box(np.array([0.6, 0.4, -0.3]), np.array([2.0, 2.0, 0.2]), name="floor")
    family = TurnDistanceFamily(plate, [box], 0.01, 5e-4, source)
    motion = family.motion(jaxflex.as_move(first, DT), during, [])
    plane = family._row(motion, j, 7, axes)
    p = family.motion(jaxflex.as_move(second, DT), during, []).positions(np.array([7]))[j, 0]
    # the row: -coef . a <= rhs, rhs = n . (p - c) - coef . a at the first move - margin
    margin = 0.01 * (1 + 1e-3) + 5e-4
    gap = -np.sum(plane.coef * second) * 0.01 + plane.rhs * 0.01 + margin  # n . (p(a2) - c)
    assert gap == pytest.approx(p[2] - (-0.2), rel=1e-9)


def test_active_cups_on_a_tilt(plate):
    """Cups 15 % below what the unconstrained tilt reaches: the optimum changes, keeps the
    limit (certified), and the dense evaluation never finds more than the limit (the rows
    keep 1e-3 in reserve, the finer sampling of the body-frame loads changes the outputs
    by O(dt^2): measured 6e-5 of the peak)."""
    plain = optim.optimize(plate, *LIFT, constraints=optim.Constraints(cup_safety=1.0), **TILT)
    peak = plain.constraints[0]["peak"]
    safety = 1.0 / (0.85 * peak)
    result = optim.optimize(plate, *LIFT, constraints=optim.Constraints(cup_safety=safety), **TILT)
    assert not np.array_equal(result.acc, plain.acc)
    assert result.cycle_time_s >= plain.cycle_time_s
    assert all(
        result.objective_s <= b.score() for b in result.baselines.entries if b.constraints_ok
    )
    (constraint,) = result.constraints
    assert constraint["bound"] <= 1.0
    assert constraint["peak"] > 0.99  # active
    dense, _ = _dense_loads(plate, result, safety)
    assert constraint["peak"] - 1e-3 <= dense <= 1.0 * (1 + 1e-9)
    assert result.turn.as_dict()["angle_deg"] == pytest.approx(30.0)


@pytest.mark.slow
def test_active_stress_on_a_tilt(plate):
    """Von Mises 15 % below the unconstrained tilt's peak: held, and the dense evaluation
    stays below the limit (as for the cups)."""
    plain = optim.optimize(plate, *LIFT, constraints=optim.Constraints(max_stress_pa=1e12), **TILT)
    limit = 0.85 * plain.constraints[0]["peak"]
    result = optim.optimize(
        plate, *LIFT, constraints=optim.Constraints(max_stress_pa=limit), **TILT
    )
    assert result.cycle_time_s >= plain.cycle_time_s
    (constraint,) = result.constraints
    assert 0.99 * limit < constraint["peak"] <= constraint["bound"] <= limit
    _, dense = _dense_loads(plate, result)
    assert dense <= limit * (1 + 1e-9)


@pytest.mark.slow
def test_active_distance_on_a_swivel(plate, tmp_path):
    """The plate swivelled 90 degrees about the vertical while it moves 1 m along x sweeps a
    corner past a post placed 5.5 mm (skins) from the unconstrained optimum's path: with 10
    mm required the move changes, the certified distance (turning_min_distance) holds, and
    the dense evaluation of every node finds no point closer than the certified distance
    less its sampling (a point moves at most 2 m/s + 3 rad/s x 0.72 m = 4.2 m/s, 1.25 ms
    of it between the dense samples: 2.6 mm over the tolerance it can miss by, far below
    what the check tests, which is that nothing is inside the 10 mm)."""
    plain = optim.optimize(plate, (1.0, 0, 0), LIMITS, DT, THRESHOLD, **SWIVEL)
    far = Box(np.array([1.27, -0.73, 0.0]), np.array([0.05, 1.0, 0.3]), name="post")
    start = _dense_distance(plate, plain, [far], 5e-4)
    post = Box(far.centre_m + np.array([0.0, start - 0.0055, 0.0]), far.size_m, name="post")
    cell = Cell(obstacles=(post,), end_m=np.array([1.0, 0.0, 0.0]), thickness_m=1e-3)
    assert _dense_distance(plate, plain, cell.obstacles, 5e-4) < 0.0075  # plain violates
    in_cell = {"constraints": optim.Constraints(cell=cell, min_distance_m=0.01), **SWIVEL}
    result = optim.optimize(plate, None, LIMITS, DT, THRESHOLD, **in_cell)
    (constraint,) = result.constraints
    assert constraint["bound"] >= 0.01 * (1 - 1e-9)
    dense = _dense_distance(plate, result, cell.obstacles, 5e-4)
    assert dense >= constraint["bound"] - 1e-6
    assert result.cycle_time_s > plain.cycle_time_s


def test_robust_turning_move_holds_on_every_model(plate):
    """--robust with --rotate: the optimum's worst case over the grid, re-timed model by
    model here, is the reported one and no worse than any baseline's worst case; the
    nominal optimum's worst case is longer (the robust mode buys something)."""
    robust = optim.RobustSpec(freq_scale=(0.9, 1.1), zeta=(0.01, 0.03), n_freq=3, n_zeta=2)
    result = optim.optimize(plate, (0, 0, 1.0), LIMITS, DT, THRESHOLD, robust=robust, **TILT)
    worst, _, points = turn_worst_case(
        plate, result.turn, result.move, result.angular_acc, THRESHOLD, robust.grid()
    )
    assert len(points) == 6
    assert worst == pytest.approx(result.worst_case["cycle_time_s"], abs=1e-9)
    assert all(worst <= b.score() + 1e-9 for b in result.baselines.entries)
    nominal = optim.optimize(plate, *LIFT, **TILT)
    nominal_worst = turn_worst_case(
        plate, nominal.turn, nominal.move, nominal.angular_acc, THRESHOLD, robust.grid()
    )[0]
    assert nominal_worst >= worst


def test_turning_refusals_name_what_does(plate):
    """The gradient route refuses the cell's constraints on a turning move too, naming the
    exact route; a via orientation in another form than rotation_deg is refused, naming the
    field and the form (tests/test_optim_via_orientations.py takes rotation_deg)."""
    with pytest.raises(jaxflex.InputError, match="the exact route does: method='exact'"):
        gradient = {
            "search": optim.Search("gradient"),
            "constraints": optim.Constraints(cup_safety=1.5),
        }
        optim.optimize(plate, (0, 0, 1), LIMITS, DT, THRESHOLD, **gradient, **TILT)
    base = {"path": {"end_m": [0, 0, 1.0]}, "part": {"thickness_m": 1e-3}}
    with pytest.raises(jaxflex.InputError, match=r"via\[0\].*orientation is rotation_deg ="):
        via = [{"position_m": [0, 0, 0.5], "orientation_deg": [0, 0, 45]}]
        cell_from_dict({**base, "path": {"end_m": [0, 0, 1.0], "via": via}})


def test_turning_move_passes_the_via_point(plate, tmp_path):
    """A tilt along a cell path with a blended via point (0.1 m per axis) and cups: the
    move passes within the tolerance at a sample (positions integrated here), no worse
    than the via-point baseline (ruckig stopping at it, the turn stretched over the path),
    its cups are certified, and its files include the constraints' plot."""
    via = [{"position_m": [0.0, 0.0, 0.5], "mode": "blend", "tolerance_m": 0.1}]
    cell = cell_from_dict(
        {"path": {"end_m": [0.6, 0.0, 0.6], "via": via}, "part": {"thickness_m": 1e-3}}
    )
    in_cell = {"constraints": optim.Constraints(cell=cell, cup_safety=1.5), **TILT}
    result = optim.optimize(plate, None, LIMITS, DT, THRESHOLD, **in_cell)
    (baseline,) = result.baselines.entries
    assert baseline.name.startswith("ruckig via points")
    assert result.objective_s <= baseline.score()
    pos = path_positions(result.acc, DT, DT * np.arange(result.n_steps + 1))
    assert np.abs(pos - [0.0, 0.0, 0.5]).max(axis=1).min() <= 0.1 * (1 + 1e-9)
    (constraint,) = result.constraints
    assert constraint["bound"] <= 1.0
    result.save(tmp_path)
    assert (tmp_path / "constraints.png").stat().st_size > 0
    assert (tmp_path / "turn.png").stat().st_size > 0
