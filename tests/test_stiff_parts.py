"""Stiff parts (modes of kHz against a 10 ms move grid): the certified peaks and distances stay
exact and cheap, and the issue's very stiff plate (E = 2.1e17 Pa, first mode ~7.8 kHz) is
optimised with a cup limit instead of running for more than 15 minutes.

A stiff mode's response to a piecewise-linear acceleration is quasi-static plus a small free
vibration; bounding its curvature by the energy radius (which grows like omega dt per step)
made the branch and bound refine every step down to the mode's period (31 257 evaluations
here, 136 000 calls on the plate); the free vibration about the quasi-static response
(jaxflex._engine.derivative_bounds) needs almost none.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_model, run_jaxflex, smooth_move
from test_collision import dense_distances
from test_outputs import _dense_max, with_outputs

import jaxflex
from jaxflex import as_move
from jaxflex._cell import Box, HalfSpace
from jaxflex._collision import min_distance
from jaxflex._engine import derivative_bounds, modal_forces, modal_states, states_at
from jaxflex._loads import CupUtilisation
from jaxflex._peaks import output_peak

DT = 0.01
STIFF_HZ = (5000.0, 8000.0)


@pytest.fixture(scope="module")
def stiff():
    return with_outputs(random_model(n_points=12, n_modes=5, f_min_hz=STIFF_HZ[0],
                                     f_max_hz=STIFF_HZ[1]))  # fmt: skip


def test_derivative_bounds_hold_between_the_samples(stiff):
    """The bounds of sup |q'|, |q''|, |q'''| per step hold on a 2 us grid (16 samples per
    period of the fastest mode), with q'' and q''' from the equation of motion."""
    acc = smooth_move(40, DT)
    states = modal_states(stiff, acc, DT, xp=np)
    force = modal_forces(stiff, acc, np)
    bounds = derivative_bounds(stiff, states, force, DT)
    t = np.arange(0.0, 40 * DT, 2e-6)
    x = states_at(stiff, as_move(acc, DT), t)
    omega, zeta = np.asarray(stiff.omega_rad_s), np.asarray(stiff.zeta)
    k = np.minimum((t / DT).astype(int), 39)
    w = t / DT - k
    f = (1 - w)[:, None] * force[k] + w[:, None] * force[k + 1]
    q, v = x[..., 0], x[..., 1]
    qdd = f - 2 * zeta * omega * v - omega**2 * q
    slope = np.diff(force, axis=0)[k] / DT
    qddd = slope - 2 * zeta * omega * qdd - omega**2 * v
    for value, bound in zip((v, qdd, qddd), bounds, strict=True):
        # the samples' rounding (1e-12 of the largest term) aside
        assert (np.abs(value) <= bound[k] * (1 + 1e-9) + 1e-12 * np.abs(value).max()).all()


def test_stiff_peak_is_certified_with_few_evaluations(stiff):
    """The certified peak of the cup utilisation of 5-8 kHz modes is attained and bounds a
    2 us grid over the move and 50 ms of settling (the modes decay by e^-15 by then), and
    the search evaluates at most four times its first grid (it needed 380 times with the
    energy-radius bound)."""
    acc = smooth_move(40, DT)
    outputs, functional = stiff.cups.reaction, CupUtilisation(stiff.cups)
    offset = outputs.offset([0.0, 0.0, -9.81])
    peak = output_peak(stiff, outputs, functional, as_move(acc, DT), offset=offset, rtol=1e-6)
    dense, _ = _dense_max(stiff, outputs, functional, acc, offset, 0.45)
    assert dense <= peak.bound
    assert peak.value >= dense * (1 - 1e-5)
    first_grid = functional.n_items * (acc.shape[0])
    assert peak.evaluations <= 4 * first_grid


def test_stiff_distance_is_certified(stiff):
    """The minimum distance of a stiff part to a post and the floor (its modal speed bounded
    by jaxflex._engine.derivative_bounds): certified against a 0.1 ms grid, found within
    four times the first grid's evaluations."""
    model = stiff.posed(np.eye(3), [0.0, 0.0, 1.0])
    acc = jaxflex.jerk_limited_move([1.2, 0.3, -0.4], 2, 10, 100, DT).acc
    obstacles = (Box([1.0, 0.8, 1.2], [0.4, 0.3, 0.6], name="post"), HalfSpace([0, 0, 1], 0.0))
    found = min_distance(model, obstacles, as_move(acc, DT), atol=1e-6)
    dense = dense_distances(model, obstacles, acc, acc.shape[0] * DT + 0.05)[1].min()
    assert found.bound_m <= dense
    assert found.distance_m <= dense + 1e-6
    assert found.evaluations <= 4 * model.n_points * acc.shape[0]


@pytest.mark.slow
def test_the_issues_stiff_plate_is_optimised_with_a_cup_limit(tmp_path):
    """Issue 23: the built-in plate with E = 2.1e17 Pa (first mode near 7.8 kHz, so the
    optimum is the kinematic floor: 0.8 s over 1 m at the default limits) under a cup limit
    of safety 1.5 gives its answer (it ran for more than 15 minutes)."""
    model = tmp_path / "stiff.npz"
    made = run_jaxflex(
        "model", "--scene", "plate", "--E", "2.1e17", "--nu", "0.3", "--rho", "7850",
        "--n-modes", "10", "-o", str(model), "-q",
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    assert jaxflex.load_model(model).freq_hz[0] > 7000
    out = run_jaxflex(
        "optimize", str(model), "--distance", "0", "0", "1", "--threshold", "5e-4",
        "--cup-safety", "1.5", "-o", str(tmp_path / "out"), "-q",
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "cycle 0.800 s" in out.stdout
