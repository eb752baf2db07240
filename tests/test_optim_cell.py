"""The cell's constraints in the optimiser: obstacles and via points, cup forces, stress."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from cells import PRESS_TOML, press_cell
from conftest import run_jaxflex
from hypothesis import given, settings
from hypothesis import strategies as st
from independent import (
    box_distance,
    half_space_distance,
    modal_states_lsim,
    output_peak_lsim,
    path_positions,
    skin_points,
    static_nodes,
)

import fem
import optim
from jaxflex._cell import Box, Cell
from jaxflex._collision import distances, min_distance, positions_at
from jaxflex._loads import CupUtilisation, VonMises
from jaxflex._profile import as_move, integrate
from jaxflex.errors import InputError
from optim.cell_file import load_cell
from optim.cell_rows import (
    ROW_MARGIN,
    SCAN_RTOL,
    DistanceFamily,
    LoadFamily,
    _local_peaks,
    _worst_samples,
    check_times,
)
from optim.plots import CURVE_STRIDE, INSET_S, constraint_times
from optim.robust import perturbed
from optim.ruckig_move import kinematic_floor_move

DT = 0.01
LIMITS = optim.Limits(2.0, 10.0, 100.0)
THRESHOLD = 5e-4
GRAVITY = np.array([0.0, 0.0, -9.81])
EXAMPLE_CELL = Path(__file__).resolve().parents[1] / "examples" / "press_cell.toml"


@pytest.fixture(scope="module")
def model_all_nodes(fe_result):
    """The part of ``fe_result`` at every FE node, 8 modes and its static residual."""
    return fe_result.to_modal_model(points=None).truncate_modes(8)


@pytest.fixture(scope="module")
def model():
    """A 0.6 x 0.4 m, 1 mm steel plate on four cups (47-76 Hz, 8 modes, 54 points)."""
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.025)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    result = fem.modal_analysis(part, cups, n_modes=8, zeta=0.02)
    return result.to_modal_model(points=60)


def press(via_mode: str = "blend") -> Cell:
    """The press-opening scene of tests/cells.py (a straight move hits the lower die)."""
    return press_cell(via_mode)


@pytest.fixture(scope="module")
def fe_result():
    """The plate of ``model`` with 40 modes: the independent check's part (no discretisation
    estimate: the checks compare with this mesh's own modes and static solve, and the
    estimate, a second analysis with static stress peaks, is about half of its cost)."""
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.025)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    return fem.modal_analysis(
        part, cups, n_modes=40, zeta=0.02, error_estimate=False, progress=False
    )


def cell_posed(model):
    """``model`` posed in the press scene's cell (its points where the part is at A)."""
    return press().posed(model)


def independent_distance(result, n_modes, cell, acc, until_s, step_s=1e-4) -> float:
    """The smallest distance of the part's skins to the cell's boxes and half-spaces, by a
    computation that shares no code with jaxflex (tests/independent.py): every FE node, both
    skins (+-h/2 along the plate's normal), a 0.1 ms grid over the move and ``until_s``, the
    first ``n_modes`` modes by scipy's lsim, the sag under gravity by a direct FE solve.
    The minimum is exact but not every point is measured: each distance here is a signed
    Euclidean distance (1-Lipschitz) and a skin point lies h/2 from its mid-surface point, so
    a mid point whose lower bound (a box's: the largest axis gap, at most the distance; a
    half-space's: the distance itself) less h/2 is not below the smallest distance found so
    far cannot give a smaller one; the others' skins are measured as they are. A chunk of
    times is passed over for an obstacle at once where the same lower bound over the box
    around all its mid points (each point's bound is at least it) is not below either."""
    rotation, start = cell.rotation, cell.start_m
    g_part = rotation.T @ cell.gravity_m_s2
    t = step_s * np.arange(round(until_s / step_s) + 1)
    q = modal_states_lsim(
        result.freq_hz[:n_modes], result.zeta[:n_modes], result.gamma[:n_modes],
        acc @ rotation, DT, t,
    )  # fmt: skip
    rest = result.system.nodes + static_nodes(result, -g_part)
    shapes = result.node_shapes()[:, :, :n_modes]
    path = path_positions(acc, DT, t)
    thickness = result.part.thickness_m
    # the shapes and the rest in the cell's frame by coordinate (3, N, M), (3, N): per chunk
    # of times one contiguous (times, N) array of mid points per coordinate
    world = np.einsum("ij,kjm->ikm", rotation, shapes)
    rest = (rest @ rotation.T + start).T
    best = np.inf
    for chunk in np.array_split(np.arange(len(t)), max(1, len(t) // 500)):
        mid = [q[chunk] @ world[i].T for i in range(3)]
        for i, coordinate in enumerate(mid):
            coordinate += rest[i]
            coordinate += path[chunk, i][:, None]
        lo, hi = np.array([c.min() for c in mid]), np.array([c.max() for c in mid])
        for o in cell.obstacles:
            if isinstance(o, Box):  # the axis gaps' bound at the box's point nearest the centre
                centre, half = np.asarray(o.centre_m), np.asarray(o.size_m) / 2
                around = np.max(np.abs(np.clip(centre, lo, hi) - centre) - half)
            else:  # the half-space's distance at the box's lowest corner, less round-off
                n = np.asarray(o.normal, dtype=float) / np.linalg.norm(o.normal)
                around = np.minimum(n * lo, n * hi).sum() - o.offset_m - 1e-9
            if around - thickness / 2 >= best:
                continue
            if isinstance(o, Box):  # the largest axis gap
                low = np.abs(mid[0] - centre[0]) - half[0]
                for i in (1, 2):
                    np.maximum(low, np.abs(mid[i] - centre[i]) - half[i], out=low)
            else:
                low = mid[0] * n[0] + mid[1] * n[1] + mid[2] * n[2] - o.offset_m
            keep = low - thickness / 2 < best
            if not keep.any():
                continue
            skins = skin_points(np.column_stack([c[keep] for c in mid]), rotation[:, 2], thickness)
            if isinstance(o, Box):
                d = box_distance(skins, o.centre_m, o.size_m)
            else:
                d = half_space_distance(skins, o.normal, o.offset_m)
            best = min(best, float(d.min()))
    return best


@pytest.fixture(scope="module")
def press_result(model_all_nodes):
    """The optimised via-point move of ``model_all_nodes`` through :func:`press`, 10 mm from
    the obstacles."""
    return optim.optimize(
        model_all_nodes,
        None,
        LIMITS,
        DT,
        THRESHOLD,
        constraints=optim.Constraints(cell=press(), min_distance_m=0.01),
    )


def test_press_opening_via_point_move(model_all_nodes, fe_result, press_result):
    """The optimised via-point move passes the press opening with the requested 10 mm from
    the part's skins, certified; an independent evaluation (every FE node, both skins, a
    0.1 ms grid over the move and 1 s of settling, scipy's lsim of 40 modes, the sag by a
    direct FE solve) finds no distance below the certified bound, up to the model error of 8
    modes and the static residual against 40 (measured here: below 2 um); the straight move
    collides; the optimum is faster than the ruckig move through the same via point plus its
    decay (the feasible baseline)."""
    model, cell, result = model_all_nodes, press(), press_result
    (constraint,) = result.constraints
    assert constraint["bound"] >= 0.01 * (1 - 1e-9)
    assert constraint["points"] == len(fe_result.system.nodes)
    assert constraint["half_thickness_m"] == 0.5e-3
    until = result.n_steps * DT + 1.0
    dense = independent_distance(fe_result, 40, cell, result.acc, until)
    assert dense >= constraint["bound"] - 2e-6
    assert dense <= 0.0105  # the constraint is active: the part passes the die's corner
    (baseline,) = result.baselines.entries
    assert baseline.constraints_ok
    assert result.cycle_time_s < baseline.cycle_time_s
    straight = kinematic_floor_move(cell.distance_m, LIMITS, DT, 1000).acc
    assert min_distance(cell.posed(model), cell.obstacles, as_move(straight, DT)).distance_m < 0
    report = result.report()
    assert report["frame"] == "cell" and report["constraints"][0]["obstacle"] == "lower die"


def _pruning_moves(press_result, cell):
    """Moves that exercise every branch of the pruned searches on :func:`press`: the
    certified optimum (it passes the die's corner near the limit), the straight kinematic
    floor (it runs through the die) and the optimum lifted 20 % less (it grazes the die)."""
    lower = press_result.acc.copy()
    lower[:, 2] *= 0.8
    straight = kinematic_floor_move(cell.distance_m, LIMITS, DT, 1000).acc
    return [as_move(a, DT, at_rest=True) for a in (press_result.acc, straight, lower)]


def _same_places(found, expected) -> None:
    """The rows ``found`` and ``expected``, as (time s, value there), are at the same times
    with the same values: the same rows up to which of two items of equal value (the plate
    and the press are symmetric) a tie picks; values to the rounding of two evaluations."""
    assert len(found) == len(expected)
    if not expected:
        return
    (t_a, v_a), (t_b, v_b) = (np.array(sorted(rows)).T for rows in (found, expected))
    np.testing.assert_array_equal(t_a, t_b)
    np.testing.assert_allclose(v_a, v_b, rtol=1e-12, atol=1e-15)


def test_pruned_distance_agrees_with_every_point_at_every_time(model_all_nodes, press_result):
    """The distance family prunes twice (block centres every 8th check time with a speed
    bound between, then the blocks by their bound at each time) and certifies by branch and
    bound: on the press scene it gives the rows of evaluating every point at every check
    time (the same (time, point) pairs, each separating plane of a violation), the same
    smallest distance at every time, and a certificate whose bound no point on the check
    grid goes below (decided against the limit, or located to 1e-6 m)."""
    cell, model = press(), cell_posed(model_all_nodes)
    family = DistanceFamily(model, cell.obstacles, 0.01, GRAVITY, 0.5e-3)
    threshold = 0.01 * (1 + ROW_MARGIN - SCAN_RTOL)
    rows = 0
    for move in _pruning_moves(press_result, cell):
        t = check_times(model, move.n_steps, DT)
        every = positions_at(model, move, t, GRAVITY)  # (T, K, 3)
        dense = distances(cell.obstacles, every.reshape(-1, 3))[0].reshape(every.shape[:2])
        dense -= 0.5e-3
        expected = [(t[j], dense[j, k]) for j, k in _local_peaks(-dense, -threshold)]
        rows += len(expected)
        found = [
            (r.time_s, dense[np.searchsorted(t, r.time_s), r.item])
            for r in family.scan(move, (0, 2))
        ]
        _same_places(found, expected)
        # the same positions, summed in another order by the blocked evaluation: equal to
        # the round-off of a distance of 0.1 m (a few ulp, 1e-16 m), not bit for bit
        np.testing.assert_allclose(family.curve(move, t), dense.min(axis=1), rtol=0, atol=1e-15)
        decided, located = family.certify(move), family.measure(move)
        assert located.bound_m <= dense.min() + 1e-12  # the grid's smallest is attained
        assert located.distance_m - located.bound_m <= 1.01e-6  # CERTIFY_ATOL_M
        assert decided.bound_m <= dense.min() + 1e-12
        assert family.holds(decided) == family.holds(located) == (located.bound_m >= 0.01)
    assert rows  # the moves that run into the die give rows


@pytest.mark.parametrize("kind", ["cups", "stress"])
def test_pruned_loads_agree_with_every_item_at_every_time(model_all_nodes, press_result, kind):
    """The load families evaluate only the items whose bound reaches the limit, at the
    samples and between them where a curvature bound reaches it: on the press scene (limits
    that some moves break) they give the rows of evaluating every item at every check time,
    the same largest load at every time, a certified peak that no item on that grid exceeds,
    and for a model of a robust grid (its maps the nominal ones, column-scaled) the rows and
    peaks of the model whose scaled maps are built (jaxflex.model.with_frequency_scale)."""
    cell, model = press(), cell_posed(model_all_nodes)
    moves = _pruning_moves(press_result, cell)
    make = LoadFamily.cups if kind == "cups" else LoadFamily.stress
    unit = make(model, 1.0, GRAVITY)  # utilisation at safety 1, or the stress in Pa
    largest = max(unit.values(m, check_times(model, m.n_steps, DT)).max() for m in moves)
    # a limit that the move of the largest load breaks (safety factor, or Pa)
    family = make(model, 1 / (0.95 * largest) if kind == "cups" else 0.95 * largest, GRAVITY)
    above = family.limit * (1 - ROW_MARGIN + SCAN_RTOL)
    broken = 0
    for move in moves:
        t = check_times(model, move.n_steps, DT)
        dense = family.values(move, t)  # every item at every time
        found = [
            (r.time_s, dense[np.searchsorted(t, r.time_s), r.item])
            for r in family.scan(move, (0, 2))
        ]
        _same_places(found, [(t[j], dense[j, i]) for j, i in _worst_samples(dense, above)])
        np.testing.assert_allclose(family.curve(move, t), dense.max(axis=1), rtol=1e-12)
        decided, located = family.certify(move), family.measure(move)
        assert located.bound >= dense.max() * (1 - 1e-12)
        assert located.bound <= located.value * (1 + 1.01e-5)  # located to rtol 1e-5
        assert family.holds(decided) == family.holds(located)
        broken += not family.holds(located)
    assert broken  # the decided certificate located a peak above the limit
    scaled = family.scenario(0.9, 0.01)
    built = perturbed(model, 0.9, 0.01, outputs=True)
    outputs = built.cups.reaction if kind == "cups" else built.stress.stress
    copy = LoadFamily(family.name, built, outputs, family.functional, family.limit, GRAVITY)
    for move in moves[1:]:
        a, b = scaled.measure(move), copy.measure(move)
        assert a.value == pytest.approx(b.value, rel=1e-9) and a.item == b.item
        rows_a = scaled.scan(move, (0, 2))
        rows_b = copy.scan(move, (0, 2))
        assert [(r.time_s, r.item) for r in rows_a] == [(r.time_s, r.item) for r in rows_b]
        for ra, rb in zip(rows_a, rows_b, strict=True):
            np.testing.assert_allclose(ra.coef, rb.coef, rtol=1e-9, atol=1e-12 * abs(rb.coef).max())


def test_the_nominal_answer_is_no_longer_than_the_robust_one(model):
    """A robust grid that holds the nominal model is a larger set of constraints: its
    certified move is certified for the nominal model too, so the nominal answer must not
    be longer. The robust search starts from the nominal search (the same as the nominal
    run's: the same lengths, the same verdicts) and tests no shorter length: its answer is at
    least the nominal one (here with the distance, cups and stress on the press scene)."""
    cell = press()
    limits = {"min_distance_m": 0.01, "cup_safety": 1.5, "max_stress_pa": "yield"}
    options = {"constraints": optim.Constraints(cell, **limits)}
    nominal = optim.optimize(model, None, LIMITS, DT, THRESHOLD, **options)
    robust = optim.optimize(
        model,
        None,
        LIMITS,
        DT,
        THRESHOLD,
        robust=optim.RobustSpec((0.9, 1.1), None, 3, 1),
        **options,
    )
    assert nominal.transfer_time_s <= robust.transfer_time_s
    assert nominal.cycle_time_s <= robust.worst_cycle_time_s
    before = robust.solver_stats["nominal_attempts"]
    tested = [(a["n_steps"], a["feasible"]) for a in nominal.solver_stats["attempts"]]
    assert [(a["n_steps"], a["feasible"]) for a in before] == tested[: len(before)]
    assert all(c["bound"] <= c["limit"] * (1 + 1e-9) for c in robust.constraints[1:])


def _fe_scaled(fe_result, scale: float):
    """The plate of ``fe_result`` with its stiffness times scale^2 (its frequencies times
    scale): what a robust grid's model stands for, solved again by FE."""
    steel = fe_result.part.material
    material = fem.Material("steel", steel.E_pa * scale**2, steel.nu, steel.rho_kg_m3)
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, material, 0.025)
    return fem.modal_analysis(
        part, fe_result.supports, n_modes=40, zeta=0.02, error_estimate=False, progress=False
    )


@pytest.mark.slow
def test_robust_distance_holds_for_every_model_of_the_grid(model_all_nodes, fe_result):
    """With a robust grid (frequencies x0.9 ... x1.1) the distance is certified on every
    model of it (a softer part sags more and vibrates otherwise), and the report says how
    many models the certificate covers; each of the grid's parts, solved again by FE with
    its stiffness scaled and checked independently (every node and skin, lsim, 0.1 ms),
    keeps the 10 mm up to the 8-mode model's error (below 2 um)."""
    cell = press()
    robust = optim.RobustSpec(freq_scale=(0.9, 1.1), zeta=None, n_freq=3, n_zeta=1)
    result = optim.optimize(
        model_all_nodes,
        None,
        LIMITS,
        DT,
        THRESHOLD,
        robust=robust,
        constraints=optim.Constraints(cell=cell, min_distance_m=0.01),
    )
    (constraint,) = result.constraints
    assert constraint["scenarios"] == 4  # the nominal model and the grid's three
    assert constraint["bound"] >= 0.01 * (1 - 1e-9)
    until = result.n_steps * DT + 1.0
    for fe in (_fe_scaled(fe_result, 0.9), fe_result, _fe_scaled(fe_result, 1.1)):
        assert independent_distance(fe, 40, cell, result.acc, until) >= 0.01 - 2e-6


def test_stop_at_a_via_point(model):
    """A "stop" via point is passed at rest, exactly where it is."""
    cell = press("stop")
    result = optim.optimize(
        model,
        None,
        LIMITS,
        DT,
        THRESHOLD,
        constraints=optim.Constraints(cell=cell, min_distance_m=0.01),
    )
    vel, pos = integrate(result.acc, DT)
    target = cell.via[0].position_m - cell.start_m
    k = int(np.argmin(np.linalg.norm(pos - target, axis=1)))
    np.testing.assert_allclose(pos[k], target, atol=1e-9)
    np.testing.assert_allclose(vel[k], 0.0, atol=1e-9)
    np.testing.assert_allclose(result.acc[k], 0.0, atol=1e-9)


@pytest.fixture(scope="module")
def plain(model):
    return optim.optimize(model, [0.3, 0.0, 0.6], LIMITS, DT, 2e-5)


def _peak(model, outputs, functional, acc, until_s):
    """The independent check of a load: every item on a 0.1 ms grid over the move and the
    settling (its modes decay to 1e-3 within 1 s), the modal states by scipy's lsim
    (tests/independent.py), gravity from the model's static response."""
    return output_peak_lsim(model, outputs, functional, acc, DT, until_s, GRAVITY)


def test_inactive_constraints_leave_the_optimum(model, plain):
    """Limits far above what the optimum reaches change nothing, bit for bit."""
    loose = optim.optimize(
        model,
        [0.3, 0.0, 0.6],
        LIMITS,
        DT,
        2e-5,
        constraints=optim.Constraints(
            cup_safety=0.5
            / _peak(model, model.cups.reaction, CupUtilisation(model.cups, 1.0), plain.acc, 1.6),
            max_stress_pa=3 * 7.4e6,
        ),
    )
    np.testing.assert_array_equal(loose.acc, plain.acc)
    assert [c["name"] for c in loose.constraints] == ["cup utilisation", "von Mises stress"]


@pytest.mark.parametrize("kind", ["cups", "stress"])
def test_active_load_constraints_hold(model, plain, kind):
    """A limit 15 % below what today's optimum reaches changes the optimum; the new one
    keeps the limit at every item on a 0.1 ms grid of an independent simulation (scipy's
    lsim; certified between: the grid values stay below the certified bound, which is at
    most the limit; 1e-9 for the round-off of two simulations)."""
    if kind == "cups":
        functional = CupUtilisation(model.cups, 1.0)
        peak0 = _peak(model, model.cups.reaction, functional, plain.acc, 1.6)
        options = {"constraints": optim.Constraints(cup_safety=1 / (0.85 * peak0))}
        outputs, functional, limit = (
            model.cups.reaction,
            CupUtilisation(model.cups, 1 / (0.85 * peak0)),
            1.0,
        )
    else:
        functional = VonMises(model.stress.n_points)
        peak0 = _peak(model, model.stress.stress, functional, plain.acc, 1.6)
        options = {"constraints": optim.Constraints(max_stress_pa=0.85 * peak0)}
        outputs, limit = model.stress.stress, 0.85 * peak0
    result = optim.optimize(model, [0.3, 0.0, 0.6], LIMITS, DT, 2e-5, **options)
    assert not np.array_equal(result.acc, plain.acc)
    assert result.cycle_time_s >= plain.cycle_time_s
    dense = _peak(model, outputs, functional, result.acc, result.n_steps * DT + 1.0)
    assert dense <= limit * (1 + 1e-9)
    (constraint,) = result.constraints
    assert constraint["bound"] <= limit * (1 + 1e-9)
    assert constraint["utilisation"] > 0.99  # active


def test_cell_options_are_checked(model):
    with pytest.raises(InputError, match="min_distance_m"):
        optim.optimize(
            model,
            [0.3, 0, 0.6],
            LIMITS,
            DT,
            2e-5,
            constraints=optim.Constraints(min_distance_m=0.01),
        )
    with pytest.raises(InputError, match="method"):
        optim.optimize(
            model,
            None,
            LIMITS,
            DT,
            2e-5,
            search=optim.Search(method="gradient"),
            constraints=optim.Constraints(cell=press()),
        )
    blocked = Cell(
        obstacles=(Box([0.3, 0.0, 0.1], [0.2, 0.2, 0.2], name="pillar"),), end_m=[1, 0, 0]
    )
    with pytest.raises(InputError, match="pillar"):
        optim.optimize(
            model,
            None,
            LIMITS,
            DT,
            2e-5,
            constraints=optim.Constraints(cell=blocked, min_distance_m=0.01),
        )
    with pytest.raises(InputError, match="gravity alone"):
        optim.optimize(
            model, [0.3, 0, 0.6], LIMITS, DT, 2e-5, constraints=optim.Constraints(cup_safety=1e4)
        )


def test_optimize_command_with_a_cell(tmp_path, model):
    model.save(tmp_path / "plate.npz")
    (tmp_path / "press.toml").write_text(PRESS_TOML)
    done = run_jaxflex(
        "optimize", str(tmp_path / "plate.npz"), "--cell", str(tmp_path / "press.toml"),
        "--min-distance", "0.01", "--cup-safety", "1.5", "--max-stress", "--threshold", "5e-4",
        "-o", str(tmp_path / "out"), "--quiet",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    names = [c["name"] for c in report["constraints"]]
    assert names == ["distance to obstacles", "cup utilisation", "von Mises stress"]
    assert report["constraints"][2]["limit"] == pytest.approx(140e6 / 1.5)
    assert (tmp_path / "out" / "constraints.png").stat().st_size > 10_000
    assert "distance to obstacles" in done.stdout
    bad = run_jaxflex(
        "optimize", str(tmp_path / "plate.npz"), "--distance", "1", "0", "0",
        "--min-distance", "0.01", "--threshold", "5e-4", "-o", str(tmp_path / "x"),
    )  # fmt: skip
    assert bad.returncode == 2 and "min_distance_m" in bad.stderr


def test_the_example_cell_is_a_press_opening():
    """examples/press_cell.toml (the README's and optim.bench.cell's scene) still describes
    what they say: for the built-in plate's rigid footprint (1.5 x 0.8 m, in its frame),
    A, the via point and B are clear of every obstacle by more than the 10 mm margin, and
    the straight line from A to B runs into the lower die."""
    cell = load_cell(EXAMPLE_CELL)
    assert [o.name for o in cell.obstacles] == ["lower die", "upper die", "floor"]
    assert [v.mode for v in cell.via] == ["blend"]
    x, y = np.meshgrid(np.linspace(0, 1.5, 31), np.linspace(0, 0.8, 17))
    footprint = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])

    def clearance(origin_m) -> float:
        return distances(cell.obstacles, footprint + origin_m)[0].min()

    for origin in (cell.start_m, cell.via[0].position_m, cell.end_m):
        assert clearance(np.asarray(origin)) > 0.01
    line = np.linspace(0, 1, 101)[:, None] * (cell.end_m - cell.start_m) + cell.start_m
    assert min(clearance(p) for p in line) < 0


@pytest.mark.slow
def test_the_example_cell_from_the_command_line(tmp_path):
    """The README's commands with examples/press_cell.toml on the built-in plate (fewer
    modes and points): the optimised move keeps the 10 mm margin, certified."""
    built = run_jaxflex(
        "model", "--scene", "plate", "--n-modes", "8", "--points", "60",
        "-o", str(tmp_path / "plate.npz"), "--quiet",
    )  # fmt: skip
    assert built.returncode == 0, built.stderr
    done = run_jaxflex(
        "optimize", str(tmp_path / "plate.npz"), "--cell", str(EXAMPLE_CELL),
        "--min-distance", "0.01", "--threshold", "5e-4", "-o", str(tmp_path / "press"),
        "--quiet",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "press" / "report.json").read_text())
    (distance,) = report["constraints"]
    assert distance["name"] == "distance to obstacles"
    assert distance["peak"] >= distance["limit"] * (1 - 1e-9)


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(2, 3000),
    step=st.floats(1e-4, 2e-3),
    peaks=st.lists(st.one_of(st.floats(-1.0, 8.0), st.just(float("nan")), st.none()), max_size=3),
)
def test_constraint_pictures_keep_every_sample_near_the_certified_peaks(n, step, peaks):
    """constraints.png's curves (optim.plots.constraint_times) are evaluated every
    CURVE_STRIDE-th time of the deviation grid, at its last time, and at every time within
    INSET_S of a certified peak (where the mark and the distance's inset are), no other."""
    t = step * np.arange(n)
    kept = constraint_times(t, peaks)
    near = np.zeros(n, dtype=bool)
    for when in peaks:
        if when is not None and np.isfinite(when):
            near |= np.abs(t - when) <= INSET_S
    expected = (np.arange(n) % CURVE_STRIDE == 0) | (np.arange(n) == n - 1) | near
    np.testing.assert_array_equal(kept, t[expected])
