"""The stages of ``optim.optimize``, one job each, on a checked ``optim.request.Request``.

plan -> baselines -> search -> choose -> certify -> report, each reading the one growing
:class:`Run` (the request and what the stages before it found) and returning its part:

* :func:`plan`: the cell set-up (optim.cell_setup) and the budgets (optim.budget): the
  longest move the search may try, refused before any work if it cannot fit;
* :func:`baselines`: the baseline moves (optim.baselines), which of them meet the cell's
  constraints and the clearance (each baseline's deviation simulated once, kept for
  :func:`certify`), the threshold's advice;
* :func:`search`: the problem (built once, with the cell's rows and via points), the
  bisection over the number of steps (optim.search) and, on the exact route, the polish pass;
* :func:`choose`: the best certified move seen that passes the limits check (optim.choice);
* :func:`certify`: the chosen move's exact nominal timing (a baseline's is reused) and, in
  robust mode, its worst case (the search's certified grid is reused);
* :func:`report`: the OptimizationResult.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from jaxflex.errors import BudgetError, InputError, JaxflexError
from jaxflex.geometry import BLOCK_POINTS
from jaxflex.response import Move, SettleReport, analyze_move
from jaxflex.runtime import issue, model_resolution, require, threshold_advice
from optim.advice import grid_advice
from optim.baselines import Baseline, BaselineSet, via_baselines
from optim.baselines import baselines as compute_baselines
from optim.budget import (
    CellCost,
    check_memory,
    check_move_length,
    distance_need,
    families_need,
    models_need,
    obstacle_pieces,
    search_need,
)
from optim.cell_setup import CellSetup, prepare_cell
from optim.choice import Candidate, candidates
from optim.choice import choose as choose_candidate
from optim.exact import POLISH_MARGIN, LPSubsolver
from optim.limits import ConstraintCheck, check_profile
from optim.move_response import SAMPLING_ALLOWANCE, shortest_clearance_move_s
from optim.obstacle_reach import reachable_cell
from optim.request import Request
from optim.result import OptimizationResult, deviation_summary
from optim.search import Attempt, Problem, active_components, attempt, bisect, scenarios
from optim.turn import TurnSchedule, turn_deviation
from optim.turn_baselines import turn_baselines, turn_via_baselines, turn_worst_case
from optim.turn_plan import (
    check_clearance_resolution,
    plan_turning_search,
    turn_plan_need,
    turning_floor_steps,
)
from optim.turn_via import ViaTurn
from optim.turn_via_baselines import oriented_via_baselines

if TYPE_CHECKING:
    from optim.gradient import GradientSubsolver


@dataclass(frozen=True)
class Plan:
    """The cell set-up and the search's budget: ``shortest`` the fewest steps any move can
    have, ``steps_cap`` the most steps a search's move may have."""

    setup: CellSetup
    shortest: int
    steps_cap: int
    advice: list[dict]


@dataclass(frozen=True)
class Baselines:
    """The baselines, where the via points fall (fractions of the move) and the baselines
    that meet the cell's constraints."""

    moves: BaselineSet
    via_fractions: list[float]
    feasible: list[Baseline]
    # deviation summaries by baseline name: the kinematic floor's (entries[0]) and, with a
    # clearance, every baseline's; each baseline is simulated once for them
    deviations: dict[str, dict]
    advice: list[dict]
    turn_trains: list = field(default_factory=list)  # shapers of the turn's schedules
    over_clearance: list[str] = field(default_factory=list)  # baselines above clearance_m


@dataclass
class Search:
    """The search's problem, its subsolver, every attempt and its final move (None if it
    found none)."""

    problem: Problem
    subsolver: LPSubsolver | GradientSubsolver
    history: list[Attempt]
    final: Attempt | None
    notes: list[str] = field(default_factory=list)
    nominal: list[Attempt] = field(default_factory=list)  # the robust cell's nominal search


@dataclass(frozen=True)
class Choice:
    move: Candidate
    check: ConstraintCheck
    notes: list[str]


@dataclass(frozen=True)
class Certified:
    timing: SettleReport
    deviation: dict
    worst_case: dict | None


@dataclass
class Run:
    """One run of the stages: the checked request, the ``time.perf_counter()`` its wall
    time counts from, and each stage's part as it is found (None before)."""

    request: Request
    start_s: float
    plan: Plan | None = None
    base: Baselines | None = None
    found: Search | None = None
    choice: Choice | None = None
    certified: Certified | None = None


def plan(run: Run) -> Plan:
    """Pose the model in the cell and fix the search's budget; refuse (InputError,
    BudgetError) what cannot fit before any work."""
    r = run.request
    models = 1 + (0 if r.robust is None else r.robust.n_scenarios)  # the cell's
    cell = reachable_cell(r)  # far obstacles left out (optim.obstacle_reach)
    if cell is not None and r.constraints.min_distance_m is not None:  # before the set-up measures
        shortest, _ = check_move_length(
            cell.distance_m, r.limits, r.dt_s, r.budget.max_duration_s, r.budget.max_steps
        )
        require(distance_need(cell, r.model.n_points, shortest, models))
    setup = prepare_cell(
        r.model,
        r.distance_m,
        cell=cell,
        min_distance_m=r.constraints.min_distance_m,
        max_stress_pa=r.constraints.max_stress_pa,
        cup_safety=r.constraints.cup_safety,
        robust=r.robust,
        turn=r.turn,
    )
    model = setup.model
    shortest, allowed = check_move_length(
        setup.distance_m, r.limits, r.dt_s, r.budget.max_duration_s, r.budget.max_steps
    )
    if setup.families and r.turn is None:  # a stiff part's constraints cost (optim.budget)
        require(families_need(setup.families, model, shortest, r.dt_s, r.n_scenarios))
    if r.turn is not None:  # before its baselines: a turning move's plan (optim.turn_plan)
        check_clearance_resolution(r, model, setup.distance_m)
        floor = turning_floor_steps(r, setup.distance_m, shortest)
        require(turn_plan_need(r, model, floor, len(setup.families)))
    if r.constraints.clearance_m is not None and (r.turn is None or not r.turn.turns):
        _check_clearance(setup, r.constraints.clearance_m, r.budget.max_duration_s)
    clearance = r.constraints.clearance_m is not None
    steps_cap = check_memory(
        model.n_modes, shortest, allowed, r.n_scenarios, clearance, r.budget.max_memory_bytes
    )
    cost = _cell_cost(cell, setup, models)
    need = search_need(model.n_modes, model.n_points, shortest, steps_cap, r.n_scenarios, cell=cost)
    grid = [] if r.robust is None else [models_need(model.n_modes, model.n_points, models)]
    require(need, *grid)
    return Plan(setup, shortest, steps_cap, issue(grid_advice(r.robust) + setup.advice))


def _cell_cost(cell, setup: CellSetup, models: int) -> CellCost | None:
    """What the cell's constraint families cost a search (optim.budget.CellCost), None
    without them: the distance's blocks of points and obstacle pieces, the loads' output
    rows, each family on ``models`` models."""
    if not setup.families:
        return None
    nominal = [getattr(f, "nominal", f) for f in setup.families]
    loads = [f.functional for f in nominal if hasattr(f, "functional")]
    rows = sum(f.n_items * f.rows_per_item for f in loads)
    distance = len(loads) < len(nominal)
    blocks = math.ceil(setup.model.n_points / BLOCK_POINTS) if distance else 0
    pieces = obstacle_pieces(cell) if distance else 0
    return CellCost(blocks, pieces, rows, len(nominal), models)


def _check_clearance(setup: CellSetup, clearance_m: float, max_duration_s: float) -> None:
    """Refuse a clearance no move within max_duration_s can meet (a necessary condition,
    optim.move_response.shortest_clearance_move_s), before the search tries ever longer
    moves. Straight moves (and turns by 0 degrees) only: the condition integrates the modal
    equation twice over the move, whose forcing is then -Gamma . a with double integral
    -Gamma . distance. With a turn the translation loads the modes in the body frame,
    R(t)^T a(t), whose double integral depends on when the translation happens along the
    turn (it can vanish for a nonzero distance), and the turn adds its own loads (Euler,
    centrifugal, the change of the sag): no bound from the distance alone remains, so
    turning moves are not pre-checked (the search finds an impossible clearance out)."""
    model = setup.model
    comps = active_components(model)
    t_min, mode = shortest_clearance_move_s(model, comps, setup.distance_m, clearance_m)
    if t_min > max_duration_s:
        raise InputError(
            f"clearance_m: no move of at most max_duration_s = {max_duration_s:g} s keeps the "
            f"deviation during it below {clearance_m:.3g} m: mode {mode} "
            f"({float(model.freq_hz[mode]):.4g} Hz) alone needs a move of at least "
            f"{t_min:.4g} s to stay within even {SAMPLING_ALLOWANCE:g} times that (--clearance, "
            "--max-duration)"
        )


def baselines(run: Run) -> Baselines:
    """The baselines (along the via points, if any), each marked whether it meets the cell's
    constraints, and the advice on the threshold from the kinematic floor's response."""
    r, plan = run.request, run.plan
    setup = plan.setup
    fractions: list[float] = []
    trains = []
    if r.turn is not None and setup.via:
        via = [v[0] for v in setup.via]
        through = oriented_via_baselines if isinstance(r.turn, ViaTurn) else turn_via_baselines
        moves, fractions = through(r, setup.model, setup.distance_m, via, plan.steps_cap)
    elif r.turn is not None:
        moves, trains = turn_baselines(r, setup.model, setup.distance_m, plan.steps_cap)
    elif setup.via:
        via = [v[0] for v in setup.via]
        moves, fractions = via_baselines(
            setup.model, setup.distance_m, via, r.limits, r.dt_s, r.threshold_m,
            robust=r.robust, max_steps=plan.steps_cap,
        )  # fmt: skip
    else:
        moves = compute_baselines(
            setup.model, setup.distance_m, r.limits, r.dt_s, r.threshold_m,
            robust=r.robust, max_shaped_modes=r.search.max_shaped_modes, max_steps=plan.steps_cap,
            progress=r.search.progress,
        )  # fmt: skip
    for entry in moves.entries:
        entry.constraints_ok, entry.constraints = setup.feasible(
            entry.move, entry.angular_acc, every=False
        )
    floor = moves.entries[0]  # the fastest move there is on the grid (along the path)
    measured = [floor] if r.constraints.clearance_m is None else moves.entries
    deviations = {
        e.name: _deviation(r, setup.model, e.move, e.angular_acc, e.neglected_bound_m)
        for e in measured
    }
    peak = deviations[floor.name]["peak_during_move_m"]
    resolution = model_resolution(setup.model, setup.distance_m)
    advice = threshold_advice(r.threshold_m, floor.timing.settle_time_s, peak, resolution)
    over = _over_clearance(r.constraints.clearance_m, deviations)
    for entry in moves.entries:
        entry.clearance_ok = entry.name not in over
    feasible = [e for e in moves.entries if e.allowed]
    return Baselines(moves, fractions, feasible, deviations, issue(advice), trains, over)


def _over_clearance(clearance_m: float | None, deviations: dict[str, dict]) -> list[str]:
    """The names of the baselines whose deviation during the move (``deviations``, by name)
    exceeds the clearance at the samples every dt / 8 it is held at: they are no
    candidates (none without a clearance)."""
    if clearance_m is None:
        return []
    return [name for name, d in deviations.items() if d["peak_during_move_m"] > clearance_m]


def _problem(request: Request, plan: Plan, base: Baselines) -> Problem:
    """The search's problem with the cell's constraint families and via points, or the
    turn's schedules."""
    r, setup, fractions = request, plan.setup, base.via_fractions
    via = [(o, m, t, f) for (o, m, t), f in zip(setup.via, fractions, strict=True)]
    grid, training = scenarios(setup.model, r.robust, r.threshold_m)
    comps = active_components(setup.model)
    turn = None if r.turn is None else TurnSchedule(r.turn, r.dt_s, base.turn_trains)
    if setup.turn_source is not None:
        setup.turn_source.schedule = turn  # the cell's families evaluate the search's turn
    clearance_m = r.constraints.clearance_m
    return Problem(
        setup.model, setup.distance_m, r.limits, r.threshold_m, r.dt_s, plan.steps_cap, r.robust,
        grid, training, comps, clearance_m, via=via, families=setup.families, turn=turn,
    )  # fmt: skip


def search(run: Run) -> Search:
    """Bisect over the number of steps below the best feasible baseline (optim.search),
    then, on the exact route, smooth the search's move (:func:`_polish`). Refuses a request
    no move can meet (no move found and no baseline to fall back on)."""
    r, plan, base = run.request, run.plan, run.base
    model = plan.setup.model
    problem = _problem(r, plan, base)
    method, solver = r.search.method, r.search.solver
    if method == "exact":
        sub = LPSubsolver(solver)
    else:
        from optim.gradient import GradientSubsolver  # scipy.optimize: ~0.1 s, when chosen

        sub = GradientSubsolver(solver)
    bound = min((e.score() for e in base.feasible), default=plan.steps_cap * r.dt_s)
    upper = math.ceil(bound / r.dt_s - 1e-9)
    if r.robust is None and not plan.setup.families:
        # the search's moves are now bracketed: its LPs reach up to the best baseline's
        # length (the nominal baselines are cheap: this refusal still comes early; a robust
        # or cell plan is final, its baselines can take longer)
        bracket = min(upper, plan.steps_cap)
        need = search_need(model.n_modes, model.n_points, plan.shortest, bracket, 1, bracket)
        require(need)
    notes = []
    if r.turn is not None:  # bracketed by the best baseline, and planned (optim.turn_plan)
        plan_turning_search(r, plan, base, problem, upper)
    moves = base.moves
    warm = [e.acc for e in moves.entries]
    start, nominal = _nominal_first(r, problem, sub, (moves.floor_acc, upper, warm))
    lowest = start if start is not None and problem.covers_nominal() else None
    best, history = bisect(
        problem, sub, moves.floor_acc, upper, warm, progress=r.search.progress, start_steps=start,
        lowest_steps=lowest,
    )  # fmt: skip
    if best is None and not ((plan.setup.families or r.turn is not None) and base.feasible):
        raise _no_move(r, plan)
    if best is None and r.turn is not None:
        notes.append(
            "the search's turn schedules found no certified move shorter than the best "
            "baseline; the best baseline is returned"
        )
    if r.search.method != "exact" or best is None:
        return Search(problem, sub, history, best, notes, nominal)
    final, notes = _polish(problem, sub, best, history)
    return Search(problem, sub, history, final, notes, nominal)


def _nominal_first(request: Request, problem: Problem, sub, bracket) -> tuple[int | None, list]:
    """With a robust grid and the cell's constraints (straight moves, exact route): the
    search of the nominal model alone first (cheap: one model to certify), whose answer is
    where the robust search starts and whose rows it starts from (the nominal model is one
    of the robust models of every constraint; optim.search.Problem.adopt). Where the
    nominal model is also one of the grid's scenarios of the cycle time, no shorter length
    is tested: a robust move is then a nominal one, and the nominal search, the same as the
    nominal run's, tried every shorter length (docs/optim.md, "The shortest certified
    move"). Returns (the nominal answer's steps or None, the nominal search's attempts)."""
    if request.robust is None or not problem.families or problem.turn is not None:
        return None, []
    if request.search.method != "exact":
        return None, []
    nominal = problem.nominal()
    floor, upper, warm = bracket
    found, attempts = bisect(nominal, sub, floor, upper, warm, progress=request.search.progress)
    problem.adopt(nominal)
    return (None if found is None else found.n_steps), attempts


def _no_move(request: Request, plan: Plan) -> JaxflexError:
    """The error for a search that found no move: the budget's (BudgetError) if longer
    moves were cut off by it, else the request's (InputError)."""
    r, cap, budget = request, plan.steps_cap, request.budget
    clearance_m = r.constraints.clearance_m
    during = "" if clearance_m is None else f" (and below {clearance_m * 1e3:g} mm during it)"
    during += " within the cell's constraints" if plan.setup.families else ""
    if cap < math.floor(budget.max_duration_s / r.dt_s + 1e-9):
        return BudgetError(
            f"no move of at most {cap} steps ({cap * r.dt_s:g} s) keeps the "
            f"deviation below {r.threshold_m * 1e3:g} mm after it{during}; longer moves "
            f"exceed the budget (--max-steps {budget.max_steps}, --max-memory "
            f"{budget.max_memory_bytes / 1e9:.3g} GB); raise them, use a coarser --dt or raise "
            "the threshold"
        )
    return InputError(
        f"threshold_m: no move of at most max_duration_s = {budget.max_duration_s:g} s keeps the "
        f"deviation below {r.threshold_m * 1e3:g} mm after it{during}; raise "
        "max_duration_s, threshold_m" + ("" if clearance_m is None else " or clearance_m")
    )


def _polish(problem: Problem, sub: LPSubsolver, best: Attempt, history: list[Attempt]) -> tuple:
    """The final solve of the exact route: the smoothest move of the search's length that
    keeps (nearly) its margin, every limit held a little inside (POLISH_MARGIN), or exactly
    on the limits where the reserve rules the length out (the kinematic floor, when the
    vibration does not limit the move). Returns (the smoothed attempt, or ``best`` if both
    fail, and notes)."""
    for margin in (POLISH_MARGIN, 0.0):
        polished = attempt(problem, sub.polishing(margin), best.n_steps, best.acc)
        history.append(polished)
        if polished.feasible:
            return polished, []
    return best, [
        f"the smoothing pass found no move of {best.n_steps} steps; the search's move is "
        "returned as found"
    ]


def choose(run: Run) -> Choice:
    """The best certified move seen (the search's, the polish pass's, the baselines that meet
    the cell's constraints: the search's moves meet them by construction) that passes the
    exact limits check (optim.choice)."""
    r, base, found = run.request, run.base, run.found
    distance = run.plan.setup.distance_m
    usable = {e.name for e in base.feasible}  # the cell's constraints and the clearance met
    moves = candidates(
        found.problem, found.history, found.final, base.moves, eligible=lambda e: e.name in usable
    )
    try:
        move, check, notes = choose_candidate(
            moves, lambda move: check_profile(move, r.limits, distance)
        )
    except ValueError as exc:
        raise JaxflexError(str(exc)) from exc
    if base.over_clearance:
        notes.append(
            f"baselines above the clearance during the move, not returned: "
            f"{', '.join(base.over_clearance)}"
        )
    return Choice(move, check, found.notes + notes)


def certify(run: Run) -> Certified:
    """The chosen move's exact nominal timing and deviation, and in robust mode its worst
    exact cycle time over the check grid; what the baselines or the search already
    certified for this move is reused (a baseline's timing and, where the baselines stage
    measured it, its deviation; the search's grid of cycle times)."""
    r, model, chosen = run.request, run.plan.setup.model, run.choice.move
    base, found = run.base, run.found
    move = chosen.move  # checked once, where the candidate was made, for every certificate
    entries = base.moves.entries
    known = next((e for e in entries if chosen.kind == "baseline" and e.name == chosen.name), None)
    if known:
        timing, bound = known.timing, known.neglected_bound_m
    elif r.turn is not None:
        timing, response = r.turn.timing(model, chosen.angular_acc, move, r.threshold_m)
        bound = response.neglected_bound_m
    else:
        timing, bound = analyze_move(model, move, threshold_m=r.threshold_m), None
    deviation = base.deviations.get(known.name) if known else None
    if deviation is None:
        deviation = _deviation(r, model, move, chosen.angular_acc, bound)
    worst = None
    if r.robust is not None:
        worst = _worst_case(found.problem, move, chosen.grid, chosen.angular_acc, r.turn)
    return Certified(timing, deviation, worst)


def _deviation(request: Request, model, move: Move, angular_acc, neglected_bound_m) -> dict:
    """The deviation summary of a move (optim.result); a turning move's (optim.turn, with
    the turn ``angular_acc``) carries ``neglected_bound_m``, the bound its timing's response
    gave (the move is not simulated again for it)."""
    if request.turn is None:
        return deviation_summary(model, move)
    found = turn_deviation(model, request.turn, angular_acc, move)
    return {**found, "neglected_bound_m": neglected_bound_m}


def _worst_case(problem: Problem, move: Move, grid, angular_acc, turn) -> dict:
    """Worst exact cycle time over the robust check grid: ``grid`` (the move's certified
    (scale, zeta, cycle time s) triples) if known, else computed on the problem's scenarios
    at its threshold (a turning move with its ``turn`` and ``angular_acc``)."""
    if grid is None and turn is not None:
        grid = [
            (g["freq_scale"], g["zeta"], g["cycle_time_s"])
            for g in turn_worst_case(
                problem.model, turn, move, angular_acc, problem.threshold_m,
                [(s.scale, s.zeta) for s in problem.scenarios],
            )[2]
        ]  # fmt: skip
    if grid is None:
        grid = []
        for s in problem.scenarios:
            timing = analyze_move(s.model, move, threshold_m=problem.threshold_m, settle=False)
            grid.append((s.scale, s.zeta, timing.cycle_time_s))
    scale, zeta, cycle = max(grid, key=lambda g: g[2])
    return {
        "cycle_time_s": cycle,
        "freq_scale": scale,
        "zeta": zeta,
        "grid": [{"freq_scale": s, "zeta": z, "cycle_time_s": c} for s, z, c in grid],
    }


def report(run: Run) -> OptimizationResult:
    """The OptimizationResult: the chosen move, what is certified about it, the baselines,
    the advice and the search's statistics; its wall time counted from the run's start."""
    r, plan, base, found, choice = run.request, run.plan, run.base, run.found, run.choice
    setup, move, certified = plan.setup, choice.move, run.certified
    history, problem = found.history, found.problem
    stats = {
        "route": found.subsolver.name,
        "attempts": [a.summary() for a in history],
        "subproblems": sum(len(a.solver_stats) for a in history),
        "pooled_rows": len(problem.pool),
        "training_scenarios": [problem.scenarios[i].as_dict() for i in problem.training],
        "nominal_attempts": [a.summary() for a in found.nominal],
        "totals": _totals(history),
        "notes": choice.notes,
    }
    return OptimizationResult(
        clearance_m=r.constraints.clearance_m,
        model=setup.model,
        distance_m=setup.distance_m,
        threshold_m=r.threshold_m,
        limits=r.limits,
        method=r.search.method,
        solver=r.search.solver,
        robust=r.robust,
        move=move.move,
        timing=certified.timing,
        deviation=certified.deviation,
        constraint_check=choice.check,
        source=move.name if move.kind == "baseline" else move.kind,
        warnings=plan.advice + base.advice,
        solver_stats=stats,
        wall_time_s=time.perf_counter() - run.start_s,
        baselines=base.moves,
        worst_case=certified.worst_case,
        constraints=setup.describe_move(move.move, move.angular_acc) if setup.families else [],
        cell=setup,
        turn=r.turn,
        angular_acc=move.angular_acc,
    )


_SUMMED = (
    "lp_solves",
    "lp_wall_s",
    "lp_iterations",
    "nlp_solves",
    "nlp_wall_s",
    "iterations",
    "jax_evaluations",
    "jax_s",
)


def _totals(history: list[Attempt]) -> dict:
    """Solver work summed over every subproblem of the search; for the gradient route also
    whether every Ipopt / SLSQP run reported success (casadi ``stats()['success']``)."""
    every = [s for a in history for s in a.solver_stats]
    totals = {key: sum(s.get(key, 0) for s in every) for key in _SUMMED}
    totals = {k: v for k, v in totals.items() if v}
    if any("success" in s for s in every):
        totals["all_nlp_success"] = all(s.get("success", True) for s in every)
    return totals
