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
from optim.options import RobustSpec
from optim.result_files import ANIMATION_DIR as ANIMATION_DIR  # their home: the light names
from optim.result_files import RESULT_FILES as RESULT_FILES
from optim.result_files import RESULT_KIND as RESULT_KIND
from optim.result_report import Reported
from optim.robust import perturbed
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
class OptimizationResult(Reported):
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
