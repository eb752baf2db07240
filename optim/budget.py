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
  memory budget (jaxflex._budget: ``--max-memory``, default half the machine's memory), and a
  request whose shortest move is already above it is refused up front. A robust grid's
  models are kept once built (:func:`models_need`: a few arrays per point each).
* **Time.** :func:`search_need` estimates what the search takes (its tests of moves near the
  shortest, each an LP or a few and the certification of every robust scenario and, with the
  cell's constraints, of every model; a robust cell search after its nominal search; the
  report) against the time budget (``--max-time``), in CPU seconds measured on this machine
  (the constants below), before any heavy work: the plan of a robust or cell search is
  final (a refusal comes within seconds of the start); a plain nominal search is planned
  again once its baselines bracket it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jaxflex.errors import BudgetError, InputError
from jaxflex.geometry import BLOCK_POINTS
from jaxflex.runtime import Need, current_budget, format_bytes
from optim.defaults import MAX_STEPS as MAX_STEPS  # its home: the defaults (light)
from optim.limits import Limits
from optim.residual import SAMPLES_PER_PERIOD

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


# a robust grid's model kept by the search: its static response and residual (9 + 9), its
# shapes' norms (M) and, for the cell, a posed copy of the points (3) and the families'
# per-model arrays (about M again), 8-byte floats per point
MODEL_POINT_FLOATS = 30


def models_need(n_modes: int, n_points: int, models: int) -> Need:
    """The memory of the ``models`` models a robust search keeps (the grid's, each built on
    first use and kept: the cycle time's scenarios and the cell's families)."""
    return Need(
        f"the {models:,} models of the robust grid ({n_points} points, {n_modes} modes each)",
        float(models) * n_points * 8 * (2 * n_modes + MODEL_POINT_FLOATS),
        0.0,
        "use fewer robust grid points (--grid) or fewer monitored points",
    )


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


# What a search costs, CPU seconds on this project's 2-core machine (measured with
# python -m optim.bench.cell --cases press and optim.bench.targets; docs/optim.md, Budget):
LP_S_AT_1000 = 0.9  # an LP of the kinematic rows at 1 000 steps, growing with the square
CELL_LP_FACTOR = 4.0  # the search's LPs with the cell's rows (via points, planes, cuts)
NEAR_FLOOR_TESTS = 8  # tests of a search whose answer lies near the floor (module docstring)
NOMINAL_FIRST_TESTS = 3  # tests of a robust cell search after the nominal one
ROUNDS = 1.5  # LPs (rounds of rows) per test of a search without the cell's constraints
CELL_ROUNDS = 3  # ... with them (2.3 on the press scene, 2.8 with its stress active)
TRAINING = 4  # robust scenarios an LP holds, typically
CYCLE_S = 2e-3  # one scenario's exact cycle time: a fixed part ...
CYCLE_S_PER = 1e-10  # ... and per point, step and mode (jaxflex._settle's pruned blocks)
RESIDUAL_S = 1e-7  # a training scenario's scan of its residual vibration, per point and mode
PIECE_S = 2.5e-7  # a distance certificate: per block of points, obstacle piece and sample
LOAD_S = 4e-9  # a load certificate: per output row and mode
FAMILY_S = 2e-3  # a certificate's fixed part, per constraint family and model
SCAN_FACTOR = 4.0  # a family's scan of a round (dt / 8 and the tail) against its certificate


@dataclass(frozen=True)
class CellCost:
    """What the cell's constraint families cost a search: the distance's ``blocks`` of points
    (jaxflex.geometry.BLOCK_POINTS) and obstacle ``pieces``, the load families' output rows
    ``load_rows``, the number of ``families`` and the ``models`` each is certified on (the
    nominal one and every model of a robust grid)."""

    blocks: int
    pieces: int
    load_rows: int
    families: int
    models: int

    def certify_s(self, n_steps: int, n_modes: int) -> float:
        """CPU seconds of one model's certificates of an ``n_steps``-step move."""
        distance = self.blocks * self.pieces * (n_steps + 1) * PIECE_S
        return distance + self.load_rows * n_modes * LOAD_S + self.families * FAMILY_S


def search_need(
    n_modes: int,
    n_points: int,
    floor_steps: int,
    max_steps: int,
    scenarios: int,
    lp_steps: int | None = None,
    *,
    cell: CellCost | None = None,
) -> Need:
    """What the search will take (a jaxflex.runtime.Need; constants above): its tests of moves
    near ``floor_steps`` (the gallop, the bisection, the polish, the lengths tried below the
    answer: NEAR_FLOOR_TESTS), or, given ``lp_steps`` (a baseline's length bracketing the
    search), the bisection of the range up to it at that length. Each test makes ROUNDS
    (with a cell CELL_ROUNDS) rounds (an LP of the training scenarios' end states and the
    cell's rows, their scans)
    and certifies every scenario's cycle time and, with a ``cell``, every model's
    constraints; a robust cell search first searches the nominal model alone and then tests
    only a few lengths (NOMINAL_FIRST_TESTS), and its report locates every model's values."""
    n = floor_steps if lp_steps is None else lp_steps
    tests = NEAR_FLOOR_TESTS
    if lp_steps is not None:
        tests = math.ceil(math.log2(max(lp_steps - floor_steps, 2))) + 2

    def test_s(models: int) -> float:
        training = min(scenarios if models > 1 or cell is None else 1, TRAINING)
        lp = LP_S_AT_1000 * (n / 1000) ** 2 * (1 + training * n_modes / 200)
        lp *= 1.0 if cell is None else CELL_LP_FACTOR
        residual = training * RESIDUAL_S * n_points * n_modes
        ones = scenarios if models > 1 or cell is None else 1
        cycle = ones * (CYCLE_S + CYCLE_S_PER * n_points * n * n_modes)
        rounds = ROUNDS if cell is None else CELL_ROUNDS
        return rounds * (lp + residual) + cycle + _cell_test_s(cell, models, n, n_modes)

    where = ""
    if cell is not None:
        where = f"; the cell's {cell.families} constraint(s) on {cell.models:,} model(s)"
    return Need(
        f"the search ({tests} tests of moves of about {n} steps, {scenarios:,} "
        f"scenario(s), {n_modes} modes, {n_points} points{where})",
        0.0,
        _schedule_s(test_s, tests, cell, n, n_modes),
        "use a coarser --dt, fewer robust grid points (--grid), modes or points, or a "
        "shorter --max-duration",
    )


def _cell_test_s(cell: CellCost | None, models: int, n_steps: int, n_modes: int) -> float:
    """CPU seconds of the cell's part of one test on ``models`` models: CELL_ROUNDS scans of
    the training models, a certificate of every model."""
    if cell is None:
        return 0.0
    certify = cell.certify_s(n_steps, n_modes)
    return CELL_ROUNDS * min(models, TRAINING) * SCAN_FACTOR * certify + models * certify


def _schedule_s(test_s, tests: int, cell: CellCost | None, n_steps: int, n_modes: int) -> float:
    """CPU seconds of ``tests`` tests (``test_s(models)`` each) and the report: with a cell
    on several models the nominal model's search first, then NOMINAL_FIRST_TESTS tests on
    every model."""
    if cell is None:
        return tests * test_s(1)
    report = cell.models * cell.certify_s(n_steps, n_modes)
    if cell.models == 1:
        return tests * test_s(1) + report
    return tests * test_s(1) + NOMINAL_FIRST_TESTS * test_s(cell.models) + report


def obstacle_pieces(cell) -> int:
    """The convex pieces of a cell's obstacles (a mesh's triangles, a box, a half-space)."""
    return sum(len(getattr(obstacle, "triangles", (0,))) for obstacle in cell.obstacles)


def distance_need(cell, n_points: int, floor_steps: int, models: int = 1) -> Need:
    """What keeping the distance to ``cell``'s obstacles takes at least, checked before the
    cell's set-up measures anything: every test of the search certifies the distance of
    every block of points (jaxflex.geometry.BLOCK_POINTS: a block's supporting-plane bound
    rules most (time, block) pairs out) to every piece at each sample of a move of at least
    ``floor_steps`` steps, on each of ``models`` models (:func:`search_need`'s schedule)."""
    pieces = obstacle_pieces(cell)
    blocks = math.ceil(n_points / BLOCK_POINTS)
    cost = CellCost(blocks, pieces, 0, 1, models)

    def test_s(on: int) -> float:
        return _cell_test_s(cost, on, floor_steps, 0)

    return Need(
        f"the distance to the cell's obstacles ({pieces:,} piece(s): triangles, boxes, "
        f"half-spaces; {n_points} points in {blocks} blocks at each of at least "
        f"{floor_steps + 1} samples, {NEAR_FLOOR_TESTS} tests, {models:,} model(s))",
        0.0,
        _schedule_s(test_s, NEAR_FLOOR_TESTS, cost, floor_steps, 0),
        "simplify the obstacles (fewer triangles: a coarser mesh, or boxes), or use fewer "
        "monitored points",
    )


# certifying a constraint family (cup utilisation, stresses, ...) over one move, by the
# samples of its dense check (optim.residual.SAMPLES_PER_PERIOD per period of the highest
# mode over the move): FAMILY_MOVE_S x samples^FAMILY_POWER CPU s, fitted to the cups of the
# built-in plate's mesh at 0.1 m (6 modes, 2 050 points; 2-core machine, its 18 baselines at
# a 69-step floor) made of steel (166 samples, 0.07 s a move), at E = 2.1e15 Pa (12 437,
# 0.57 s) and at E = 2.1e17 Pa (124 370, 1.55 s): within 15 % of each
FAMILY_MOVE_S = 8.2e-3
FAMILY_POWER = 0.45
BASELINE_MOVES = 18  # the straight move's baselines (optim.baselines: 3 shapers x 6 trains)


def families_need(families: list, model, floor_steps: int, dt_s: float, scenarios: int) -> Need:
    """What certifying the cell's constraint ``families`` on the baselines takes at least
    (before them): BASELINE_MOVES moves of at least ``floor_steps`` steps of ``dt_s``, each
    family on every one of ``scenarios`` models, sampled SAMPLES_PER_PERIOD times per period
    of ``model``'s highest mode (a stiff part's kHz modes make that long)."""
    f_max_hz = float(np.max(np.asarray(model.omega_rad_s))) / (2 * np.pi)
    samples = SAMPLES_PER_PERIOD * f_max_hz * floor_steps * dt_s
    names = ", ".join(f.name for f in families)
    return Need(
        f"the cell's constraints ({names}) on {BASELINE_MOVES} baselines, {samples:,.0f} "
        f"samples each (highest mode {f_max_hz:,.4g} Hz), {scenarios:,} scenario(s)",
        0.0,
        BASELINE_MOVES * len(families) * scenarios * FAMILY_MOVE_S * samples**FAMILY_POWER,
        "check the part's stiffness (its modes' frequencies), or use fewer modes or robust "
        "grid points (--grid)",
    )
