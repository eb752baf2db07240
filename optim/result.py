"""The result of an optimisation: samples, exact timing, checks, statistics, baselines.

``OptimizationResult.save(directory)`` writes, each file atomically:

* ``trajectory.csv`` — t, a, v, x per axis (jaxflex.trajectory_io format, SI units);
* ``report.json`` — inputs, exact times, ratios to the baselines, the constraint check,
  solver statistics, the robust worst case (see :meth:`OptimizationResult.report`);
* ``profiles.png`` — position, velocity, acceleration, jerk with the limits;
* ``deviation.png`` — deviation against time, optimum and baselines, with the threshold;
* ``robust.png`` and ``deviation_worst_case.png`` (robust mode) — cycle time across the
  uncertainty range for the optimum and the baselines; the optimum's deviation at its worst
  case;
* ``constraints.png`` (with cell constraints) — the largest cup utilisation, the largest von
  Mises stress and the smallest distance to the obstacles against time, with the limits.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from jaxflex.atomic import write_text_atomic
from jaxflex.deviation import deviation_curve
from jaxflex.model import ModalModel
from jaxflex.profile import integrate
from jaxflex.settle import SettleReport
from jaxflex.trajectory_io import write_trajectory_csv
from optim.baselines import BaselineSet
from optim.limits import ConstraintCheck, Limits
from optim.plots import plot_constraints, plot_deviations, plot_profiles, plot_robust
from optim.robust import RobustSpec, perturbed

SUBSTEPS = 8  # deviation curves in reports and plots: exact samples every dt / 8


def constraint_line(c: dict) -> str:
    """One line on a cell constraint's certified value (optim.cell_rows describe())."""
    when = "at rest" if not np.isfinite(c["time_s"]) else f"at {c['time_s']:.3f} s"
    if "distance" in c["name"]:
        return (
            f"{c['name']}: {c['peak'] * 1e3:.2f} mm (limit {c['limit'] * 1e3:g} mm) {when}, "
            f"point {c['item']}, obstacle {c.get('obstacle')!r}"
        )
    scale, unit = (1e-6, " MPa") if "stress" in c["name"] else (1.0, "")
    what = "cup" if "cup" in c["name"] else "stress point"
    return (
        f"{c['name']}: {c['peak'] * scale:.3g}{unit} (limit {c['limit'] * scale:.3g}{unit}, "
        f"utilisation {c['utilisation']:.1%}) {when}, {what} {c['item']}"
    )


def deviation_summary(model: ModalModel, acc: np.ndarray, dt_s: float) -> dict:
    """Peak deviation during the move (exact samples every dt / 8) and at the stop, m."""
    n = acc.shape[0] - 1
    t, d = deviation_curve(model, acc, dt_s, n * dt_s, SUBSTEPS)
    return {
        "peak_during_move_m": float(d[: n * SUBSTEPS + 1].max()),
        "peak_time_s": float(t[int(np.argmax(d[: n * SUBSTEPS + 1]))]),
        "at_stop_m": float(d[n * SUBSTEPS]),
        "sampling_s": dt_s / SUBSTEPS,
    }


@dataclass
class OptimizationResult:
    """Optimised move and everything known about it. Times in s, lengths in m."""

    model: ModalModel
    distance_m: np.ndarray
    dt_s: float
    threshold_m: float
    limits: Limits
    method: str
    solver: str
    robust: RobustSpec | None
    acc: np.ndarray  # (n+1, 3) m/s^2
    timing: SettleReport  # exact, nominal model
    deviation: dict
    constraint_check: ConstraintCheck
    solver_stats: dict
    wall_time_s: float
    baselines: BaselineSet
    worst_case: dict | None = None  # robust mode: worst exact cycle over the check grid
    clearance_m: float | None = None  # limit on the deviation during the move, if any
    constraints: list[dict] = field(default_factory=list)  # the cell's, certified
    cell: Any = None  # optim.cell_setup.CellSetup (posed model, via points, families)

    @property
    def n_steps(self) -> int:
        return int(self.acc.shape[0] - 1)

    @property
    def vel(self) -> np.ndarray:
        return integrate(self.acc, self.dt_s)[0]

    @property
    def pos(self) -> np.ndarray:
        return integrate(self.acc, self.dt_s)[1]

    @property
    def transfer_time_s(self) -> float:
        return self.timing.transfer_time_s

    @property
    def settle_time_s(self) -> float:
        return self.timing.settle_time_s

    @property
    def cycle_time_s(self) -> float:
        return self.timing.cycle_time_s

    @property
    def peak_deviation_m(self) -> float:
        return self.deviation["peak_during_move_m"]

    @property
    def worst_cycle_time_s(self) -> float | None:
        return None if self.worst_case is None else self.worst_case["cycle_time_s"]

    def ratios(self) -> dict:
        """The issue's figures: cycle time over the kinematic floor and over the best
        shaper (nominal), and the robust worst case over the best shaper's worst case."""
        base = self.baselines
        shapers = [b for b in base.entries if b.shaped_freq_hz]
        out = {
            "cycle_over_kinematic_floor": self.cycle_time_s / base.kinematic_floor_s,
            "cycle_over_floor_on_grid": self.cycle_time_s / (base.floor_steps * self.dt_s),
        }
        if shapers:
            best = min(shapers, key=lambda b: b.cycle_time_s)
            out["cycle_over_best_shaper"] = self.cycle_time_s / best.cycle_time_s
            out["best_shaper"] = best.name
            if self.worst_case is not None:
                worst = min(shapers, key=lambda b: b.worst_cycle_time_s)
                out["worst_over_best_shaper_worst"] = (
                    self.worst_cycle_time_s / worst.worst_cycle_time_s
                )
                out["best_shaper_worst_case"] = worst.name
        return out

    def report(self) -> dict:
        """Everything as JSON-ready data (the content of report.json)."""
        model = self.model
        return {
            "units": "SI (m, s, m/s, m/s^2, m/s^3)",
            "model": {
                "n_modes": model.n_modes,
                "n_points": model.n_points,
                "freq_hz_range": [float(np.min(model.freq_hz)), float(np.max(model.freq_hz))],
                "source": dict(model.meta).get("source"),
            },
            "distance_m": self.distance_m.tolist(),
            "dt_s": self.dt_s,
            "threshold_m": self.threshold_m,
            "limits": self.limits.as_dict(),
            "method": self.method,
            "solver": self.solver,
            "robust": None if self.robust is None else self.robust.as_dict(),
            "clearance_m": self.clearance_m,
            "frame": "model" if self.cell is None or self.cell.cell is None else "cell",
            "cell": None
            if self.cell is None or self.cell.cell is None
            else self.cell.cell.describe(),
            "constraints": self.constraints,
            "n_steps": self.n_steps,
            "transfer_time_s": self.transfer_time_s,
            "settle_time_s": self.settle_time_s,
            "cycle_time_s": self.cycle_time_s,
            "worst_case": self.worst_case,
            "deviation": self.deviation,
            "ratios": self.ratios(),
            "constraint_check": self.constraint_check.as_dict(),
            "baselines": self.baselines.as_dict(),
            "solver_stats": self.solver_stats,
            "wall_time_s": self.wall_time_s,
        }

    def summary(self) -> str:
        """A few lines for the terminal."""
        lines = [
            f"optimised ({self.method}, {self.solver}): transfer {self.transfer_time_s:.3f} s, "
            f"cycle {self.cycle_time_s:.3f} s (exact), {self.wall_time_s:.1f} s wall",
        ]
        if self.worst_case is not None:
            lines.append(f"  worst case over the robust grid: {self.worst_cycle_time_s:.3f} s")
        peak = self.deviation["peak_during_move_m"]
        clear = "" if self.clearance_m is None else f" (clearance {self.clearance_m * 1e3:g} mm)"
        lines.append(f"  peak deviation during the move: {peak * 1e3:.3f} mm{clear}")
        for c in self.constraints:
            lines.append("  " + constraint_line(c))
        lines.append(f"  kinematic floor (ruckig): {self.baselines.kinematic_floor_s:.3f} s")
        for b in self.baselines.entries:
            worst = "" if b.worst_cycle_time_s is None else f", worst {b.worst_cycle_time_s:.3f} s"
            bad = "" if b.constraints_ok else " (breaks a cell constraint)"
            lines.append(f"  {b.name:22s} cycle {b.cycle_time_s:.3f} s{worst}{bad}")
        for note in self.solver_stats.get("notes", []):
            lines.append(f"  note: {note}")
        lines.append(f"  limits: {self.constraint_check.summary()}")
        return "\n".join(lines)

    def save(self, directory: str | os.PathLike) -> list[Path]:
        """Write trajectory.csv, report.json and the plots into ``directory`` (module
        docstring); every file atomically. Returns the paths written."""
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        written = [out / "trajectory.csv", out / "report.json", out / "profiles.png"]
        write_trajectory_csv(written[0], self.acc, self.dt_s)
        write_text_atomic(written[1], json.dumps(self.report(), indent=2))
        plot_profiles(written[2], self.acc, self.dt_s, self.limits)
        written += self._plot_deviation(out / "deviation.png")
        if self.constraints:
            written.append(out / "constraints.png")
            self._plot_constraints(written[-1])
        if self.worst_case is not None:
            written.append(out / "robust.png")
            series = {"optimised": self.worst_case["grid"]}
            for b in self.baselines.entries:
                if b.worst_grid is not None:
                    series[b.name] = b.worst_grid
            plot_robust(written[-1], series, "exact cycle time across the uncertainty range")
        return written

    def _plot_constraints(self, path: Path) -> None:
        moves = {"optimised": self.acc}
        for b in self.baselines.entries:
            moves[b.name] = b.acc
        until = 1.15 * max(self.cycle_time_s, *(b.cycle_time_s for b in self.baselines.entries))
        curves: dict[str, dict] = {}
        for label, acc in moves.items():
            t, _ = deviation_curve(self.model, acc, self.dt_s, until, SUBSTEPS)
            for name, values in self.cell.curves(acc, self.dt_s, t).items():
                curves.setdefault(name, {})[label] = (t, values)
        limits = {c["name"]: c["limit"] for c in self.constraints}
        plot_constraints(path, curves, limits)

    def _plot_deviation(self, path: Path) -> list[Path]:
        moves = {"optimised": (self.acc, self.cycle_time_s)}
        for b in self.baselines.entries:
            moves[b.name] = (b.acc, b.cycle_time_s)
        until = 1.15 * max(c for _, c in moves.values()) + self.dt_s
        curves = {}
        for label, (acc, cycle) in moves.items():
            t, d = deviation_curve(self.model, acc, self.dt_s, until, SUBSTEPS)
            curves[label] = (t, d, cycle)
        plot_deviations(path, curves, self.threshold_m, "Deviation: optimised move vs baselines")
        written = [path]
        if self.worst_case is not None:
            scale, zeta = self.worst_case["freq_scale"], self.worst_case["zeta"]
            worst_model = perturbed(self.model, scale, zeta)
            t, d = deviation_curve(worst_model, self.acc, self.dt_s, until, SUBSTEPS)
            curves = {
                f"optimised, worst case (f x{scale:.3f}, zeta {zeta})": (
                    t,
                    d,
                    self.worst_cycle_time_s,
                )
            }
            written.append(path.with_name("deviation_worst_case.png"))
            plot_deviations(
                written[-1], curves, self.threshold_m, "Optimised move at its worst case"
            )
        return written
