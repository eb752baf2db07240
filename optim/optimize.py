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

The options come as frozen objects checked when made (optim.options: Search, Constraints,
Rotation, Budget; with optim.limits.Limits and optim.robust.RobustSpec); the request is
checked once, where it enters (optim.request.Request); the work is a pipeline of stages
with one job each (optim.stages: plan, baselines, search, choose, certify, report), each
adding its part to one growing run. Input that is allowed but probably not meant (a
threshold above every deviation or below the model's resolution, a sparse robust grid) is
reported as warnings (optim.advice).
"""

from __future__ import annotations

import time

from jaxflex.model import ModalModel
from optim import stages
from optim.limits import Limits
from optim.options import Budget, Constraints, RobustSpec, Rotation, Search
from optim.request import Request
from optim.result import OptimizationResult


def optimize(
    model: ModalModel,
    distance_m,
    limits: Limits,
    dt_s: float,
    threshold_m: float,
    *,
    robust: RobustSpec | None = None,
    constraints: Constraints | None = None,
    rotation: Rotation | None = None,
    search: Search | None = None,
    budget: Budget | None = None,
) -> OptimizationResult:
    """The move over ``distance_m`` ((3,) m) within ``limits`` with the shortest cycle time
    (move plus settling below ``threshold_m`` m), on the ``dt_s`` grid.

    robust: None for the nominal model, or a RobustSpec: then the worst cycle time over the
        spec's frequency-scale / damping grid is minimised (recommended: FE frequencies and
        damping are uncertain).
    constraints: an optim.Constraints: the cell the part moves in (a jaxflex.geometry.Cell:
        obstacles, the part's pose, via points, gravity; the move is then the cell's,
        ``distance_m`` None or equal, and in cell coordinates) and what the move must keep:
        the clearance during the move, the distance to the obstacles, the cups, the stress.
        With ``robust`` the cell's constraints hold for the nominal model and every model of
        the robust grid (certified on each; the report names the model with the smallest
        margin).
    rotation: an optim.Rotation: the part also turns by ``angle_deg`` about ``axis`` (model
        frame, through ``pivot_m``) within ``angular_limits``, under gravity, the turn on a
        fixed schedule per move length (optim.turn; the model needs its rotation data). Both
        routes take it, with ``robust`` and the constraints (the cell's via points and
        constraints on the exact route only, as for a straight move).
    search: an optim.Search: the method ("exact": LP feasibility tests, the default;
        "gradient": smooth surrogate), its solver, the baselines' shaped modes, progress.
    budget: an optim.Budget: the longest move (max_duration_s), the most steps of an LP
        (max_steps) and the search's memory (max_memory_bytes, default the process's
        budget). A request that cannot fit them, or the time budget, is refused before any
        work with a BudgetError that says what it needs.
    None for an option object: its defaults. Each option object checks its fields when
    made (optim.options); what needs the model is checked here (optim.request).
    """
    start = time.perf_counter()
    request = Request(
        model=model,
        distance_m=distance_m,
        limits=limits,
        dt_s=dt_s,
        threshold_m=threshold_m,
        robust=robust,
        constraints=constraints,
        rotation=rotation,
        search=search,
        budget=budget,
    )
    return run(request, start)


def run(request: Request, start: float | None = None) -> OptimizationResult:
    """Run the stages (optim.stages) on a checked request, each adding its part to the one
    growing :class:`optim.stages.Run`; ``start`` the ``time.perf_counter()`` the wall time
    is counted from (default: now)."""
    run = stages.Run(request, time.perf_counter() if start is None else start)
    run.plan = stages.plan(run)
    run.base = stages.baselines(run)
    run.found = stages.search(run)
    run.choice = stages.choose(run)
    run.certified = stages.certify(run)
    return stages.report(run)
