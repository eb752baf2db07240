"""The answer of a sweep, per move: the best layout, how it compares with its best baseline,
how many layouts tie with it; and the limits each move used (the spec's or the defaults).

Layouts are ranked by what the optimisation minimised (the worst case over the robust grid
in robust mode, else the nominal cycle time), ties (equal to the grid step) by the peak
deviation during the move.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from optim.sweep.cases import Case
from optim.sweep.spec import LIMIT_KEYS, SweepSpec


@dataclass(frozen=True)
class MoveBest:
    """The best layout of one move. Times in s."""

    move: str
    layout: str
    objective: str  # "cycle" or "worst case"
    objective_s: float
    ties: int  # other layouts with the same objective
    baseline: str  # the best baseline of that layout, by the same objective
    baseline_s: float
    n_layouts: int  # successful layouts of this move

    def line(self) -> str:
        saving = self.baseline_s - self.objective_s
        text = (
            f"move {self.move!r}: best layout {self.layout!r}, {self.objective} "
            f"{self.objective_s:.3f} s"
        )
        if saving > 0:
            text += (
                f", {saving:.3f} s ({100 * saving / self.baseline_s:.1f} %) shorter than its "
                f"best baseline, {self.baseline} {self.baseline_s:.3f} s"
            )
        else:
            text += f", as short as its best baseline, {self.baseline}"
        if self.ties:
            text += (
                f"; {self.ties} other layout{'s' if self.ties > 1 else ''} of "
                f"{self.n_layouts} tie at {self.objective_s:.3f} s (ranked by peak deviation)"
            )
        return text


RANKED = (
    "cycle_time_s",
    "worst_cycle_time_s",
    "peak_deviation_m",
    "best_baseline",
    "best_baseline_s",
    "best_baseline_cycle_time_s",
)


def objective_s(record: dict) -> float:
    """What a case's optimisation minimised: the robust worst case, else the cycle time."""
    opt = record["opt"]
    worst = opt.get("worst_cycle_time_s")
    return opt["cycle_time_s"] if worst is None else worst


def rank_key(record: dict) -> tuple[float, float]:
    return objective_s(record), record["opt"]["peak_deviation_m"]


def best_layouts(spec: SweepSpec, items: Iterable[tuple[Case, dict]]) -> list[MoveBest]:
    """Per move of ``spec`` with a successful case, its best layout (module docstring);
    ``items``: (case, record) pairs."""
    by_move: dict[str, list[tuple[Case, dict]]] = {}
    for case, record in items:  # kept: the few numbers ranked by (records may be thousands)
        if record.get("status") == "ok":
            slim = {"opt": {k: record["opt"].get(k) for k in RANKED}}
            by_move.setdefault(case.move.name, []).append((case, slim))
    found = []
    for move in spec.moves:
        ok = by_move.get(move.name)
        if not ok:
            continue
        case, record = min(ok, key=lambda item: rank_key(item[1]))
        best = objective_s(record)
        opt = record["opt"]
        found.append(
            MoveBest(
                move=move.name,
                layout=case.layout.name,
                objective="cycle" if opt.get("worst_cycle_time_s") is None else "worst case",
                objective_s=best,
                ties=sum(objective_s(r) == best for _, r in ok) - 1,
                baseline=opt["best_baseline"],
                baseline_s=opt["best_baseline_s"] or opt["best_baseline_cycle_time_s"],
                n_layouts=len(ok),
            )
        )
    return found


def move_limits(spec: SweepSpec) -> list[str]:
    """One line per move: its distance and the limits it used, saying which were defaults
    (not given in the spec)."""
    given = [dict(m) for m in spec.source.get("moves", [])] if spec.source else []
    lines = []
    for i, move in enumerate(spec.moves):
        raw = given[i] if i < len(given) else {}
        parts = []
        for key, unit in LIMIT_KEYS:
            values = getattr(move, key)
            shown = (
                f"{values[0]:g}" if len(set(values)) == 1 else " ".join(f"{v:g}" for v in values)
            )
            parts.append(f"{key} {shown} {unit}" + ("" if key in raw else " (default)"))
        distance = " ".join(f"{v:g}" for v in move.distance_m)
        lines.append(f"move {move.name!r}: distance ({distance}) m, " + ", ".join(parts))
    return lines
