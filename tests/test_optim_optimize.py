"""optim.optimize: optimality against the baselines, robust mode, both routes, exact
limits and boundary conditions on every returned profile, clear errors, saved outputs."""

from __future__ import annotations

import json
import math
import sys
from collections import Counter
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import jaxflex
import optim
from jaxflex._trajectory_io import read_trajectory_csv
from jaxflex.errors import InputError
from jaxflex.response import upsample
from optim import stages
from optim.bench.targets import few_mode_model as bench_model
from optim.choice import Candidate
from optim.exact import LPSubsolver
from optim.limits import ConstraintCheck, Violation
from optim.robust import perturbed
from optim.search import attempt, make_problem

DT = 0.01
LIMITS = optim.Limits(1.5, 8.0, 80.0)
DISTANCE = (0.0, 0.0, 0.8)
THRESHOLD = 1e-3


def few_mode_model() -> jaxflex.ModalModel:
    """optim.bench.targets's synthetic three-mode part (full 3-D shapes at 16 points, participation
    mostly along z) at 3, 7 and 15 Hz: stiff enough for short test runs."""
    return bench_model(freq_hz=(3.0, 7.0, 15.0))


@pytest.fixture(scope="module")
def model():
    return few_mode_model()


@pytest.fixture(scope="module")
def nominal(model):
    return optim.optimize(model, DISTANCE, LIMITS, DT, THRESHOLD)


def test_optimum_beats_every_baseline(model, nominal):
    assert nominal.constraint_check.ok
    for baseline in nominal.baselines.entries:
        assert nominal.cycle_time_s <= baseline.cycle_time_s, baseline.name
    # the reported cycle time is the exact one, recomputed independently (no lead-in)
    assert nominal.cycle_time_s == pytest.approx(
        jaxflex.cycle_time(model, nominal.acc, DT, THRESHOLD), abs=2e-9
    )
    # it is the move itself: the optimum leaves no settling time
    assert nominal.cycle_time_s == pytest.approx(nominal.n_steps * DT)
    assert nominal.transfer_time_s >= nominal.baselines.kinematic_floor_s


def test_one_step_less_is_certainly_infeasible(model, nominal):
    # Minimality: with the rows found so far the LP already proves n - 1 infeasible.
    problem = make_problem(model, np.array(DISTANCE), LIMITS, DT, THRESHOLD, 3000, None)
    shorter = attempt(problem, LPSubsolver(), nominal.n_steps - 1, nominal.baselines.floor_acc)
    assert not shorter.feasible


def test_vibration_ignored_gives_ruckigs_duration_on_the_grid(model):
    # A threshold no deviation reaches: the minimum is the kinematic floor, i.e. ruckig's
    # time-optimal duration rounded up to the grid (at most one more step where no grid
    # move of ceil(T / dt) steps exists), and the LP proves one step less impossible.
    result = optim.optimize(model, DISTANCE, LIMITS, DT, 10.0)
    base = result.baselines
    assert result.n_steps == base.floor_steps
    ceil_steps = math.ceil(base.kinematic_floor_s / DT - 1e-7)
    assert ceil_steps <= result.n_steps <= ceil_steps + 1
    problem = make_problem(model, np.array(DISTANCE), LIMITS, DT, 10.0, 3000, None)
    assert not attempt(problem, LPSubsolver(), result.n_steps - 1, base.floor_acc).feasible


@pytest.mark.slow
def test_routes_agree_and_the_exact_route_is_never_worse(model, nominal):
    # exact via scipy's HiGHS (the fixture), via casadi + Clp, and the gradient route via
    # Ipopt and SLSQP: same problem, answers within a few steps, the exact one the shortest.
    for method, solver in (("exact", "casadi"), ("gradient", "ipopt"), ("gradient", "slsqp")):
        other = optim.optimize(
            model,
            DISTANCE,
            LIMITS,
            DT,
            THRESHOLD,
            search=optim.Search(method=method, solver=solver),
        )
        assert other.constraint_check.ok
        assert other.cycle_time_s == pytest.approx(
            jaxflex.cycle_time(model, other.acc, DT, THRESHOLD), abs=2e-9
        )
        if method == "exact":
            assert other.n_steps == nominal.n_steps  # two LP solvers, same optimum
        else:
            assert nominal.n_steps <= other.n_steps <= nominal.n_steps + 3, solver
            assert other.solver_stats["totals"]["jax_evaluations"] > 0


def test_robust_worst_case_beats_every_shaper(model, nominal):
    spec = optim.RobustSpec((0.9, 1.1), (0.01, 0.03), n_freq=5, n_zeta=2)
    result = optim.optimize(model, DISTANCE, LIMITS, DT, THRESHOLD, robust=spec)
    assert result.constraint_check.ok
    shapers = [b for b in result.baselines.entries if b.shaped_freq_hz]
    assert len(shapers) == 3
    for b in shapers:
        assert result.worst_cycle_time_s <= b.worst_cycle_time_s, b.name
    # the worst case is the exact maximum over the grid, recomputed independently
    worst = max(
        jaxflex.cycle_time(perturbed(model, s, z), result.acc, DT, THRESHOLD)
        for s, z in spec.grid()
    )
    assert result.worst_cycle_time_s == pytest.approx(worst, abs=2e-9)
    # robustness costs time: never shorter than the nominal optimum
    assert result.n_steps >= nominal.n_steps


def test_clearance_limits_the_deviation_during_the_move(model, nominal):
    clearance = 0.025  # the unconstrained optimum peaks at ~43 mm during the move
    assert nominal.peak_deviation_m > clearance
    result = optim.optimize(
        model, DISTANCE, LIMITS, DT, THRESHOLD, constraints=optim.Constraints(clearance_m=clearance)
    )
    # independent check: the exact response sampled every dt / 8 by jaxflex.simulate
    fine = jaxflex.simulate(model, upsample(result.acc, 8), DT / 8)
    assert float(np.max(fine.deviation)) <= clearance
    assert result.peak_deviation_m == pytest.approx(float(np.max(fine.deviation)), rel=1e-9)
    assert result.n_steps > nominal.n_steps  # the limit costs time here
    assert result.cycle_time_s == pytest.approx(result.n_steps * DT)
    assert result.constraint_check.ok
    assert result.report()["clearance_m"] == clearance


def test_each_baseline_is_simulated_once_for_its_deviation(model, monkeypatch):
    """With a clearance every baseline's deviation during the move is measured once, in the
    baselines stage; a baseline that is chosen (here forced: the last shaped one) keeps
    that measurement instead of being simulated again for the report."""
    simulated: Counter[bytes] = Counter()  # deviation summaries by move
    summary, choose = stages.deviation_summary, stages.choose

    def counted(model, move):
        simulated[move.acc.tobytes()] += 1
        return summary(model, move)

    def choose_a_shaped_baseline(run):
        shaped = run.base.moves.entries[-1]
        move = Candidate("baseline", shaped.name, shaped.move, shaped.score(), None)
        return replace(choose(run), move=move)

    monkeypatch.setattr(stages, "deviation_summary", counted)
    monkeypatch.setattr(stages, "choose", choose_a_shaped_baseline)
    result = optim.optimize(
        model, DISTANCE, LIMITS, DT, THRESHOLD, constraints=optim.Constraints(clearance_m=1.0)
    )
    shaped = result.baselines.entries[-1]
    assert result.source == shaped.name
    assert set(simulated) == {b.acc.tobytes() for b in result.baselines.entries}
    assert set(simulated.values()) == {1}
    assert result.deviation == summary(model, shaped.move)


@pytest.mark.slow
def test_gradient_route_meets_the_clearance_too(model):
    exact = optim.optimize(
        model, DISTANCE, LIMITS, DT, THRESHOLD, constraints=optim.Constraints(clearance_m=0.025)
    )
    other = optim.optimize(
        model,
        DISTANCE,
        LIMITS,
        DT,
        THRESHOLD,
        search=optim.Search(method="gradient", solver="slsqp"),
        constraints=optim.Constraints(clearance_m=0.025),
    )
    assert other.peak_deviation_m <= 0.025
    assert exact.n_steps <= other.n_steps <= exact.n_steps + 3


@settings(
    max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    distance=st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda d: np.linalg.norm(d) > 0.05),
    vmax=st.floats(0.5, 3.0),
    amax=st.floats(3.0, 15.0),
    jmax=st.floats(30.0, 300.0),
    path=st.booleans(),
    method=st.sampled_from(["exact", "gradient"]),
)
def test_limits_and_boundary_conditions_hold_on_every_returned_profile(
    model, distance, vmax, amax, jmax, path, method
):
    limits = optim.Limits(
        [vmax, 1.2 * vmax, vmax],
        amax,
        [jmax, jmax, 0.8 * jmax],
        vpath=1.1 * vmax if path else None,
        apath=1.1 * amax if path else None,
        jpath=1.1 * jmax if path else None,
    )
    result = optim.optimize(model, distance, limits, DT, 2e-3, search=optim.Search(method=method))
    acc = result.acc
    # independent re-check: samples, every step's jerk, velocity between samples
    check = optim.check_profile(jaxflex.as_move(acc, DT), limits, distance)
    assert check.ok, check.summary()
    assert np.all(acc[0] == 0) and np.all(acc[-1] == 0)
    np.testing.assert_allclose(result.pos[-1], distance, atol=1e-9)
    np.testing.assert_allclose(result.vel[-1], 0.0, atol=1e-9)
    assert np.all(np.abs(acc) <= limits.amax * (1 + 1e-9))
    assert np.all(np.abs(np.diff(acc, axis=0)) / DT <= limits.jmax * (1 + 1e-9))
    assert result.cycle_time_s <= min(b.cycle_time_s for b in result.baselines.entries) + 1e-9


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"limits": {"vmax": 0.0, "amax": 8.0, "jmax": 80.0}}, r"vmax\[x\]"),
        ({"limits": {"vmax": 1.5, "amax": -8.0, "jmax": 80.0}}, r"amax\[x\]"),
        ({"limits": {"vmax": 1.5}}, r"limits: .*missing \['amax', 'jmax'\]"),
        ({"limits": {"vmax": 1, "amax": 8, "jmax": 80, "vmx": 2}}, r"unknown \['vmx'\]"),
        ({"threshold_m": 0.0}, "threshold_m"),
        ({"threshold_m": -1e-3}, "threshold_m"),
        ({"distance_m": (0.0, 0.0, 0.0)}, "zero length"),
        ({"distance_m": (0.0, np.nan, 1.0)}, "distance_m"),
        ({"distance_m": (0.0, 0.0, 50.0)}, "max_duration_s"),
        ({"dt_s": 0.0}, "dt_s"),
        ({"robust": optim.RobustSpec}, "robust"),
        ({"search": {"method": "newton"}}, r"search: an optim\.Search\(\.\.\.\) or None, got dict"),
        ({"budget": 5000}, r"budget: an optim\.Budget\(\.\.\.\) or None, got int"),
        ({"constraints": 0.01}, "constraints: an optim.Constraints"),
        ({"rotation": ("x", 30.0)}, r"rotation: an optim\.Rotation\(axis, angle_deg, \.\.\.\)"),
    ],
)
def test_infeasible_or_bad_requests_give_clear_errors(model, change, message):
    kwargs = {
        "model": model,
        "distance_m": DISTANCE,
        "limits": LIMITS,
        "threshold_m": THRESHOLD,
        "dt_s": DT,
    } | change
    with pytest.raises(InputError, match=message):
        optim.optimize(**kwargs)


def test_undamped_models_and_unreachable_thresholds_are_errors(model):
    with pytest.raises(InputError, match=r"model\.zeta"):
        optim.optimize(model.with_damping(0.0), DISTANCE, LIMITS, DT, THRESHOLD)
    # only the kinematic floor fits in max_duration_s, and it leaves too much vibration
    floor_s = optim.baselines(model, DISTANCE, LIMITS, DT, THRESHOLD).floor_steps * DT
    with pytest.raises(InputError, match="no move of at most"):
        optim.optimize(
            model, DISTANCE, LIMITS, DT, 1e-6, budget=optim.Budget(max_duration_s=floor_s + 1e-9)
        )


def test_save_writes_everything_atomically(model, nominal, tmp_path):
    paths = nominal.save(tmp_path / "out")
    names = {p.name for p in paths}
    assert {"trajectory.csv", "report.json", "profiles.png", "deviation.png"} <= names
    for p in paths:
        assert p.stat().st_size > 0
    assert not list((tmp_path / "out").glob("*.tmp"))
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    for key in (
        "distance_m",
        "dt_s",
        "threshold_m",
        "limits",
        "transfer_time_s",
        "settle_time_s",
        "cycle_time_s",
        "method",
        "robust",
        "baselines",
    ):
        assert key in report, key
    assert report["robust"] is None and report["method"] == "exact"
    assert report["limits"]["vmax_m_s"] == [1.5, 1.5, 1.5]
    move = read_trajectory_csv(tmp_path / "out" / "trajectory.csv")
    assert move.dt_s == pytest.approx(DT)
    # the saved file reproduces the reported exact cycle time
    assert jaxflex.cycle_time(model, move, threshold_m=report["threshold_m"]) == pytest.approx(
        report["cycle_time_s"], abs=2e-9
    )
    names = [b["name"] for b in report["baselines"]["entries"]]
    assert names[0] == "ruckig + free decay" and len(names) == 4


def test_a_profile_that_fails_the_final_check_is_never_returned(model, monkeypatch):
    """The last line of defence: if the optimiser's final move failed the exact limit check
    (a solver's tolerance, say), the next best certified move that passes it is returned (a
    move of the search or a baseline), with a note; never a broken profile."""
    optimize_module = sys.modules["optim.stages"]  # the choose stage checks the limits

    real_check = optimize_module.check_profile
    calls = []

    def check_rejecting_the_optimum(move, *args, **kwargs):
        calls.append(move.acc)
        if len(calls) == 1:  # the optimiser's final move is checked first
            return ConstraintCheck((Violation("jerk", "z", 0.1, 101.0, 100.0),))
        return real_check(move, *args, **kwargs)

    monkeypatch.setattr(optimize_module, "check_profile", check_rejecting_the_optimum)
    result = optim.optimize(model, DISTANCE, LIMITS, DT, THRESHOLD)
    assert any("rejected" in note for note in result.solver_stats["notes"])
    assert any("did not pass the limits check" in note for note in result.report()["notes"])
    assert not np.array_equal(result.acc, calls[0])
    np.testing.assert_array_equal(result.acc, calls[1])  # the next best candidate
    assert result.constraint_check.ok and real_check(result.move, LIMITS, DISTANCE).ok
    assert result.cycle_time_s <= min(b.cycle_time_s for b in result.baselines.entries)
