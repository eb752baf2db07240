"""What fem.size_model chose and why: the candidate table, the error figures and a report.

Errors are dimensionless: ``linf`` is max_t |d(t) - d_ref(t)| / max_t d_ref(t) on the
evaluation grid, ``r2`` the coefficient of determination of d against d_ref; settle times in s.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fem.modal import ModalResult
from fem.sizing.curves import SettleCheck
from jaxflex.files import write_text_atomic
from jaxflex.model import ModalModel


@dataclass(frozen=True)
class Row:
    """One candidate that was evaluated: ``stage`` "mesh" / "points" / "modes" / "final",
    what it is, its cost, what it was compared with, the errors and the verdict."""

    stage: str
    candidate: str
    cost: str
    against: str
    linf: float | None = None
    r2: float | None = None
    settle: SettleCheck | None = None
    accepted: bool | None = None
    note: str = ""

    @classmethod
    def compared(
        cls,
        stage: str,
        candidate: str,
        cost: str,
        against: str,
        err: dict,
        settle,
        ok: bool,
        note: str = "",
    ) -> Row:
        """A candidate checked against ``against``: ``err`` from fem.sizing.curves.curve_error."""
        return cls(stage, candidate, cost, against, err["linf"], err["r2"], settle, ok, note)

    def as_dict(self) -> dict[str, Any]:
        out = {
            "stage": self.stage,
            "candidate": self.candidate,
            "cost": self.cost,
            "against": self.against,
            "linf_rel_peak": self.linf,
            "r2": self.r2,
            "accepted": self.accepted,
            "note": self.note,
        }
        if self.settle is not None:
            out["settle_s"] = self.settle.settle_s
            out["settle_reference_s"] = self.settle.reference_s
            out["settle_allowed_s"] = self.settle.allowed_s
            out["settle_band_s"] = None if self.settle.band_s is None else list(self.settle.band_s)
            out["settle_ok"] = self.settle.ok
        return out


def _json_safe(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return _json_safe(value.tolist())
    if isinstance(value, np.integer | np.bool_):
        return value.item()
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    return value


def _percent(value: float | None) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    return f"{100 * value:.3g} %"


def _r2(value: float | None) -> str:
    return "-" if value is None else f"{value:.6f}"


@dataclass(eq=False)
class SizingResult:
    """Outcome of :func:`fem.size_model` (SI units).

    Attributes:
        model: the chosen jaxflex.ModalModel (its meta["sizing"] holds :meth:`as_dict`
            without the table rows).
        result: the fem.ModalResult of the chosen mesh (all modes computed there).
        tolerance: the requested accuracy (fraction, 0.01 = 1 %).
        met: True if the chosen model met the tolerance against the richer model (and the
            mesh sequence converged to it).
        choice: mesh size, cup element size, DOFs, modes, highest frequency, points, voxel.
        reference: the richer model it was checked against (mesh, DOFs, modes, points, peak
            deviation, settle and cycle time).
        error: measured error of the choice against the reference, and the reference's own
            estimated error (Richardson on the mesh sequence, quasi-static modal residual).
        checks: effective-mass fraction, static residual fraction and the quasi-static
            estimate of the chosen modal truncation.
        rows: every candidate evaluated (:class:`Row`), in order.
        move, notes, timings_s: the move, remarks for the reader, wall times in s.
    """

    model: ModalModel
    result: ModalResult
    tolerance: float
    met: bool
    choice: dict[str, Any]
    reference: dict[str, Any]
    error: dict[str, Any]
    checks: dict[str, Any]
    rows: list[Row]
    move: dict[str, Any]
    notes: list[str] = field(default_factory=list)
    timings_s: dict[str, float] = field(default_factory=dict)

    def as_dict(self, rows: bool = True) -> dict[str, Any]:
        """JSON-serialisable report (non-finite numbers become null)."""
        out = {
            "tolerance": self.tolerance,
            "met": self.met,
            "choice": self.choice,
            "reference": self.reference,
            "error": self.error,
            "checks": self.checks,
            "move": self.move,
            "notes": self.notes,
            "timings_s": self.timings_s,
        }
        if rows:
            out["candidates"] = [row.as_dict() for row in self.rows]
        return _json_safe(out)

    def save_report(self, path: str | os.PathLike) -> None:
        """Write :meth:`as_dict` as JSON, atomically."""
        write_text_atomic(path, json.dumps(self.as_dict(), indent=2) + "\n")

    def summary(self) -> str:
        """The explanation: every candidate with its cost and errors, the choice, the error
        estimate and the modal checks."""
        tol = self.tolerance
        ref, err, choice = self.reference, self.error, self.choice
        lines = [
            f"model sizing to {_percent(tol)}: deviation L-inf <= {_percent(tol)} of the peak, "
            f"settle time within {_percent(tol)} of the cycle time or inside the settle band "
            f"of thresholds (1 +- {tol:g}) x {self.move['threshold_m']:g} m",
            f"move: {self.move['n_steps']} steps of {self.move['dt_s']:g} s, threshold "
            f"{self.move['threshold_m']:g} m; reference peak deviation {ref['peak_m']:.4g} m, "
            f"settle {ref['settle_s']:.4f} s, cycle {ref['cycle_s']:.4f} s",
            "",
            f"{'stage':7s}{'candidate':30s}{'cost':16s}{'against':24s}{'L-inf':>9s} "
            f"{'R^2':>9s}  settle                               ok",
        ]
        for row in self.rows:
            verdict = {True: "yes", False: "no", None: ""}[row.accepted]
            settle = row.settle.describe() if row.settle is not None else "-"
            lines.append(
                f"{row.stage:7s}{row.candidate[:29]:30s}{row.cost[:15]:16s}{row.against[:23]:24s}"
                f"{_percent(row.linf):>9s} {_r2(row.r2):>9s}  {settle:36s} {verdict}"
                + (f"  ({row.note})" if row.note else "")
            )
        est = err["reference_estimate"]
        lines += [
            "",
            f"chosen: {choice['describe']}",
            f"  cost: {choice['n_points']} points x {choice['n_modes']} modes = "
            f"{choice['n_points'] * choice['n_modes']} shape entries per axis "
            f"(reference {ref['n_points']} x {ref['n_modes']}); FE {choice['n_dof']} DOFs, "
            f"modal analysis {choice['modal_analysis_s']:.2f} s",
            f"  measured against the reference ({ref['describe']}): L-inf "
            f"{_percent(err['linf'])} of the peak, R^2 {_r2(err['r2'])}, settle "
            f"{err['settle_s']:.4f} s vs {err['settle_reference_s']:.4f} s "
            f"({1e3 * err['settle_error_s']:+.1f} ms)",
            f"  the reference's own error (estimated): mesh {_percent(est['mesh'])} "
            f"({est['mesh_note']}), truncated modes {_percent(est['modes'])} (quasi-static "
            "residual), points: not estimated (every node of its mesh)",
            f"  estimated error against the converged model: <= {_percent(err['estimated'])} "
            "(measured + the reference's estimate)",
            "  modal checks of the choice: effective mass "
            + ", ".join(
                f"{d} {_percent(v)}"
                for d, v in zip("xyz", self.checks["effective_mass_fraction"], strict=True)
                if v is not None and math.isfinite(v)
            )
            + "; static residual "
            + ", ".join(
                f"{d} {_percent(v)}"
                for d, v in zip("xyz", self.checks["static_residual_fraction"], strict=True)
                if v is not None and math.isfinite(v)
            )
            + f"; quasi-static estimate of the truncation {_percent(self.checks['quasi_static'])}"
            " of the peak",
            "tolerance " + ("met" if self.met else "NOT met") + ".",
        ]
        lines += [f"note: {note}" for note in self.notes]
        return "\n".join(lines)
