"""optim's option objects (optim.options: Search, Constraints, Rotation, Budget): each field
checked when made and refused by name, with its command-line option, what is allowed and
what was given; frozen; and optim.optimize with every object spelled out gives the move the
independent checks certify (the engine's exact cycle time, an LP that proves one step
less impossible, the budget's refusal one step below it)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import run_jaxflex
from hypothesis import given, settings
from hypothesis import strategies as st

import jaxflex
import optim
from jaxflex.errors import BudgetError, InputError
from jaxflex.geometry import Box, Cell
from optim.bench.targets import few_mode_model
from optim.exact import LPSubsolver
from optim.search import attempt, make_problem

DT = 0.01
LIMITS = optim.Limits(1.5, 8.0, 80.0)
DISTANCE = (0.0, 0.0, 0.8)
THRESHOLD = 1e-3
NOT_POSITIVE = [0, -1.0, float("nan"), float("inf"), "a"]


S, B, C, R = optim.Search, optim.Budget, optim.Constraints, optim.Rotation
REFUSED = [  # (the object, its arguments, the message: the field, its option, allowed, given)
    (S, {"method": "newton"}, "method (--method): one of ['exact', 'gradient'], got 'newton'"),
    (
        S,
        {"solver": "ipopt"},
        "solver (--solver): method 'exact' accepts ('highs', 'casadi', 'casadi-highs'), "
        "got 'ipopt'",
    ),
    (
        S,
        {"method": "gradient", "solver": "highs"},
        "solver (--solver): method 'gradient' accepts ('ipopt', 'slsqp'), got 'highs'",
    ),
    (S, {"max_shaped_modes": -1}, "max_shaped_modes: must be an integer >= 0, got -1"),
    (S, {"max_shaped_modes": 2.5}, "max_shaped_modes: must be an integer >= 0, got 2.5"),
    (S, {"progress": "yes"}, "progress: True, False or None, got 'yes'"),
    (
        B,
        {"max_duration_s": 0},
        "max_duration_s (--max-duration): must be a finite number > 0, got 0",
    ),
    (B, {"max_steps": 1}, "max_steps (--max-steps): must be an integer >= 2, got 1"),
    (B, {"max_steps": True}, "max_steps (--max-steps): must be an integer >= 2, got True"),
    (
        B,
        {"max_memory_bytes": -5},
        "max_memory_bytes (--max-memory): must be a finite number > 0, got -5",
    ),
    (
        C,
        {"cell": "press.toml"},
        "cell (--cell): a jaxflex.geometry.Cell (optim.load_cell(path)) or None, got str",
    ),
    (
        C,
        {"clearance_m": -0.01},
        "clearance_m (--clearance): must be a finite number > 0, got -0.01",
    ),
    (
        C,
        {"min_distance_m": 0.01},
        "min_distance_m (--min-distance): needs a cell with obstacles (--cell FILE), got no cell",
    ),
    (
        C,
        {"cell": Cell(end_m=[0, 0, 1]), "min_distance_m": 0.01},
        "min_distance_m (--min-distance): needs a cell with obstacles (--cell FILE), got a "
        "cell without obstacles",
    ),
    (C, {"cup_safety": 0}, "cup_safety (--cup-safety): must be a finite number > 0, got 0"),
    (
        C,
        {"max_stress_pa": "ultimate"},
        "max_stress_pa (--max-stress): a stress in Pa or 'yield', got 'ultimate'",
    ),
    (
        C,
        {"max_stress_pa": -1e6},
        "max_stress_pa (--max-stress): must be a finite number > 0, got -1000000.0",
    ),
    (
        R,
        {"axis": "w", "angle_deg": 30},
        "axis (--rotate AXIS ANGLE_DEG): 'x', 'y', 'z' or three numbers, got 'w'",
    ),
    (
        R,
        {"axis": (0, 0, 0), "angle_deg": 30},
        "axis (--rotate AXIS ANGLE_DEG): three numbers not all zero, got (0.0, 0.0, 0.0)",
    ),
    (
        R,
        {"axis": (1, 0), "angle_deg": 30},
        "axis (--rotate AXIS ANGLE_DEG): three finite numbers, not all zero (model frame); "
        "got (1, 0)",
    ),
    (
        R,
        {"axis": "z", "angle_deg": "ninety"},
        "angle_deg (--rotate AXIS ANGLE_DEG): a finite number of degrees, got 'ninety'",
    ),
    (
        R,
        {"axis": "z", "angle_deg": 1e-12},
        "angle_deg (--rotate AXIS ANGLE_DEG): a turn of 1e-12 degrees is below",
    ),
    (
        R,
        {"axis": "z", "angle_deg": 30, "angular_limits": (3, 20)},
        "angular_limits (--angular-limits W A J): three finite numbers, rate rad/s, "
        "acceleration rad/s^2, jerk rad/s^3; got (3, 20)",
    ),
    (
        R,
        {"axis": "z", "angle_deg": 30, "angular_limits": (3, 20, -1)},
        "angular_limits (--angular-limits W A J): jerk_rad_s3 must be > 0, got (3, 20, -1)",
    ),
    (
        R,
        {"axis": "z", "angle_deg": 30, "pivot_m": (0, np.nan, 0)},
        "pivot_m (--pivot X Y Z): three finite numbers, m in the model frame; got (0, nan, 0)",
    ),
]


@pytest.mark.parametrize(("kind", "kwargs", "message"), REFUSED)
def test_each_field_is_refused_by_name(kind, kwargs, message):
    with pytest.raises(InputError) as info:
        kind(**kwargs)
    assert message in str(info.value)


def test_objects_are_frozen_and_made_final():
    """Defaults filled in when made (the method's solver, the default angular limits and
    pivot, numbers as floats), and no field can change after the check."""
    assert optim.Search().solver == "highs"
    assert optim.Search("gradient").solver == "ipopt"
    rotation = optim.Rotation([0, 0, 2], 90)
    assert rotation.axis == (0.0, 0.0, 2.0)
    assert rotation.angular_limits == (3.0, 20.0, 200.0)  # optim.defaults.ANGULAR_LIMITS
    assert rotation.pivot_m == (0.0, 0.0, 0.0)
    assert optim.Constraints(clearance_m=1).clearance_m == 1.0
    assert optim.Budget().max_memory_bytes is None  # the process's budget, when it runs
    for obj, field in (
        (optim.Search(), "method"),
        (optim.Budget(), "max_steps"),
        (optim.Constraints(), "cup_safety"),
        (rotation, "angle_deg"),
    ):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(obj, field, None)


@settings(max_examples=60, deadline=None)
@given(
    steps=st.integers(-3, 10**6),
    duration=st.one_of(st.floats(allow_nan=True), st.sampled_from(NOT_POSITIVE)),
)
def test_budget_takes_exactly_the_valid_numbers(steps, duration):
    valid = isinstance(duration, float) and math.isfinite(duration) and duration > 0
    if steps >= 2 and valid:
        budget = optim.Budget(max_duration_s=duration, max_steps=steps)
        assert (budget.max_duration_s, budget.max_steps) == (duration, steps)
        return
    field = "max_duration_s" if not valid else "max_steps"  # checked in this order
    with pytest.raises(InputError, match=field):
        optim.Budget(max_duration_s=duration, max_steps=steps)


@settings(max_examples=60, deadline=None)
@given(
    limits=st.tuples(*[st.floats(allow_nan=True, allow_infinity=True)] * 3),
    pivot=st.tuples(*[st.floats(allow_nan=True, allow_infinity=True)] * 3),
)
def test_rotation_takes_exactly_the_valid_limits_and_pivots(limits, pivot):
    limits_ok = all(math.isfinite(v) and v > 0 for v in limits)
    pivot_ok = all(math.isfinite(v) for v in pivot)
    if limits_ok and pivot_ok:
        rotation = optim.Rotation("x", 30.0, angular_limits=limits, pivot_m=pivot)
        assert rotation.angular_limits == limits and rotation.pivot_m == pivot
        return
    with pytest.raises(InputError, match="angular_limits" if not limits_ok else "pivot_m"):
        optim.Rotation("x", 30.0, angular_limits=limits, pivot_m=pivot)


@settings(max_examples=40, deadline=None)
@given(
    value=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(NOT_POSITIVE)),
    field=st.sampled_from(["clearance_m", "cup_safety", "max_stress_pa"]),
)
def test_constraints_take_exactly_the_positive_numbers(value, field):
    if isinstance(value, float) and math.isfinite(value) and value > 0:
        assert getattr(optim.Constraints(**{field: value}), field) == value
        return
    with pytest.raises(InputError, match=field):
        optim.Constraints(**{field: value})


def test_min_distance_with_a_cell_of_obstacles():
    post = Box([0.5, 0.0, 0.5], [0.1, 0.1, 0.1], name="post")
    cell = Cell(obstacles=(post,), end_m=[1.0, 0.0, 0.0])
    constraints = optim.Constraints(cell, min_distance_m=0.01)
    assert constraints.has_cell_limits and not constraints.has_via


def test_optimize_with_every_object_spelled_out():
    """The defaults spelled out as objects (and None for the same defaults) give the move
    the independent checks certify: its exact cycle time by the engine (jaxflex.cycle_time,
    1e-9 s: two evaluations of the same closed form), the move itself (it ends settled),
    one step less infeasible by an LP built without the request (make_problem), and a
    Budget one step below it refused before any search."""
    model = few_mode_model(freq_hz=(3.0, 7.0, 15.0))
    options = {
        "robust": None,
        "constraints": optim.Constraints(),
        "rotation": None,
        "search": optim.Search("exact", "highs", max_shaped_modes=6, progress=False),
        "budget": optim.Budget(max_duration_s=30.0, max_steps=5000),
    }
    result = optim.optimize(model, DISTANCE, LIMITS, DT, THRESHOLD, **options)
    assert result.constraint_check.ok and result.source == "optimised"
    exact = jaxflex.cycle_time(model, result.acc, DT, THRESHOLD)
    assert result.cycle_time_s == pytest.approx(exact, abs=1e-9)
    assert result.cycle_time_s == pytest.approx(result.n_steps * DT)
    problem = make_problem(model, np.array(DISTANCE), LIMITS, DT, THRESHOLD, 3000, None)
    shorter = attempt(problem, LPSubsolver(), result.n_steps - 1, result.baselines.floor_acc)
    assert not shorter.feasible
    assert len([b for b in result.baselines.entries if b.shaped_freq_hz]) == 3  # 3 modes
    # the budget reaches the search: a move of n - 1 steps at most cannot settle in time
    tight = optim.Budget(max_steps=result.n_steps - 1)
    with pytest.raises((BudgetError, InputError), match=r"--max-steps"):
        optim.optimize(model, DISTANCE, LIMITS, DT, THRESHOLD, budget=tight)


def test_command_builds_and_refuses_the_objects(tmp_path):
    """`jaxflex optimize` refuses a bad option through the same objects, in one line, exit 2,
    before it reads the model file (it does not exist here)."""
    base = ["optimize", str(tmp_path / "none.npz"), "--distance", "0", "0", "1"]
    base += ["--threshold", "5e-4", "-o", str(tmp_path / "o")]
    for extra, message in (
        (["--max-steps", "1"], "--max-steps (max_steps): must be an integer >= 2, got 1"),
        (["--rotate", "w", "30"], "--rotate AXIS ANGLE_DEG (axis): 'x', 'y', 'z'"),
        (["--pivot", "0", "0", "0"], "--angular-limits, --pivot: only with --rotate"),
        (["--method", "gradient", "--solver", "highs"], "--solver (solver): method 'gradient'"),
    ):
        proc = run_jaxflex(*base, *extra)
        assert proc.returncode == 2, proc.stderr
        assert message in proc.stderr
        assert "none.npz" not in proc.stderr  # refused before the model file is looked at


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"kind": "threads"}, "executor: must be one of ['serial', 'dask'], got 'threads'"),
        ({"kind": "serial", "scheduler": "tcp://h:8786"}, "scheduler: only used with the dask"),
        ({"kind": "serial", "dashboard_address": ":8787"}, "dashboard_address: only used with"),
        ({"n_workers": 0}, "n_workers: must be >= 1, got 0"),
    ],
)
def test_sweep_executor_refuses_each_field_by_name(kwargs, message):
    from optim.sweep import Executor

    with pytest.raises(InputError) as info:
        Executor(**kwargs)
    assert message in str(info.value)
