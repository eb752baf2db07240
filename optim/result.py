"""The result of an optimisation: samples, exact timing, checks, statistics, baselines.

``OptimizationResult.save(directory)`` writes one set of files (jaxflex._fileset: each file
atomically, then ``manifest.json`` with their hashes; readers such as ``jaxflex export``
accept the files only as that set):

* ``trajectory.csv`` — t, a, v, x per axis (jaxflex._trajectory_io format, SI units);
* ``report.json`` — inputs, exact times, ratios to the baselines, the constraint check,
  solver statistics, the robust worst case (see :meth:`OptimizationResult.report`);
* ``profiles.png`` — position, velocity, acceleration, jerk with the limits;
* ``deviation.png`` — deviation against time, optimum and baselines, with the threshold;
* ``robust.png`` and ``deviation_worst_case.png`` (robust mode) — cycle time across the
  uncertainty range for the optimum and the baselines; the optimum's deviation at its worst
  case;
* ``turn.png`` (moves that turn the part, optim.turn) — the angle and angular rate of the
  optimum and the baselines; trajectory.csv then also holds the turn's angle, rate and
  angular acceleration, the report the turn and the bound on the neglected terms;
* ``constraints.png`` (with cell constraints) — the largest cup utilisation, the largest von
  Mises stress and the smallest distance to the obstacles against time, with the limits.
"""

from __future__ import annotations

import contextlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from jaxflex.files import MANIFEST, SetWriter, write_trajectory_csv, writing
from jaxflex.model import ModalModel
from jaxflex.response import Move, SettleReport, as_move, deviation_curve, integrate
from optim.baselines import BaselineSet
from optim.limits import ConstraintCheck, Limits
from optim.result_files import ANIMATION_DIR as ANIMATION_DIR  # their home: the light names
from optim.result_files import RESULT_FILES as RESULT_FILES
from optim.result_files import RESULT_KIND as RESULT_KIND
from optim.robust import RobustSpec, perturbed
from optim.turn_clearance import turning_move_deviation

SUBSTEPS = 8  # deviation curves in reports and plots: exact samples every dt / 8
PLOT_AFTER = 20_000  # plots: at most this many samples of the settling (a long baseline's)


def remove_animation(directory: Path) -> None:
    """Remove the animation set (optim.animate: ``animation/`` with its manifest) of an
    earlier result in ``directory``: it is not this result's."""
    folder = directory / ANIMATION_DIR
    manifest = folder / MANIFEST
    if not manifest.is_file():
        return
    try:
        names = json.loads(manifest.read_text(encoding="utf-8"))["files"]
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError):
        names = {}
    manifest.unlink()
    for name in names:
        (folder / Path(str(name)).name).unlink(missing_ok=True)
    with contextlib.suppress(OSError):
        folder.rmdir()


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
    error = ""
    if c.get("discretisation_error") is not None:  # the FE's estimate (fem.discretisation)
        high = c["peak_with_discretisation"]
        error = (
            f"; FE discretisation error +-{100 * c['discretisation_error']:.2g} %: up to "
            f"{high * scale:.3g}{unit} on the real part"
            + (", above the limit" if high > c["limit"] else "")
        )
    return (
        f"{c['name']}: {c['peak'] * scale:.3g}{unit} (limit {c['limit'] * scale:.3g}{unit}, "
        f"utilisation {c['utilisation']:.1%}{error}) {when}, {what} {c['item']}"
    )


def deviation_summary(model: ModalModel, move: Move) -> dict:
    """Peak deviation during the Move (exact samples every dt_s / 8) and at the stop, m."""
    n, dt_s = move.n_steps, move.dt_s
    t, d = deviation_curve(model, move, n * dt_s, SUBSTEPS)
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
    threshold_m: float
    limits: Limits
    method: str
    solver: str
    robust: RobustSpec | None
    move: Move  # the samples (n+1, 3) m/s^2 and their step, s
    timing: SettleReport  # exact, nominal model
    deviation: dict
    constraint_check: ConstraintCheck
    solver_stats: dict
    wall_time_s: float
    baselines: BaselineSet
    worst_case: dict | None = None  # robust mode: worst exact cycle over the check grid
    clearance_m: float | None = None  # limit on the deviation during the move, if any
    source: str = "optimised"  # "optimised", "search" or a baseline's name (optim.choice)
    warnings: list[dict] = field(default_factory=list)  # optim.advice: {"kind", "message"}
    constraints: list[dict] = field(default_factory=list)  # the cell's, certified
    cell: Any = None  # optim.cell_setup.CellSetup (posed model, via points, families)
    turn: Any = None  # optim.turn.TurnSpec of a move that turns the part
    angular_acc: np.ndarray | None = None  # (n+1,) rad/s^2: the turn's schedule
    inputs: dict = field(default_factory=dict)  # the input files, {"model": {path, sha256}}
    _traces: list = field(default_factory=list, repr=False, compare=False)  # _responses()

    @property
    def acc(self) -> np.ndarray:
        """The move's samples, (n+1, 3) m/s^2."""
        return self.move.acc

    @property
    def dt_s(self) -> float:
        """The move's step, s."""
        return self.move.dt_s

    @property
    def n_steps(self) -> int:
        return self.move.n_steps

    @property
    def vel(self) -> np.ndarray:
        return integrate(self.move)[0]

    @property
    def pos(self) -> np.ndarray:
        return integrate(self.move)[1]

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

    @property
    def objective_s(self) -> float:
        """What was minimised: the worst case over the robust grid, else the cycle time."""
        return self.cycle_time_s if self.worst_case is None else self.worst_cycle_time_s

    def comparison(self) -> dict:
        """The answer against the best baseline that meets the cell's constraints and the
        clearance (``baseline_allowed``), by the same objective: its name, its objective and
        the saving (s, and relative to the baseline). Where no baseline does, against the
        fastest one, ``baseline_allowed`` False and ``breaks`` saying what it breaks."""
        allowed = self.baselines.best_allowed()
        best = allowed if allowed is not None else self.baselines.best()
        saving = best.score() - self.objective_s
        return {
            "objective": "cycle_time_s" if self.worst_case is None else "worst_cycle_time_s",
            "best_baseline": best.name,
            "best_baseline_s": best.score(),
            "saving_s": saving,
            "saving_rel": saving / best.score(),
            "baseline_allowed": allowed is not None,
            "breaks": best.broken(),
        }

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
            "inputs": self.inputs or None,
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
            "source": self.source,
            "notes": list(self.solver_stats.get("notes", [])),
            "warnings": self.warnings,
            "frame": "model" if self.cell is None or self.cell.cell is None else "cell",
            "cell": None
            if self.cell is None or self.cell.cell is None
            else self.cell.cell.describe(),
            "constraints": self.constraints,
            "turn": None if self.turn is None else self._turn_report(),
            "n_steps": self.n_steps,
            "transfer_time_s": self.transfer_time_s,
            "settle_time_s": self.settle_time_s,
            "cycle_time_s": self.cycle_time_s,
            "worst_case": self.worst_case,
            "comparison": self.comparison(),
            "deviation": self.deviation,
            "ratios": self.ratios(),
            "constraint_check": self.constraint_check.as_dict(),
            "baselines": self.baselines.as_dict(),
            "solver_stats": self.solver_stats,
            "wall_time_s": self.wall_time_s,
        }

    def _turn_report(self) -> dict:
        """The turn, its schedule's heuristic and the neglected terms' bound (optim.turn)."""
        return {
            "schedule": "fixed per move length: ruckig's turn stretched to the move, or shaped "
            "like the best shaped baselines and stretched (optim.turn)",
            **self.turn.as_dict(),  # a turn through via orientations says its own schedule
            "neglected_bound_m": self.deviation["neglected_bound_m"],
            "angular_acc_rad_s2": self.angular_acc.tolist(),
        }

    def _turn_line(self) -> str:
        spec = self.turn.as_dict()
        axis = ", ".join(f"{v:g}" for v in spec["axis"])
        bound = self.deviation["neglected_bound_m"]
        through = "".join(  # a turn through via orientations (optim.turn_via)
            f"{' then' if i else ' through the via orientations:'} {s['angle_deg']:.4g} deg "
            f"about ({', '.join(f'{v:.3g}' for v in s['axis'])})"
            for i, s in enumerate(spec.get("via_turns", ()))
        )
        return (
            f"  turn: {spec['angle_deg']:g} deg about ({axis}){through} within "
            f"{spec['rate_rad_s']:g} "
            f"rad/s, {spec['acc_rad_s2']:g} rad/s^2, {spec['jerk_rad_s3']:g} rad/s^3; the "
            f"neglected gyroscopic and spin-softening terms change the deviation by at most "
            f"{bound * 1e3:.3g} mm"
        )

    def summary(self) -> str:
        """The answer first (ruckig-style: one line), then the details, for the terminal."""
        lines = [self.headline(), f"  {self._timeline()}"]
        if self.worst_case is not None:
            grid = self.worst_case["grid"]
            lines.append(
                f"  nominal model: cycle {self.cycle_time_s:.3f} s; worst over the "
                f"{len(grid)} models of the robust grid at f x{self.worst_case['freq_scale']:.3g}"
                + ("" if self.worst_case["zeta"] is None else f", zeta {self.worst_case['zeta']:g}")
            )
        peak = self.deviation["peak_during_move_m"]
        clear = "" if self.clearance_m is None else f" (clearance {self.clearance_m * 1e3:g} mm)"
        lines.append(f"  peak deviation during the move: {peak * 1e3:.3f} mm{clear}")
        if self.turn is not None:
            lines.append(self._turn_line())
        for c in self.constraints:
            lines.append("  " + constraint_line(c))
        base = self.baselines
        lines.append(
            f"  kinematic floor (ruckig): {base.kinematic_floor_s:.3f} s, "
            f"{base.floor_steps} steps on the {self.dt_s * 1e3:g} ms grid"
        )
        robust = self.worst_case is not None
        lines.append("  baselines:" + " " * 16 + "cycle" + ("      worst" if robust else ""))
        for b in base.entries:
            worst = f"    {b.worst_cycle_time_s:7.3f} s" if robust else ""
            bad = "" if b.allowed else f" (not allowed: breaks {b.broken()})"
            lines.append(f"    {b.name:24s}{b.cycle_time_s:7.3f} s{worst}{bad}")
        lines.append(f"  limits: {self.constraint_check.summary()}")
        lines += [f"  note: {note}" for note in self.solver_stats.get("notes", [])]
        lines.append(f"  ({self.method}, {self.solver}; {self.wall_time_s:.1f} s wall)")
        return "\n".join(lines)

    def headline(self) -> str:
        """One line with the answer: which move, its objective, and how it compares with
        the best baseline that meets the cell's constraints and the clearance (the same
        objective), or that no baseline does."""
        cmp = self.comparison()
        what = "worst case" if self.worst_case is not None else "cycle"
        base = f"{cmp['best_baseline']} {cmp['best_baseline_s']:.3f} s"
        if self.source not in ("optimised", "search"):
            return (
                f"best move: the baseline {self.source!r}, {what} {self.objective_s:.3f} s (no "
                "optimised move was shorter; see the note)"
            )
        head = f"best move: optimised, {what} {self.objective_s:.3f} s"
        if not cmp["baseline_allowed"]:
            return (
                f"{head}; no baseline meets the cell's constraints (the fastest, {base}, "
                f"breaks {cmp['breaks']})"
            )
        if cmp["saving_s"] > 0:
            return (
                f"{head}, {cmp['saving_s']:.3f} s ({100 * cmp['saving_rel']:.1f} %) shorter "
                f"than the best feasible baseline, {base}"
            )
        if cmp["saving_s"] < -1e-9:  # not a candidate (optim.stages.choose's notes)
            return (
                f"{head}; the best baseline, {base}, is shorter but breaks the clearance or "
                "a cell constraint"
            )
        floor = " = the kinematic floor, no move is shorter" if self._at_floor() else ""
        return f"{head}, as short as the best feasible baseline, {base}{floor}"

    def _at_floor(self) -> bool:
        return (
            self.n_steps == self.baselines.floor_steps and self.objective_s == self.transfer_time_s
        )

    def _timeline(self) -> str:
        """Transfer, settle and cycle time in words: the cycle is max(transfer, settle)."""
        transfer, settle = self.transfer_time_s, self.settle_time_s
        mm = f"{self.threshold_m * 1e3:g} mm"
        if settle == 0.0:
            after = f"the deviation never exceeds {mm}"
        else:
            when = "before" if settle <= transfer else f"{settle - transfer:.3f} s after"
            after = f"the deviation stays below {mm} from {settle:.3f} s on, {when} the stop"
        return f"transfer {transfer:.3f} s; {after}; cycle {self.cycle_time_s:.3f} s (exact)"

    def save(self, directory: str | os.PathLike, *, plots: bool = True) -> list[Path]:
        """Write trajectory.csv, report.json and (with ``plots``) the pictures into
        ``directory`` (module docstring) as one set (jaxflex._fileset): each file atomically,
        the manifest last, the files of an earlier run that this one does not write removed.
        Returns the paths written (manifest.json last)."""
        with writing(directory, RESULT_KIND, RESULT_FILES) as files:
            files.add(
                "trajectory.csv",
                lambda p: write_trajectory_csv(p, self.move, turn_acc_rad_s2=self.angular_acc),
            )
            files.add_text("report.json", json.dumps(self.report(), indent=2))
            if plots:
                self._plot(files)
        remove_animation(files.directory)
        return [files.directory / name for name in (*files.members, MANIFEST)]

    def _plot(self, files: SetWriter) -> None:
        """The pictures of the module docstring, added to ``files``."""
        from optim.plots import plot_profiles, plot_robust  # matplotlib: only when drawing

        files.add("profiles.png", lambda p: plot_profiles(p, self.move, self.limits))
        self._plot_deviation(files)
        if self.turn is not None:
            files.add("turn.png", self._plot_turn)
        if self.constraints:
            files.add("constraints.png", self._plot_constraints)
        if self.worst_case is not None:
            series = {self._label(): self.worst_case["grid"]}
            for b in self.baselines.entries:
                if b.worst_grid is not None:
                    series[b.name] = b.worst_grid
            title = "Exact cycle time across the uncertainty range"
            files.add("robust.png", lambda p: plot_robust(p, series, title))

    def _label(self) -> str:
        return "optimised" if self.source in ("optimised", "search") else f"{self.source} (chosen)"

    def _responses(self) -> list:
        """The deviation curves (optim.plots.Trace) of the returned move and of every other
        baseline (nominal model), each simulated once for every plot that shows it."""
        from optim.plots import Trace  # matplotlib: only when drawing

        if not self._traces:
            label = self._label()
            moves = [(label, self.acc, self.cycle_time_s, self.worst_cycle_time_s, "")]
            for b in self._other_baselines():
                moves.append((b.name, b.acc, b.cycle_time_s, b.worst_cycle_time_s, b.broken()))
            until = self._until()
            for label, acc, cycle, worst, breaks in moves:
                t, d = self._curve(acc, self._turn_of(label), until)
                self._traces.append(Trace(label, t, d, cycle, worst, acc, breaks))
        return self._traces

    def _other_baselines(self) -> list:
        """The baselines shown besides the returned move (not the returned one again)."""
        return [
            b
            for b in self.baselines.entries
            if not (self.source == b.name and np.array_equal(b.acc, self.acc))
        ]

    def _turn_of(self, label: str) -> np.ndarray | None:
        """The angular acceleration samples of the shown move ``label`` (None: straight)."""
        if self.turn is None:
            return None
        found = [b.angular_acc for b in self._other_baselines() if b.name == label]
        return found[0] if found else self.angular_acc

    def _curve(self, acc, angular_acc, until: float) -> tuple[np.ndarray, np.ndarray]:
        """Deviation against time up to ``until`` s: exact samples every dt / SUBSTEPS for a
        straight move; for a turning one every dt / 8 during the move (optim.turn_clearance)
        and at the samples after it (jaxflex._turning)."""
        move = as_move(acc, self.dt_s)
        if angular_acc is None:
            return deviation_curve(self.model, move, until, SUBSTEPS, PLOT_AFTER)
        t_end = move.n_steps * move.dt_s
        response = self.turn.response(self.model, angular_acc, move, max(0.0, until - t_end))
        t, d = turning_move_deviation(self.model, self.turn, angular_acc, move)
        after = response.t_s > t_end
        return np.concatenate([t, response.t_s[after]]), np.concatenate(
            [d, response.deviation_m[after]]
        )

    def _plot_turn(self, path: Path) -> None:
        from optim.plots import plot_turn  # matplotlib: only when drawing

        traces = self._responses()
        turns = [self._turn_of(trace.label) for trace in traces]
        plot_turn(path, traces, turns, self.dt_s)

    def _until(self) -> float:
        """The end of the plots' time axis (s): past every shown move's cycle."""
        cycles = [self.cycle_time_s, *(b.cycle_time_s for b in self.baselines.entries)]
        return 1.15 * max(cycles) + self.dt_s

    def _plot_constraints(self, path: Path) -> None:
        from optim.plots import constraint_times, plot_constraints  # matplotlib: when drawing

        certified = {c["name"]: (c["time_s"], c["peak"]) for c in self.constraints}
        peaks_s = [when for when, _ in certified.values()]
        curves: dict[str, dict] = {}
        for trace in self._responses():
            turn = self._turn_of(trace.label)
            move = as_move(trace.acc, self.dt_s)
            t = constraint_times(trace.t, peaks_s)
            for name, values in self.cell.curves(move, t, turn).items():
                curves.setdefault(name, {})[trace.label] = (t, values)
        limits = {c["name"]: c["limit"] for c in self.constraints}
        plot_constraints(path, curves, limits, self.cycle_time_s, certified)

    def _plot_deviation(self, files: SetWriter) -> None:
        from optim.plots import Trace, plot_comparison, plot_worst_case  # when drawing

        traces = self._responses()
        until = self._until()
        floor_s = self.baselines.kinematic_floor_s
        title = "Deviation of the optimised move and the baselines (nominal model)"
        files.add(
            "deviation.png",
            lambda p: plot_comparison(p, traces, self.threshold_m, floor_s, title),
        )
        if self.worst_case is not None:
            scale, zeta = self.worst_case["freq_scale"], self.worst_case["zeta"]
            worst_model = perturbed(self.model, scale, zeta)
            t, d = deviation_curve(worst_model, self.move, until, SUBSTEPS, PLOT_AFTER)
            label = f"{self._label()} at f x{scale:g}" + (
                "" if zeta is None else f", zeta {zeta:g}"
            )
            worst = Trace(label, t, d, self.worst_cycle_time_s)
            files.add(
                "deviation_worst_case.png",
                lambda p: plot_worst_case(p, worst, self.threshold_m),
            )
