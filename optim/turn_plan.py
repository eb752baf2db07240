"""What optimising a move that turns the part costs, planned before the work
(jaxflex._budget Needs; optim.budget plans the straight move's search).

A turning search (optim.turn, optim.stages) differs from a straight one in where its time
goes: every move length it tests has its own turn schedules (optim.turn.TurnSchedule: the
stretched turn, then up to SHAPED_SCHEDULES shaped ones, each tried while none is
certified), and for each schedule the turning engine runs (jaxflex._turning: the turn's own
end state, the certification of an LP's answer), whose programs are compiled once per move
length. Measured on the project's 2-core machine (CPU s, a cold JAX cache, whole runs of
`jaxflex optimize --rotate` logged stage by stage; the 1.2 x 0.8 m turning plate at 54
points and 4 modes and the built-in plate at 7 854 points and 20 modes cost alike: the
engine's evaluations are dominated by fixed work at these sizes):

* COMPILE_S per new move length, EVAL_S per turning response or settling, EVAL_STEP_S more
  per step;
* the LP of a schedule: optim.budget's LP_S_AT_1000 growing with the square of the steps,
  ROUNDS rounds of rows per schedule tried;
* with a clearance, the response during the move every dt / 8 (optim.move_response's state
  map: 8 n x M x n values, shared by a length's schedules): CLEARANCE_S per value;
* with the cell's constraints, their certificates (branch and bound over the turning
  move): FAMILY_S per family and schedule;
* once per scenario's model, the turning bound's kernels (jaxflex.response.
  turning_bound_need: time and memory growing with omega_max dt, the sub-samples per step).

Every schedule of every length is counted (a search tries the shaped ones only while none
is certified), so the plan errs high: over whole runs of the turning plate lifted 1 m and
tilted 30 degrees (free, with --angular-limits 1e9 1e9 1e9, with a clearance, in a cell
with a box and a 90-degree via orientation, the pivot 1e6 m off the axis) and the built-in
plate, each stage's plan was 1.0-12 times the CPU seconds the stage took (median 3;
COMPILE_S, EVAL_S and FAMILY_S were 2.0, 0.5 and 1.0 s before those runs: 6-30 times).

The plan is made in three steps, each before the work it covers:

1. :func:`check_clearance_resolution`, at once: a clearance below what the model resolves
   is refused (no move could be told to meet it: the search would try ever longer moves);
2. :func:`turn_plan_need`, before the baselines: the baselines (BASELINE_EVALS turning
   evaluations, on every robust model) and the first tests of the search near the floor;
3. :func:`turn_search_need`, once the baselines bracket the search (a turning search stops
   at the best baseline's length: no longer move can beat it; stages.search): the tests of
   every length up to the bracket (the gallop from the floor and the bisection); without a
   bracket (no baseline meets the clearance or the cell's constraints) the search is
   planned a length at a time (:class:`LengthPlanner`: before each new length, that test
   and the bisection below it), and refused when the next one no longer fits.
"""

from __future__ import annotations

import math

import numpy as np

from jaxflex.errors import InputError
from jaxflex.response import turning_bound_need
from jaxflex.runtime import Need, model_resolution, require
from optim.budget import LP_S_AT_1000
from optim.kinematics import clean_distance
from optim.ruckig_move import grid_steps, time_optimal_move
from optim.turn_baselines import SHAPED_SCHEDULES

COMPILE_S = 0.3
EVAL_S = 0.08
EVAL_STEP_S = 2.5e-4
ROUNDS = 3
CLEARANCE_S = 3.5e-8
FAMILY_S = 0.1
BASELINE_EVALS = 10  # the floor and a few shaped moves per shaper (optim.turn_baselines)
NEAR_FLOOR_TESTS = 3  # the first gallop lengths, before a bracket is known
ADVICE = (
    "raise --max-time, use a coarser --dt or fewer robust grid points (--grid), or relax "
    "what makes the move long (--clearance, --threshold, the cell's limits)"
)


def gallop_lengths(floor_steps: int, cap_steps: int) -> list[int]:
    """The lengths a search tests while none is feasible (optim.search.bisect's gallop:
    from the floor in strides of 4 % that double, the last one the cap)."""
    lengths, n, stride = [], floor_steps, max(1, math.ceil(0.04 * floor_steps))
    while True:
        lengths.append(n)
        if n >= cap_steps:
            return lengths
        lo, n = n, n + stride
        stride *= 2
        if lo < cap_steps < n:
            n = cap_steps


def test_s(n_steps: int, n_modes: int, schedules: int, *, clearance: bool, families: int) -> float:
    """CPU seconds of one turning test of an ``n_steps`` move trying ``schedules`` turn
    schedules (module docstring)."""
    evaluation = EVAL_S + EVAL_STEP_S * n_steps
    lp = LP_S_AT_1000 * (n_steps / 1000) ** 2 * (1 + n_modes / 200)
    schedule = 2 * evaluation + ROUNDS * lp + FAMILY_S * families
    shared = COMPILE_S
    if clearance:
        shared += CLEARANCE_S * 8 * n_steps**2 * n_modes
    return shared + schedules * schedule


def _tests_needed(floor_steps: int, bracket_steps: int) -> list[int]:
    """Every length a search bracketed by ``bracket_steps`` may test: the gallop up to the
    bracket, then the bisection of the last stride (at about the bracket's length)."""
    lengths = gallop_lengths(floor_steps, bracket_steps)
    last = lengths[-1] - (lengths[-2] if len(lengths) > 1 else floor_steps - 1)
    return lengths + [lengths[-1]] * max(0, (last - 1).bit_length())


def _describe(request, model, lengths: list[int]) -> str:
    parts = [f"{model.n_modes} modes", f"{request.n_scenarios:,} scenario(s)"]
    if request.constraints.clearance_m is not None:
        parts.append("the clearance during the move")
    return (
        f"{len(lengths)} tests of moves of {min(lengths)} to {max(lengths)} steps, up to "
        f"{_schedules(request)} turn schedules each, " + ", ".join(parts)
    )


def _schedules(request) -> int:
    """The turn schedules a test may try (optim.turn.TurnSchedule)."""
    return 1 + (SHAPED_SCHEDULES if request.turn.turns else 0)


def search_s(request, model, lengths: list[int], families: int) -> float:
    """CPU seconds of testing ``lengths`` (every schedule of each: a length is tested in
    full when none is certified) and certifying each answer on every robust scenario."""
    schedules = _schedules(request)
    total = 0.0
    for n in lengths:
        total += test_s(
            n, model.n_modes, schedules, clearance=request.constraints.clearance_m is not None,
            families=families,
        )  # fmt: skip
        total += (request.n_scenarios - 1) * (EVAL_S + EVAL_STEP_S * n)
    return total


def turning_floor_steps(request, distance_m, shortest_steps: int) -> int:
    """The fewest steps of a turning move: the longer of the translation's time-optimal
    move (ruckig) and the turn alone, on the grid (at least ``shortest_steps``, the
    closed-form bound of optim.budget)."""
    duration = max(
        time_optimal_move(clean_distance(distance_m), request.limits).duration_s,
        request.turn.fastest_s(),
    )
    return max(shortest_steps, grid_steps(duration, request.dt_s))


def turn_plan_need(request, model, floor_steps: int, families: int) -> Need:
    """What a turning optimisation takes at least, before its baselines: BASELINE_EVALS
    turning evaluations near the floor (``floor_steps``, :func:`turning_floor_steps`; each
    on every robust scenario) and the search's first NEAR_FLOOR_TESTS tests."""
    evals = BASELINE_EVALS * request.n_scenarios
    baselines = evals * (EVAL_S + EVAL_STEP_S * floor_steps) + 4 * COMPILE_S
    lengths = gallop_lengths(floor_steps, 10 * floor_steps)[:NEAR_FLOOR_TESTS]
    # each scenario's model builds the turning bound's kernels once (stiff parts at a long
    # step: many sub-samples); they stay in memory with the model
    bound = turning_bound_need(model, request.dt_s)
    return Need(
        f"the turning move's baselines ({evals:,} turning evaluations) and its search's first "
        f"{_describe(request, model, lengths)}; {bound.what}",
        request.n_scenarios * bound.memory_bytes,
        baselines
        + search_s(request, model, lengths, families)
        + request.n_scenarios * bound.time_s,
        ADVICE if bound.time_s < 1.0 else f"{ADVICE}; {bound.advice}",
    )


def turn_search_need(request, model, floor_steps: int, bracket_steps: int, families: int) -> Need:
    """What the turning search takes once the best baseline brackets it at
    ``bracket_steps``: every length up to the bracket (:func:`_tests_needed`)."""
    lengths = _tests_needed(floor_steps, max(bracket_steps, floor_steps))
    return Need(
        f"the turning search ({_describe(request, model, lengths)})",
        0.0,
        search_s(request, model, lengths, families),
        ADVICE,
    )


class LengthPlanner:
    """Plans a turning search a length at a time where no baseline brackets it: before a
    length beyond those planned is tested (optim.turn.TurnSchedule.variants), the test of
    that length and the bisection below it must fit the time left (jaxflex.runtime.require)."""

    def __init__(self, request, model, families: int, planned_steps: int) -> None:
        self.request, self.model, self.families = request, model, families
        self.planned_steps = planned_steps
        self.tested = 0

    def __call__(self, n_steps: int) -> None:
        if n_steps > self.planned_steps:
            below = max(1, (n_steps - max(self.tested, 1)).bit_length())
            lengths = [n_steps] * (1 + below)
            require(
                Need(
                    f"the turning search beyond {self.planned_steps} steps (no baseline "
                    f"meets the constraints: {_describe(self.request, self.model, lengths)})",
                    0.0,
                    search_s(self.request, self.model, lengths, self.families),
                    ADVICE,
                )
            )
            self.planned_steps = n_steps
        self.tested = max(self.tested, n_steps)


def resolution_m(model, distance_m, max_duration_s: float) -> tuple[float, float, float, float]:
    """(the smallest deviation the model resolves for a move over ``distance_m`` (3,) m of
    at most ``max_duration_s``, m; the model's relative resolution along the move
    (jaxflex.runtime.model_resolution: at least 0.1 %, the reduced model against the
    full-order FE); the deflection it is a share of, m; that move's acceleration, m/s^2):
    the relative resolution of the quasi-static deflection under the gentlest acceleration
    that covers the distance in that time, 4 |d| / T^2 per axis (a rest-to-rest move over d
    within T accelerates at least that much at some instant): the static response where the
    model has one, else its modes' share."""
    distance = np.asarray(distance_m, dtype=np.float64)
    acc = 4.0 * np.abs(distance) / max_duration_s**2
    static = model.static_shapes
    if static is None:
        along = np.asarray(model.gamma) @ acc / np.asarray(model.omega_rad_s) ** 2  # (M,)
        deflection = np.linalg.norm(np.asarray(model.shapes) @ along, axis=1)
    else:
        deflection = np.linalg.norm(np.asarray(static) @ acc, axis=1)
    peak = float(deflection.max())
    relative = model_resolution(model, distance) if np.any(distance) else 0.0
    return relative * peak, relative, peak, float(np.linalg.norm(acc))


def check_clearance_resolution(request, model, distance_m) -> None:
    """Refuse (InputError naming --clearance) a turning move's clearance below the model's
    resolution (:func:`resolution_m`): the search could not tell a move that meets it from
    one that does not, and would try ever longer moves. A straight move's clearance has a
    sharper test (optim.stages: the shortest move any clearance allows)."""
    clearance_m = request.constraints.clearance_m
    if clearance_m is None:
        return
    max_duration_s = request.budget.max_duration_s
    floor, relative, deflection, acc = resolution_m(model, distance_m, max_duration_s)
    if clearance_m < floor:
        raise InputError(
            f"clearance_m (--clearance): {clearance_m:.3g} m is below the model's "
            f"resolution for this move, {floor:.3g} m ({relative:.2g} of {deflection:.3g} m, "
            "the quasi-static deflection under the gentlest acceleration that covers the "
            f"distance in max_duration_s = {max_duration_s:g} s, {acc:.3g} m/s^2): no "
            "move can be told to meet it; give a clearance above it"
        )


def plan_turning_search(request, plan, base, problem, upper_steps: int) -> None:
    """Once the baselines are known (optim.stages.search): a turning search stops at the
    best baseline's length ``upper_steps`` (no longer move beats that baseline, whose
    schedule the search's need not share) and is planned up to it
    (:func:`turn_search_need`); without a baseline that meets the constraints, it is
    planned a length at a time (:class:`LengthPlanner`)."""
    model, families = plan.setup.model, len(plan.setup.families)
    if base.feasible:
        bracket = min(upper_steps, plan.steps_cap)
        problem.max_steps = max(bracket, plan.shortest)
        require(turn_search_need(request, model, plan.shortest, bracket, families))
        return
    near = gallop_lengths(plan.shortest, plan.steps_cap)[:NEAR_FLOOR_TESTS]
    problem.turn.planner = LengthPlanner(request, model, families, near[-1])
