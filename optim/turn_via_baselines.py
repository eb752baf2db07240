"""The baseline of a move through via points with orientations (optim.turn_via.ViaTurn):
ruckig segment by segment, stopping at every via point (as optim.baselines.via_baselines),
the turn through the via orientations on the same via samples (ViaTurn.stretched), both on
the fewest steps at which every segment fits, plus free decay; its exact cycle time is the
turning engine's (optim.turn_baselines)."""

from __future__ import annotations

import itertools

import numpy as np

from jaxflex.errors import InputError
from optim.baselines import BaselineSet
from optim.kinematics import clean_distance, via_step
from optim.limits import Limits
from optim.ruckig_move import (
    MAX_EXTRA_STEPS,
    fit_to_grid,
    grid_steps,
    kinematic_floor_move,
    time_optimal_move,
)
from optim.search import pad_to
from optim.turn_baselines import _evaluate
from optim.turn_via import ViaTurn


def _synchronised(turn: ViaTurn, stops, limits: Limits, dt_s: float, n_steps: int):
    """(translation (n+1, 3) m/s^2, turn (n+1,) rad/s^2) of an n-step move that stops at
    every via point at its sample, each translation segment ruckig's stretched to its steps
    on the grid, the turn ``turn``'s schedule; None if a segment does not fit."""
    alpha = turn.stretched(n_steps, dt_s)
    if alpha is None:
        return None
    k = [0, *(via_step(f, n_steps) for f in turn.via_fractions), n_steps]
    pieces: list[np.ndarray] = []
    for (a, b), (k0, k1) in zip(itertools.pairwise(stops), itertools.pairwise(k), strict=True):
        distance = clean_distance(b - a)
        if k1 - k0 < grid_steps(time_optimal_move(distance, limits).duration_s, dt_s):
            return None
        motion = time_optimal_move(distance, limits, minimum_duration_s=(k1 - k0) * dt_s)
        acc = fit_to_grid(
            motion.acceleration(dt_s * np.arange(k1 - k0 + 1)), dt_s, distance, limits
        )
        if acc is None:
            return None
        pieces.append(acc if not pieces else acc[1:])
    return np.concatenate(pieces), alpha


def oriented_via_baselines(
    request, model, distance_m, via_offsets, max_steps: int
) -> tuple[BaselineSet, list[float]]:
    """The baseline of a move through via points some of which carry an orientation
    (``request.turn`` a :class:`ViaTurn`): ruckig segment by segment, stopping at every via
    point, and the turn through the via orientations, both on the fewest steps n >= the
    synchronised path's duration at which every segment fits at the via samples of
    ``turn.via_fractions``, plus free decay; and those fractions (the search's via rows). The
    kinematic floor is the longer of the straight move's and the turn's alone."""
    turn, limits, dt_s = request.turn, request.limits, request.dt_s
    distance = clean_distance(distance_m)
    stops = [np.zeros(3), *(np.asarray(v, dtype=np.float64) for v in via_offsets), distance]
    start = grid_steps(turn.duration_s, dt_s)
    last = min(max_steps, start + MAX_EXTRA_STEPS * (len(stops) - 1))
    for n_steps in range(start, last + 1):
        found = _synchronised(turn, stops, limits, dt_s, n_steps)
        if found is not None:
            break
    else:
        raise InputError(
            f"rotate: the path through the via points and orientations needs at least "
            f"{turn.duration_s:.3f} s at these limits; no grid move of up to {last} steps of "
            f"{dt_s:g} s found (max_duration_s, or the limits)"
        )
    acc, alpha = found
    name = "ruckig via points and orientations + free decay"
    entry = _evaluate(model, request, name, acc, alpha, [])
    floor = kinematic_floor_move(distance, limits, dt_s, max_steps)
    floor_steps = max(floor.acc.shape[0] - 1, grid_steps(turn.fastest_s(), dt_s))
    floor_s = max(floor.continuous_duration_s, turn.fastest_s())
    return BaselineSet(floor_s, pad_to(floor.acc, floor_steps), [entry]), list(turn.via_fractions)
