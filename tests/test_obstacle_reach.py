"""Obstacles left out before a cell's distance is measured (optim.obstacle_reach): the bound
on how far the part can come is checked against the exact response of real moves
(jaxflex._collision.positions_at: the modal response with the static residual and the sag),
and every piece left out against the brute-force distance of every point at every sample."""

from __future__ import annotations

import numpy as np
import pytest

import fem
import jaxflex
import optim
from jaxflex import as_move
from jaxflex._cell import Box, Cell, HalfSpace, TriangleMesh
from jaxflex._collision import distances, positions_at
from jaxflex._profile import kinematics_at
from optim.obstacle_reach import deviation_bound_m, pivot_box, reachable

DT = 0.01
LIMITS = optim.Limits(vmax=2.0, amax=10.0, jmax=100.0)


@pytest.fixture(scope="module")
def posed():
    part = fem.rectangular_plate(0.4, 0.3, 1e-3, "steel", 0.05)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.1, 0.3) for y in (0.08, 0.22)]
    model = fem.modal_analysis(part, cups, n_modes=5, zeta=0.02).to_modal_model(points=20)
    cell = Cell(obstacles=(HalfSpace([0, 0, 1], -0.05, "floor"),), start_m=[0.0, 0.0, 0.3],
                end_m=[0.8, 0.2, 0.5])  # fmt: skip
    return model, cell


def _motion(model, cell, distance_m, duration_s):
    """(the move's acceleration (n+1, 3), the exact positions (T, P, 3) every dt / 4 over
    the move and as long again after it, the rigid positions (T, P, 3) without sag)."""
    acc = jaxflex.jerk_limited_move(distance_m, LIMITS.vmax, LIMITS.amax, LIMITS.jmax, DT).acc
    posed = cell.posed(model)
    t = np.arange(0.0, 2 * duration_s, DT / 4)
    exact = positions_at(posed, as_move(acc, DT), t, cell.gravity_m_s2)
    rigid = np.asarray(posed.points)[None] + kinematics_at(as_move(acc, DT), t)[0][:, None]
    return acc, exact, rigid


@pytest.mark.parametrize("distance_m", [(0.8, 0.2, 0.2), (0.0, 0.0, 1.0), (1.5, -0.3, 0.0)])
def test_no_point_goes_beyond_the_deviation_bound(posed, distance_m):
    model, cell = posed
    acc, exact, rigid = _motion(model, cell, distance_m, 3.0)
    duration = 2 * len(acc) * DT  # the samples' span: move and decay
    bound = deviation_bound_m(cell.posed(model), LIMITS.amax, duration, cell.gravity_m_s2)
    deviation = np.linalg.norm(exact - rigid, axis=-1).max()
    # a bound of the exact response (sag included); a loose one (resonance at every mode
    # at once for the whole time: about 1 000 times the deviation of these moves), which
    # is still millimetres: obstacles metres away are left out
    assert 0 < deviation <= bound < 0.1


def test_pieces_left_out_never_come_near(posed):
    """Boxes and a mesh's triangles spread from next to the path to tens of metres away:
    those left out are farther than the limit from every point at every sample of real
    moves within the limits (straight at full speed, and along the path); the nearest is
    kept."""
    model, cell = posed
    rng = np.random.default_rng(3)
    centres = rng.uniform(-1, 1, (300, 3)) * np.logspace(-0.5, 1.5, 300)[:, None]
    boxes = tuple(Box(c, [0.05, 0.05, 0.05], name=f"b{i}") for i, c in enumerate(centres))
    tri = rng.uniform(-20, 20, (60, 3))
    mesh = TriangleMesh(tri, np.arange(60).reshape(20, 3), "mesh")
    scene = Cell(obstacles=(*boxes, mesh), start_m=cell.start_m, end_m=cell.end_m)
    limit_m, max_duration_s = 0.05, 2.0
    pruned = reachable(scene, model, LIMITS, max_duration_s, limit_m)
    assert 0 < pruned.dropped < pruned.total == 320
    kept_names = {o.name for o in pruned.cell.obstacles}
    dropped = [o for o in boxes if o.name not in kept_names]
    low, high = pivot_box(scene, LIMITS, max_duration_s)
    mid = (low + high) / 2
    tried = 0
    for target in (scene.end_m, mid + 0.5 * (high - mid), mid + 0.5 * (low - mid)):
        acc, exact, _ = _motion(model, scene, np.asarray(target) - scene.start_m, max_duration_s)
        if len(acc) * DT > max_duration_s:  # not a move within the time: no claim
            continue
        tried += 1
        near = distances(tuple(dropped), exact.reshape(-1, 3))[0].min()
        assert near > limit_m + 0.5e-3  # the skins: half the 1 mm sheet
    assert tried >= 2 and pruned.beyond_m > limit_m
