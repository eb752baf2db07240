"""The cases of a sweep (every layout with every move) and their content-derived ids.

A case id is a hash of everything that determines its result (part, modal settings, cups,
move, optimisation settings) and nothing else: renaming a layout or reordering the spec keeps
the stored results; changing a setting makes new cases. A layout id likewise identifies the
finite-element model (part, modal settings, cups), which the cases of all moves share.
The jobs handed to the workers are plain dicts (picklable, JSON-able).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass

from optim.sweep.spec import LayoutSpec, MoveSpec, SweepSpec


def _digest(data) -> str:
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Case:
    """One layout with one move; ``index`` is its row in the spec's order."""

    index: int
    case_id: str
    layout_id: str
    layout: LayoutSpec
    move: MoveSpec


def layout_job(spec: SweepSpec, layout: LayoutSpec) -> dict:
    """What the finite-element step needs: part, modal settings, cups (SI units)."""
    return {
        "part": asdict(spec.part),
        "model": asdict(spec.model),
        "cups": [list(c) for c in layout.cups],
    }


def case_job(spec: SweepSpec, case: Case) -> dict:
    """What the optimisation step needs besides the model: the move and the settings."""
    move = asdict(case.move)
    move.pop("name")
    return {"case_id": case.case_id, "move": move, "optimization": asdict(spec.optimization)}


def expand(spec: SweepSpec) -> list[Case]:
    """Every (layout, move) pair, layouts outer, in the spec's order."""
    cases = []
    for layout in spec.layouts:
        layout_id = _digest(layout_job(spec, layout))
        for move in spec.moves:
            dummy = Case(0, "", layout_id, layout, move)
            job = case_job(spec, dummy)
            case_id = _digest(
                {"layout": layout_id, "move": job["move"], "opt": job["optimization"]}
            )
            cases.append(Case(len(cases), case_id, layout_id, layout, move))
    return cases
