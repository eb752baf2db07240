"""``optim.optimize``: the minimum-cycle-time move under robot limits, by either route.

1. Baselines (optim.baselines): the kinematic floor from ruckig and the shaped moves; the
   best baseline's cycle time (worst case, in robust mode) brackets the search from above.
2. Bisection over the number of steps (optim.search) with the exact route's LP
   (optim.exact, default) or the gradient route's smooth NLP (optim.gradient), every
   feasible answer certified with the exact cycle time of every scenario.
3. Exact route: a polish pass picks the smoothest move among those with the margin found.
4. The returned move is the best certified move seen, baselines included, that passes the
   limits check (optim.choice): never worse than a baseline, and the report says where it
   came from when it is not the optimiser's final move.

With a cell (optim.cell_setup: obstacles, via points, cup and stress limits) the model is
posed in the cell, the baselines follow the via points, only baselines that meet the cell's
constraints bound the search and may be returned, and the exact route adds the constraints'
rows (optim.cell_rows), for every model of the robust grid in robust mode
(optim.cell_scenarios). The gradient route does not take them (refused, naming the exact
route).

Input that is allowed but probably not meant (a threshold above every deviation or below
the model's resolution, a sparse robust grid) is reported as warnings (optim.advice).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping

import numpy as np

from jaxflex.errors import BudgetError, InputError, JaxflexError
from jaxflex.files import check_positive
from jaxflex.model import ModalModel
from jaxflex.response import analyze_move, as_move
from jaxflex.runtime import current_budget, issue, model_resolution, require, threshold_advice
from optim.advice import grid_advice
from optim.baselines import baselines as compute_baselines
from optim.baselines import via_baselines
from optim.budget import (
    MAX_STEPS,
    check_memory,
    check_move_length,
    distance_need,
    search_need,
)
from optim.cell_setup import prepare_cell
from optim.choice import candidates, choose
from optim.exact import POLISH_MARGIN, LPSubsolver
from optim.gradient import GRADIENT_SOLVERS, GradientSubsolver
from optim.limits import Limits, check_profile
from optim.lp import LP_SOLVERS
from optim.move_response import SAMPLING_ALLOWANCE, shortest_clearance_move_s
from optim.result import OptimizationResult, deviation_summary
from optim.robust import RobustSpec
from optim.search import active_components, attempt, bisect, make_problem

METHODS = {"exact": ("highs", LP_SOLVERS), "gradient": ("ipopt", GRADIENT_SOLVERS)}
DEFAULT_MAX_DURATION_S = 30.0


def _as_limits(limits) -> Limits:
    if isinstance(limits, Limits):
        return limits
    if isinstance(limits, Mapping):
        if "vmax_m_s" in limits:
            return Limits.from_dict(dict(limits))
        return Limits(**limits)
    raise InputError(
        f"limits: expected optim.Limits(vmax, amax, jmax, ...) or a mapping, got {limits!r}"
    )


def _check_model(model, robust: RobustSpec | None) -> None:
    if not isinstance(model, ModalModel):
        raise InputError(f"model: expected a jaxflex.ModalModel, got {type(model).__name__}")
    zeta = np.asarray(model.zeta)
    if robust is None or robust.zeta is None:
        undamped = np.flatnonzero(zeta <= 0)
        if undamped.size:
            i = int(undamped[0])
            raise InputError(
                f"model.zeta: mode {i} ({float(model.freq_hz[i]):.4g} Hz) is undamped (zeta = 0); "
                "its vibration never decays, so no cycle time exists. Set a damping ratio "
                "(model.with_damping) or a robust zeta range"
            )


def _cell_limits(*limits) -> bool:
    return any(limit is not None for limit in limits)


def _as_robust(robust) -> RobustSpec | None:
    if robust is None or isinstance(robust, RobustSpec):
        return robust
    if robust is True:
        return RobustSpec()
    if isinstance(robust, Mapping):
        return RobustSpec.from_dict(dict(robust))
    raise InputError(f"robust: expected None, True or optim.RobustSpec(...), got {robust!r}")


def optimize(
    model: ModalModel,
    distance_m,
    limits: Limits,
    dt_s: float,
    threshold_m: float,
    *,
    method: str = "exact",
    solver: str | None = None,
    robust: RobustSpec | None = None,
    progress: bool | None = None,
    max_duration_s: float = DEFAULT_MAX_DURATION_S,
    max_shaped_modes: int = 6,
    clearance_m: float | None = None,
    max_steps: int = MAX_STEPS,
    max_memory_bytes: int | None = None,
    cell=None,
    min_distance_m: float | None = None,
    cup_safety: float | None = None,
    max_stress_pa: float | str | None = None,
) -> OptimizationResult:
    """The move over ``distance_m`` ((3,) m) within ``limits`` with the shortest cycle time
    (move plus settling below ``threshold_m`` m), on the ``dt_s`` grid.

    method: "exact" (LP feasibility tests, solver "highs", "casadi" (Clp) or
        "casadi-highs") or "gradient" (smooth surrogate, solver "ipopt" or "slsqp").
    robust: None for the nominal model, or a RobustSpec: then the worst cycle time over the
        spec's frequency-scale / damping grid is minimised (recommended: FE frequencies and
        damping are uncertain).
    max_duration_s: longest move considered (a request that needs more is an error).
    clearance_m: optional limit on the deviation of the nominal model during the move (m,
        at exact samples every dt / 8), e.g. to keep the part clear of a fixture.
    max_steps, max_memory_bytes: the budgets of optim.budget (the longest move any LP is
        built for; the search's memory, default the process's budget, jaxflex.budget). A
        request that cannot fit them, or the time budget, is refused before any work with a
        BudgetError that says what it needs.
    cell: a jaxflex.cell.Cell (obstacles, the part's pose, via points, gravity); the move is
        then the cell's (``distance_m`` None or equal) and in cell coordinates.
    min_distance_m: every monitored point keeps this distance (m) from every obstacle of the
        cell, over the move and the settling (certified).
    cup_safety: every cup's utilisation (jaxflex.loads) with this safety factor stays <= 1.
    max_stress_pa: the von Mises stress stays below this (Pa; "yield": the material's yield
        strength / 1.5).
    With ``robust`` the cell's constraints hold for the nominal model and every model of the
    robust grid (certified on each; the report names the model with the smallest margin).
    """
    start = time.perf_counter()
    robust = _as_robust(robust)
    _check_model(model, robust)
    has_via = bool(getattr(cell, "via", ()))
    if method == "gradient" and (
        has_via or _cell_limits(min_distance_m, cup_safety, max_stress_pa)
    ):
        raise InputError(
            "method: the gradient route does not take via points or the cell's constraints "
            "(min_distance_m, cup_safety, max_stress_pa); the exact route does: method='exact' "
            "(jaxflex optimize --method exact, the default)"
        )
    if cell is not None and min_distance_m is not None:  # before the cell's set-up measures
        _plan_distance(model, cell, _as_limits(limits), dt_s, max_duration_s, max_steps)
    setup = prepare_cell(
        model,
        distance_m,
        cell=cell,
        min_distance_m=min_distance_m,
        max_stress_pa=max_stress_pa,
        cup_safety=cup_safety,
        robust=robust,
    )
    model, distance = setup.model, setup.distance
    limits = _as_limits(limits)
    threshold_m = check_positive("threshold_m", threshold_m)
    dt_s = check_positive("dt_s", dt_s)
    check_positive("max_duration_s", max_duration_s)
    if clearance_m is not None:
        clearance_m = check_positive("clearance_m", clearance_m)
    if method not in METHODS:
        raise InputError(f"method: must be one of {sorted(METHODS)}, got {method!r}")
    default_solver, allowed = METHODS[method]
    solver = default_solver if solver is None else solver
    if solver not in allowed:
        raise InputError(f"solver: method {method!r} accepts {allowed}, got {solver!r}")
    if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 2:
        raise InputError(f"max_steps: must be an integer >= 2, got {max_steps!r}")
    memory = current_budget().memory_bytes if max_memory_bytes is None else max_memory_bytes
    check_positive("max_memory_bytes", memory)
    shortest, allowed_steps = check_move_length(distance, limits, dt_s, max_duration_s, max_steps)
    if clearance_m is not None:
        _check_clearance(model, distance, clearance_m, max_duration_s)
    scenarios = 1 if robust is None else robust.n_scenarios
    steps_cap = check_memory(
        model.n_modes, shortest, allowed_steps, scenarios, clearance_m is not None, memory
    )
    require(search_need(model.n_modes, model.n_points, shortest, steps_cap, scenarios))
    advice = issue(grid_advice(robust) + setup.advice)

    fractions: list[float] = []
    if setup.via:
        base, fractions = via_baselines(
            model,
            distance,
            [v[0] for v in setup.via],
            limits,
            dt_s,
            threshold_m,
            robust=robust,
            max_steps=steps_cap,
        )
    else:
        base = compute_baselines(
            model,
            distance,
            limits,
            dt_s,
            threshold_m,
            robust=robust,
            max_shaped_modes=max_shaped_modes,
            max_steps=steps_cap,
            progress=progress,
        )
    feasible = []
    for entry in base.entries:
        entry.constraints_ok, entry.constraints = setup.feasible(entry.acc, dt_s)
        if entry.constraints_ok:
            feasible.append(entry)
    floor = base.entries[0]  # the fastest move there is on the grid (along the path)
    advice += issue(
        threshold_advice(
            threshold_m,
            floor.timing.settle_time_s,
            deviation_summary(model, floor.acc, dt_s)["peak_during_move_m"],
            model_resolution(model, distance),
        )
    )
    problem = make_problem(
        model, distance, limits, dt_s, threshold_m, steps_cap, robust, clearance_m
    )
    problem.families = setup.families
    problem.via = [(o, m, t, f) for (o, m, t), f in zip(setup.via, fractions, strict=True)]
    sub = LPSubsolver(solver) if method == "exact" else GradientSubsolver(solver)
    bound = min((e.score() for e in feasible), default=steps_cap * dt_s)
    upper = math.ceil(bound / dt_s - 1e-9)
    # the search's moves are now bracketed: its LPs reach up to the best baseline's length
    bracket = min(upper, steps_cap)
    require(search_need(model.n_modes, model.n_points, shortest, bracket, scenarios, bracket))
    best, history = bisect(
        problem, sub, base.floor_acc, upper, [e.acc for e in base.entries], progress=progress
    )
    if best is None and not (setup.families and feasible):
        during = "" if clearance_m is None else f" (and below {clearance_m * 1e3:g} mm during it)"
        during += " within the cell's constraints" if setup.families else ""
        if steps_cap < math.floor(max_duration_s / dt_s + 1e-9):
            raise BudgetError(
                f"no move of at most {steps_cap} steps ({steps_cap * dt_s:g} s) keeps the "
                f"deviation below {threshold_m * 1e3:g} mm after it{during}; longer moves "
                f"exceed the budget (--max-steps {max_steps}, --max-memory "
                f"{memory / 1e9:.3g} GB); raise them, use a coarser --dt or raise the threshold"
            )
        raise InputError(
            f"threshold_m: no move of at most max_duration_s = {max_duration_s:g} s keeps the "
            f"deviation below {threshold_m * 1e3:g} mm after it{during}; raise "
            "max_duration_s, threshold_m" + ("" if clearance_m is None else " or clearance_m")
        )
    final, notes = best, []
    if method == "exact" and best is not None:
        final, notes = _polish(problem, sub, best, history)
    # the search's moves meet the cell's constraints (its rows are restrictions); only the
    # baselines that meet them may be returned
    found = candidates(problem, history, final, base, eligible=lambda e: e.constraints_ok)
    try:
        chosen, check, choice_notes = choose(
            found, lambda acc: check_profile(acc, dt_s, limits, distance)
        )
    except ValueError as exc:
        raise JaxflexError(str(exc)) from exc
    notes += choice_notes
    acc = chosen.acc
    timing = analyze_move(model, acc, dt_s, threshold_m)
    worst = None
    if robust is not None:
        worst = _worst_case(problem, acc, dt_s, threshold_m, chosen.grid)
    stats = {
        "route": sub.name,
        "attempts": [a.summary() for a in history],
        "subproblems": sum(len(a.solver_stats) for a in history),
        "pooled_rows": len(problem.pool),
        "training_scenarios": [problem.scenarios[i].as_dict() for i in problem.training],
        "totals": _totals(history),
        "notes": notes,
    }
    return OptimizationResult(
        clearance_m=clearance_m,
        model=model,
        distance_m=distance,
        dt_s=dt_s,
        threshold_m=threshold_m,
        limits=limits,
        method=method,
        solver=solver,
        robust=robust,
        acc=acc,
        timing=timing,
        deviation=deviation_summary(model, acc, dt_s),
        constraint_check=check,
        source=chosen.name if chosen.kind == "baseline" else chosen.kind,
        warnings=advice,
        solver_stats=stats,
        wall_time_s=time.perf_counter() - start,
        baselines=base,
        worst_case=worst,
        constraints=setup.describe_move(acc, dt_s) if setup.families else [],
        cell=setup,
    )


def _plan_distance(model, cell, limits, dt_s, max_duration_s, max_steps) -> None:
    """Refuse a distance constraint whose certification cannot fit the time budget (optim.
    budget.distance_need), before anything is measured against the obstacles."""
    dt_s = check_positive("dt_s", dt_s)
    shortest, allowed = check_move_length(
        cell.distance_m, limits, dt_s, check_positive("max_duration_s", max_duration_s), max_steps
    )
    require(distance_need(cell, model.n_points, shortest, allowed))


def _check_clearance(model, distance, clearance_m, max_duration_s) -> None:
    """Refuse a clearance no move within max_duration_s can meet (a necessary condition,
    optim.move_response.shortest_clearance_move_s), before the search tries ever longer
    moves."""
    t_min, mode = shortest_clearance_move_s(model, active_components(model), distance, clearance_m)
    if t_min > max_duration_s:
        raise InputError(
            f"clearance_m: no move of at most max_duration_s = {max_duration_s:g} s keeps the "
            f"deviation during it below {clearance_m:.3g} m: mode {mode} "
            f"({float(model.freq_hz[mode]):.4g} Hz) alone needs a move of at least "
            f"{t_min:.4g} s to stay within even {SAMPLING_ALLOWANCE:g} times that (--clearance, "
            "--max-duration)"
        )


def _polish(problem, sub: LPSubsolver, best, history) -> tuple:
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


def _worst_case(problem, acc, dt_s, threshold_m, grid) -> dict:
    """Worst exact cycle time over the robust check grid (reusing certified timings)."""
    if grid is None:
        move = as_move(acc, dt_s, at_rest=True)  # checked once for the whole grid
        grid = [
            (
                s.scale,
                s.zeta,
                analyze_move(s.model, move, dt_s, threshold_m, settle=False).cycle_time_s,
            )
            for s in problem.scenarios
        ]
    scale, zeta, cycle = max(grid, key=lambda g: g[2])
    return {
        "cycle_time_s": cycle,
        "freq_scale": scale,
        "zeta": zeta,
        "grid": [{"freq_scale": s, "zeta": z, "cycle_time_s": c} for s, z, c in grid],
    }


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


def _totals(history) -> dict:
    """Solver work summed over every subproblem of the search; for the gradient route also
    whether every Ipopt / SLSQP run reported success (casadi ``stats()['success']``)."""
    every = [s for a in history for s in a.solver_stats]
    totals = {key: sum(s.get(key, 0) for s in every) for key in _SUMMED}
    totals = {k: v for k, v in totals.items() if v}
    if any("success" in s for s in every):
        totals["all_nlp_success"] = all(s.get("success", True) for s in every)
    return totals
