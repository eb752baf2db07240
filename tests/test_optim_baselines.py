"""Baselines: ruckig's floor on the grid, shaped moves, the choice of shaped modes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ruckig import InputParameter, Ruckig, Trajectory
from test_optim_optimize import DISTANCE, DT, LIMITS, THRESHOLD, few_mode_model

import jaxflex
import optim
from jaxflex.settle import analyze_move
from optim.baselines import dominant_modes
from optim.robust import perturbed
from optim.ruckig_move import kinematic_floor_move, shaped_grid_move, time_optimal_move
from optim.shapers import convolve, shaper


def independent_ruckig_duration(distance, limits):
    """Time-synchronised duration = the slowest axis' own time-optimal duration."""
    durations = []
    for c in np.flatnonzero(distance):
        inp = InputParameter(1)
        inp.current_position, inp.target_position = [0.0], [float(distance[c])]
        inp.max_velocity = [float(limits.vmax[c])]
        inp.max_acceleration = [float(limits.amax[c])]
        inp.max_jerk = [float(limits.jmax[c])]
        traj = Trajectory(1)
        Ruckig(1).calculate(inp, traj)
        durations.append(traj.duration)
    return max(durations)


@settings(max_examples=25, deadline=None)
@given(
    distance=st.tuples(*[st.sampled_from([0.0, 1.0]) for _ in range(3)]).filter(any),
    scale=st.tuples(*[st.floats(0.05, 2.0)] * 3),
    vmax=st.tuples(*[st.floats(0.2, 3.0)] * 3),
    amax=st.tuples(*[st.floats(1.0, 20.0)] * 3),
    jmax=st.tuples(*[st.floats(10.0, 400.0)] * 3),
    dt=st.sampled_from([0.004, 0.01, 0.02]),
)
def test_kinematic_floor_on_the_grid(distance, scale, vmax, amax, jmax, dt):
    dist = np.array(distance) * np.array(scale)
    limits = optim.Limits(vmax, amax, jmax)
    move = kinematic_floor_move(dist, limits, dt, max_steps=100_000)
    assert optim.check_profile(move.acc, dt, limits, dist).ok
    # every grid move is a jerk-limited motion, so none is shorter than ruckig's optimum;
    # the grid version needs ceil(T / dt) steps or, where corners cannot align, one more
    steps = move.acc.shape[0] - 1
    duration = independent_ruckig_duration(dist, limits)
    assert move.continuous_duration_s == pytest.approx(duration, rel=1e-9)
    assert math.ceil(duration / dt - 1e-7) <= steps <= math.ceil(duration / dt - 1e-7) + 1


def test_path_limited_floor_keeps_the_norms():
    limits = optim.Limits(2.0, 10.0, 100.0, vpath=1.5, apath=8.0, jpath=80.0)
    move = kinematic_floor_move([0.5, 0.5, 1.0], limits, 0.01, max_steps=1000)
    check = optim.check_profile(move.acc, 0.01, limits, [0.5, 0.5, 1.0])
    assert check.ok
    assert 0.95 < check.usage["velocity"]["path"] <= 1.0  # the norm limit binds


@pytest.fixture(scope="module")
def model():
    return few_mode_model()


@pytest.fixture(scope="module")
def base(model):
    return optim.baselines(model, DISTANCE, LIMITS, THRESHOLD, DT)


def test_each_baseline_carries_its_exact_cycle_time(model, base):
    names = [b.name for b in base.entries]
    assert names[0] == "ruckig + free decay"
    assert [n.split()[0] for n in names[1:]] == ["ZV", "ZVD", "EI"]
    assert np.array_equal(base.entries[0].acc, base.floor_acc)
    for b in base.entries:
        assert optim.check_profile(b.acc, DT, LIMITS, DISTANCE).ok, b.name
        assert b.cycle_time_s == pytest.approx(
            jaxflex.cycle_time(model, b.acc, DT, THRESHOLD), abs=2e-9
        )
        assert b.timing.transfer_time_s >= base.kinematic_floor_s - 1e-12
    # shaping helps on this part: every shaper settles sooner than waiting after ruckig
    assert all(b.cycle_time_s < base.entries[0].cycle_time_s for b in base.entries[1:])


def test_the_number_of_shaped_modes_is_the_best_one(model, base):
    zv = base.entries[1]
    continuous = time_optimal_move(np.array(DISTANCE), LIMITS)
    order = dominant_modes(model, np.array(DISTANCE))
    cycles = []
    for count in range(1, model.n_modes + 1):
        modes = order[:count]
        train = convolve(*(shaper("ZV", model.freq_hz[i], model.zeta[i]) for i in modes))
        acc = shaped_grid_move(continuous, train, DISTANCE, LIMITS, DT)
        cycles.append(analyze_move(model, acc, DT, THRESHOLD).cycle_time_s)
    assert zv.cycle_time_s == pytest.approx(min(cycles), abs=1e-9)
    assert len(zv.shaped_freq_hz) == int(np.argmin(cycles)) + 1


def test_robust_baselines_report_their_worst_case(model):
    spec = optim.RobustSpec(n_freq=3, n_zeta=2)
    base = optim.baselines(model, DISTANCE, LIMITS, THRESHOLD, DT, robust=spec)
    for b in base.entries:
        cycles = [
            jaxflex.cycle_time(perturbed(model, s, z), b.acc, DT, THRESHOLD) for s, z in spec.grid()
        ]
        assert b.worst_cycle_time_s == pytest.approx(max(cycles), abs=2e-9)
        assert len(b.worst_grid) == len(cycles)
