"""What an optimisation may cost, estimated from the problem before any work and enforced
during it.

* **Steps.** Every move is an LP over its samples (3 columns and about 9 rows per step and
  axis); the solver's time grows with the square of the steps (measured with HiGHS on this
  project's 2-core machine: 0.9 s at 1 000 steps, 7 s at 3 000, 69 s at 10 000 for one grid
  fit). :data:`MAX_STEPS` (``--max-steps``) bounds the length of every move an LP is built for:
  about 20 s per LP at its default. The shortest move the limits allow (a closed-form lower
  bound of the time-optimal motion, :func:`kinematic_lower_bound_s`) is checked against it
  and against ``max_duration_s`` before anything is computed.
* **Memory.** The search keeps, per scenario it trains on, the linear map from the samples to
  the modal end state (M x 2 x (n+1) x 3 values) and its rows in the LP, and with a clearance
  limit the response during the move at every dt / 8 (8n x M x (n+1) values).
  :func:`search_bytes` estimates them at n steps; the search never builds a problem above the
  memory budget (jaxflex.budget: ``--max-memory``, default half the machine's memory), and a
  request whose shortest move is already above it is refused up front.
* **Time.** :func:`search_need` estimates what the search takes at least (its LP tests at the
  shortest move, the certification of every robust scenario) against the time budget
  (``--max-time``).
"""

from __future__ import annotations

import math

import numpy as np

from jaxflex.errors import BudgetError, InputError
from jaxflex.geometry import BLOCK_POINTS
from jaxflex.runtime import Need, current_budget, format_bytes
from optim.defaults import MAX_STEPS as MAX_STEPS  # its home: the defaults (light)
from optim.limits import Limits

# Copies of the dense end-state rows an LP holds: the builder's, the CSR matrix, the solver's.
LP_COPIES = 3
CLEARANCE_SUBSTEPS = 8


def kinematic_lower_bound_s(distance_m: np.ndarray, limits: Limits) -> float:
    """A lower bound (s) of the rest-to-rest move over ``distance_m`` (3,) m: on every axis
    a move of distance d needs at least d / vmax (cruise), 2 sqrt(d / amax) (bang-bang
    acceleration) and (32 d / jmax)^(1/3) (bang-bang jerk)."""
    d = np.abs(np.asarray(distance_m, dtype=np.float64))
    bound = np.maximum.reduce(
        [d / limits.vmax, 2.0 * np.sqrt(d / limits.amax), np.cbrt(32.0 * d / limits.jmax)]
    )
    return float(bound.max())


def check_move_length(
    distance_m: np.ndarray, limits: Limits, dt_s: float, max_duration_s: float, max_steps: int
) -> tuple[int, int]:
    """(fewest steps any move can have, most steps the search may use: min(max_duration_s /
    dt_s, max_steps)), after checking that the shortest possible move fits within both;
    InputError or BudgetError naming the option otherwise."""
    floor_s = kinematic_lower_bound_s(distance_m, limits)
    if floor_s > max_duration_s:
        raise InputError(
            f"distance_m: the move needs at least {floor_s:.4g} s at these limits, more than "
            f"max_duration_s = {max_duration_s:g} s (--max-duration); raise max_duration_s or "
            "the limits (--vmax, --amax, --jmax), or shorten the move"
        )
    steps = max(2, math.ceil(floor_s / dt_s - 1e-9))
    if steps * dt_s > max_duration_s * (1 + 1e-9):
        raise InputError(
            f"dt_s: a move on the grid of dt = {dt_s:g} s lasts at least {steps} steps = "
            f"{steps * dt_s:g} s, more than max_duration_s = {max_duration_s:g} s "
            "(--max-duration); use a finer --dt"
        )
    if steps > max_steps:
        raise BudgetError(
            f"dt_s: the shortest move (at least {floor_s:.4g} s at these limits) has {steps} "
            f"steps on the grid of dt = {dt_s:g} s, more than max_steps = {max_steps} "
            f"(--max-steps; each step adds 3 LP columns and about 9 rows per axis, and the LP "
            "time grows with the square of the steps); use a coarser --dt or raise --max-steps"
        )
    return steps, min(math.floor(max_duration_s / dt_s + 1e-9), max_steps)


def search_bytes(n_modes: int, n_steps: int, scenarios: int, clearance: bool) -> int:
    """Estimated memory (bytes) of the search's data at ``n_steps`` steps with ``scenarios``
    training scenarios (module docstring)."""
    end_maps = scenarios * n_modes * 2 * (n_steps + 1) * 3 * 8 * (1 + LP_COPIES)
    during = 0
    if clearance:  # the map, and the gradient route's dense copy over up to three axes
        during = (CLEARANCE_SUBSTEPS * n_steps + 1) * n_modes * (n_steps + 1) * 8 * (1 + 3)
    return end_maps + during


def steps_within_memory(
    n_modes: int, max_steps: int, scenarios: int, clearance: bool, budget_bytes: int
) -> int:
    """The largest n <= ``max_steps`` whose :func:`search_bytes` fits in ``budget_bytes``
    (0 if none does); the estimate grows with n, so bisection finds it."""
    lo, hi = 0, max_steps
    if search_bytes(n_modes, hi, scenarios, clearance) <= budget_bytes:
        return hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        fits = search_bytes(n_modes, mid, scenarios, clearance) <= budget_bytes
        lo, hi = (mid, hi) if fits else (lo, mid)
    return lo


def check_memory(
    n_modes: int,
    floor_steps: int,
    max_steps: int,
    scenarios: int,
    clearance: bool,
    budget_bytes: int,
) -> int:
    """The largest number of steps within the memory budget (at most ``max_steps``);
    BudgetError if even the shortest move (``floor_steps``) does not fit."""
    steps = steps_within_memory(n_modes, max_steps, scenarios, clearance, budget_bytes)
    if steps < floor_steps:
        need = search_bytes(n_modes, floor_steps, scenarios, clearance)
        what = " and the response during the move for the clearance" if clearance else ""
        raise BudgetError(
            f"memory: the search needs about {format_bytes(need)} already at the shortest move "
            f"of {floor_steps} steps ({n_modes} modes, {scenarios:,} scenario(s): the "
            f"end-state maps and their LP rows{what}), more than the budget of "
            f"{format_bytes(budget_bytes)} ({current_budget().memory_source}); use a coarser "
            "--dt, fewer modes or robust grid points (--grid), or raise --max-memory"
        )
    return steps


# The exact route's LP (HiGHS, 2-core machine; module docstring): seconds at 1 000 steps,
# growing with the square of the steps; the end-state rows of each scenario add to it
LP_S_AT_1000 = 0.9
# certifying one move's exact cycle time: per point, step and mode (jaxflex.settle)
CERTIFY_S = 2e-8


def search_need(
    n_modes: int,
    n_points: int,
    floor_steps: int,
    max_steps: int,
    scenarios: int,
    lp_steps: int | None = None,
) -> Need:
    """What the search will at least take (a jaxflex.budget.Need): the bisection's tests
    (log2 of the range of move lengths from ``floor_steps`` to ``max_steps``, and the
    polish) each solve an LP of ``lp_steps`` steps (default the shortest move; after the
    baselines, the best baseline's length: the first tests are near it) and certify every
    scenario's cycle time."""
    lp_steps = floor_steps if lp_steps is None else lp_steps
    tests = math.ceil(math.log2(max(max_steps - floor_steps, 2))) + 2
    lp_s = LP_S_AT_1000 * (lp_steps / 1000) ** 2 * (1 + scenarios * n_modes / 200)
    certify_s = CERTIFY_S * scenarios * n_points * lp_steps * n_modes
    return Need(
        f"the search ({tests} tests of moves of up to {lp_steps} steps, {scenarios:,} "
        f"scenario(s), {n_modes} modes, {n_points} points)",
        0.0,
        tests * (lp_s + certify_s),
        "use a coarser --dt, fewer robust grid points (--grid), modes or points, or a "
        "shorter --max-duration",
    )


# the distance of a point to one obstacle piece (a triangle of a mesh, a box, a half-space),
# NumPy (jaxflex.cell; 2-core machine): 0.73 us per point and triangle, 0.35 us per box
PIECE_S = 7e-7


def obstacle_pieces(cell) -> int:
    """The convex pieces of a cell's obstacles (a mesh's triangles, a box, a half-space)."""
    return sum(len(getattr(obstacle, "triangles", (0,))) for obstacle in cell.obstacles)


def distance_need(cell, n_points: int, floor_steps: int, max_steps: int) -> Need:
    """What keeping the distance to ``cell``'s obstacles takes at least: every test of the
    search bounds the distance of every block of points (jaxflex.collision.BLOCK_POINTS: a
    block's supporting-plane bound rules most (time, block) pairs out) to every piece at each
    sample of a move of at least ``floor_steps`` steps."""
    pieces = obstacle_pieces(cell)
    tests = math.ceil(math.log2(max(max_steps - floor_steps, 2))) + 2
    blocks = math.ceil(n_points / BLOCK_POINTS)
    pairs = float(blocks) * pieces * (floor_steps + 1)
    return Need(
        f"the distance to the cell's obstacles ({pieces:,} piece(s): triangles, boxes, "
        f"half-spaces; {n_points} points in {blocks} blocks at each of at least "
        f"{floor_steps + 1} samples, {tests} tests)",
        0.0,
        tests * pairs * PIECE_S,
        "simplify the obstacles (fewer triangles: a coarser mesh, or boxes), or use fewer "
        "monitored points",
    )
