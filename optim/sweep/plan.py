"""What a sweep will cost, planned before its first case (jaxflex._budget).

* **The spec** (:func:`spec_need`, while it is read, before its grids are expanded): every
  layout and case is an object of the run (``BYTES_PER_CASE``) and takes at least
  ``MIN_CASE_S`` of a worker's time (the smallest cases of docs/sweep.md: 0.13 s of FE and
  0.5 s of optimisation).
* **The cases** (:func:`sweep_needs`, before any is computed): each layout's modal analysis
  (fem.mesh.plan, with the first layout's cups), its model at the monitored points, each move's
  search (optim.budget: the memory at its shortest move and the time of its tests) on top of
  what every case takes (``MIN_CASE_S``: its baselines, exact timings and record), each on
  one worker at a time; the time of all the pending work is shared by the workers, the memory
  is what every worker needs at once. A move that no case can run (its shortest move longer
  than ``max_duration_s``) refuses the spec here: every case would fail, and so does a mode
  count above what the part's mesh has (``model.n_modes`` more than its DOFs: the FE would
  quietly give fewer, at the cost of a dense solve of every DOF).
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict

from fem.mesh.plan import fe_plan
from fem.supports import SuctionCup
from jaxflex.errors import InputError
from jaxflex.runtime import Need, current_budget
from optim.budget import MAX_STEPS, check_memory, check_move_length, search_bytes, search_need
from optim.limits import Limits
from optim.options import RobustSpec
from optim.sweep.part import build_part

BYTES_PER_CASE = 3e3  # a case, its layout, its id and status in the run, its table row
# the least a case takes on a worker besides its search: its baselines, exact timings and
# record (CPU s on the 2-core machine: 80 cases of tests/sweep_cases.py's part with 20 moves,
# their answer the kinematic floor, took 25.4 s, 0.26 s a case with the FE and start-up)
MIN_CASE_S = 0.3
MODEL_COPIES = 4  # a layout's model: the FE result's, the payload, the task's, the store's


def workers(n_workers: int | None, executor: str) -> int:
    """The worker processes a run will have (serial: this one)."""
    if executor == "serial":
        return 1
    return n_workers or os.cpu_count() or 1


def spec_need(n_layouts: int, n_moves: int, n_workers: int | None = None) -> Need:
    """What expanding and running a spec of ``n_layouts`` layouts and ``n_moves`` moves takes
    at least (module docstring)."""
    cases = n_layouts * n_moves
    share = workers(n_workers, "dask")
    return Need(
        f"the sweep's {n_layouts:,} layout(s) x {n_moves} move(s) = {cases:,} cases (at "
        f"least {MIN_CASE_S:g} s each on {share} worker(s))",
        BYTES_PER_CASE * cases,
        MIN_CASE_S * cases / share,
        "use fewer grid values (their product is the number of layouts) or moves, or split "
        "the sweep",
    )


def sweep_needs(spec, pending: int, pending_layouts: int, n_workers: int) -> list[Need]:
    """The needs of computing ``pending`` cases of ``pending_layouts`` layouts of ``spec`` (an
    optim.sweep.spec.SweepSpec) on ``n_workers`` workers (module docstring)."""
    part = build_part(asdict(spec.part))
    cups = [SuctionCup(c[0], c[1], c[-1], z=c[2] if len(c) == 4 else None)
            for c in spec.layouts[0].cups]  # fmt: skip
    fe = fe_plan(part, spec.model.n_modes, cups)
    if spec.model.n_modes > fe.n_dof:
        raise InputError(
            f"model.n_modes: {spec.model.n_modes:,} modes asked, more than the part's mesh "
            f"has DOFs (about {fe.n_dof:,} '{fe.element}' DOFs in {fe.cells:,} cells); ask for "
            "fewer modes (the lowest ones matter) or a finer part.mesh_size_m"
        )
    nx, ny = spec.model.monitor_grid
    points = nx * ny  # at most: those on the part are kept
    model_bytes = MODEL_COPIES * 8.0 * points * (3 * spec.model.n_modes + 3)
    opt = spec.optimization
    robust = None if opt.robust is None else RobustSpec.from_dict(opt.robust)
    scenarios = 1 if robust is None else robust.n_scenarios
    budget = current_budget()
    per_worker = budget.memory_bytes / n_workers
    case_s, case_bytes = [], []
    for move in spec.moves:
        limits = Limits(move.vmax, move.amax, move.jmax)
        try:
            shortest, allowed = check_move_length(
                move.distance_m, limits, opt.dt_s, opt.max_duration_s, MAX_STEPS
            )
        except InputError as exc:
            raise type(exc)(f"moves ({move.name}): no case can run: {exc}") from None
        check_memory(spec.model.n_modes, shortest, allowed, scenarios, False, per_worker)
        search = search_need(spec.model.n_modes, points, shortest, allowed, scenarios)
        case_s.append(MIN_CASE_S + search.time_s)
        case_bytes.append(search_bytes(spec.model.n_modes, shortest, scenarios, False))
    layouts_s = pending_layouts * fe.time_s
    cases_s = pending * sum(case_s) / len(case_s)
    share = f"on {n_workers} worker(s)"
    return [
        Need(
            f"each worker's analyses and searches ({n_workers} at once: "
            + fe.need("a layout's modal analysis").what
            + f"; its model at up to {points:,} monitored points)",
            n_workers * (max(fe.memory_bytes, max(case_bytes)) + model_bytes),
            0.0,
            "use a coarser mesh (part.mesh_size_m), fewer modes or monitored points "
            "(model.monitor_grid), fewer --workers",
        ),
        Need(
            f"the {pending_layouts:,} modal analyses and {pending:,} searches left {share} "
            f"(about {fe.time_s:.3g} s per layout and {math.fsum(case_s) / len(case_s):.3g} s "
            "per case)",
            0.0,
            (layouts_s + cases_s) / n_workers,
            "split the sweep, use a coarser mesh or fewer moves, or raise --max-time (a "
            "stopped sweep keeps its cases: the same command computes the rest)",
        ),
    ]
