"""The move ``optim.optimize`` returns: the best certified move it has seen, baselines included.

The search certifies moves that have settled when they end (cycle time n dt_s for every
scenario); a baseline may settle a fraction of a step after its end, and the smoothing pass
may need a step more than the search (it keeps a small reserve on every limit). So the
optimiser does not trust any one of them: every certified move of the search and of the
smoothing pass, and every baseline, is a candidate, ranked by

1. its objective: the exact cycle time of the nominal model, or in robust mode the worst
   exact cycle time over the check grid (the figure the baselines are compared by);
2. on a tie, the smoothed optimum first, then the search's moves, then the baselines (a
   baseline only wins when it is strictly better), shorter moves first;

and the first that passes the exact limits check (optim.limits) is returned, with a note
saying where it came from when it is not the smoothed optimum. By construction the returned
objective is never worse than any baseline's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jaxflex.response import Move, as_move
from optim.baselines import Baseline, BaselineSet
from optim.limits import ConstraintCheck
from optim.search import Attempt, Problem

KINDS = ("optimised", "search", "baseline")  # preference on equal objectives


@dataclass(frozen=True)
class Candidate:
    """A certified move: where it came from, the move (a checked Move: samples and step), its
    objective (s) and, in robust mode, its exact cycle time at every point of the check grid
    (or None if not known)."""

    kind: str  # one of KINDS
    name: str
    move: Move
    objective_s: float
    grid: list[tuple[float, float | None, float]] | None
    angular_acc: np.ndarray | None = None  # (n+1,) rad/s^2: the turn with the move, if any

    @property
    def n_steps(self) -> int:
        return self.move.n_steps

    def rank(self) -> tuple:
        return (self.objective_s, KINDS.index(self.kind), self.n_steps)


def _from_attempt(problem: Problem, attempt: Attempt, kind: str, name: str) -> Candidate:
    cycles = [attempt.timings[i].cycle_time_s for i in range(len(problem.scenarios))]
    grid = None
    if problem.robust is not None:
        grid = [(s.scale, s.zeta, c) for s, c in zip(problem.scenarios, cycles, strict=True)]
    move = as_move(attempt.acc, problem.dt_s, at_rest=True)
    return Candidate(kind, name, move, max(cycles), grid, attempt.turn_acc)


def candidates(
    problem: Problem,
    history: list[Attempt],
    final: Attempt | None,
    base: BaselineSet,
    eligible: Callable[[Baseline], bool] = lambda entry: True,
) -> list[Candidate]:
    """Every certified move of the search (``history``; ``final`` is the smoothed optimum or,
    without a smoothing pass, the search's best; None if the search found none) and every
    baseline that is ``eligible`` (e.g. meets the cell's constraints), best first."""
    found = [] if final is None else [_from_attempt(problem, final, "optimised", "optimised")]
    for attempt in history:
        if attempt.feasible and attempt is not final:
            found.append(
                _from_attempt(
                    problem, attempt, "search", f"search's move of {attempt.n_steps} steps"
                )
            )
    for entry in filter(eligible, base.entries):
        grid = None
        if entry.worst_grid is not None:
            grid = [(g["freq_scale"], g["zeta"], g["cycle_time_s"]) for g in entry.worst_grid]
        found.append(
            Candidate("baseline", entry.name, entry.move, entry.score(), grid, entry.angular_acc)
        )
    return sorted(found, key=Candidate.rank)


def choose(
    found: list[Candidate], check: Callable[[Move], ConstraintCheck]
) -> tuple[Candidate, ConstraintCheck, list[str]]:
    """The first candidate whose move passes ``check``, its check, and notes for the report
    (why it is not the smoothed optimum, if it is not). Raises ValueError if none passes."""
    notes = []
    optimised = next((c for c in found if c.kind == "optimised"), None)
    for cand in found:
        result = check(cand.move)
        if not result.ok:
            notes.append(f"{cand.name} rejected by the limits check ({result.summary()})")
            continue
        if cand is not optimised:
            notes.append(_why(cand, optimised))
        return cand, result, notes
    raise ValueError("no candidate move meets the limits exactly: " + "; ".join(notes))


def _why(chosen: Candidate, optimised: Candidate | None) -> str:
    if optimised is None:
        reason = "the optimiser found no certified move within the constraints shorter than it"
    elif chosen.objective_s < optimised.objective_s:
        reason = (
            f"it is shorter ({chosen.objective_s:.3f} s) than the optimiser's final move "
            f"({optimised.objective_s:.3f} s, {optimised.n_steps} steps)"
        )
    else:
        reason = "the optimiser's final move did not pass the limits check"
    if chosen.kind == "baseline":
        return f"returned the baseline {chosen.name!r}: {reason}"
    return f"returned the {chosen.name} (not smoothed): {reason}"
