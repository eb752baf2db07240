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

The arguments are checked once, where they enter (optim.request.Request); the work is a
pipeline of stages with one job each (optim.stages: plan, baselines, search, choose,
certify, report). Input that is allowed but probably not meant (a threshold above every
deviation or below the model's resolution, a sparse robust grid) is reported as warnings
(optim.advice).
"""

from __future__ import annotations

import time

from jaxflex.defaults import MAX_DURATION_S
from jaxflex.model import ModalModel
from optim import stages
from optim.baselines import MAX_SHAPED_MODES
from optim.budget import MAX_STEPS
from optim.limits import Limits
from optim.request import Request
from optim.result import OptimizationResult
from optim.robust import RobustSpec


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
    max_duration_s: float = MAX_DURATION_S,
    max_shaped_modes: int = MAX_SHAPED_MODES,
    clearance_m: float | None = None,
    max_steps: int = MAX_STEPS,
    max_memory_bytes: int | None = None,
    cell=None,
    min_distance_m: float | None = None,
    cup_safety: float | None = None,
    max_stress_pa: float | str | None = None,
    rotate=None,
    angular_limits=None,
    pivot_m=None,
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
        built for; the search's memory, default the process's budget, jaxflex._budget). A
        request that cannot fit them, or the time budget, is refused before any work with a
        BudgetError that says what it needs.
    cell: a jaxflex.geometry.Cell (obstacles, the part's pose, via points, gravity); the move is
        then the cell's (``distance_m`` None or equal) and in cell coordinates.
    min_distance_m: every monitored point keeps this distance (m) from every obstacle of the
        cell, over the move and the settling (certified).
    cup_safety: every cup's utilisation (jaxflex._loads) with this safety factor stays <= 1.
    max_stress_pa: the von Mises stress stays below this (Pa; "yield": the material's yield
        strength / 1.5).
    With ``robust`` the cell's constraints hold for the nominal model and every model of the
    robust grid (certified on each; the report names the model with the smallest margin).
    rotate: (axis, angle_deg): the part also turns by the angle (degrees) about the axis
        ("x", "y", "z" or three numbers, model frame, through the gripper origin) under
        gravity -9.81 m/s^2 along z, the turn on a fixed schedule per move length
        (optim.turn; the model needs its rotation data, jaxflex._rotation). Both routes
        take it, with ``robust``, ``clearance_m`` and a cell (its via points and
        constraints on the exact route only, as for a straight move).
    angular_limits: (rate rad/s, acceleration rad/s^2, jerk rad/s^3) of the turn, default
        optim.turn.ANGULAR_LIMITS (3, 20, 200).
    pivot_m: (3,) m, the point (model frame) the turn's axis passes through and whose
        acceleration the move's samples are (default the origin).
    """
    start = time.perf_counter()
    request = Request(
        model, distance_m, limits, dt_s, threshold_m, method, solver, robust, progress,
        max_duration_s, max_shaped_modes, clearance_m, max_steps, max_memory_bytes, cell,
        min_distance_m, cup_safety, max_stress_pa, rotate, angular_limits, pivot_m,
    )  # fmt: skip
    return run(request, start)


def run(request: Request, start: float | None = None) -> OptimizationResult:
    """Run the stages (optim.stages) on a checked request; ``start`` the
    ``time.perf_counter()`` the wall time is counted from (default: now)."""
    start = time.perf_counter() if start is None else start
    plan = stages.plan(request)
    base = stages.baselines(request, plan)
    found = stages.search(request, plan, base)
    choice = stages.choose(request, plan, base, found)
    certified = stages.certify(request, plan, base, found, choice)
    return stages.report(request, plan, base, found, choice, certified, start)
