"""Baselines every optimised move is compared against, each with its exact cycle time.

* the kinematic floor: ruckig's time-optimal jerk-limited motion; its grid version's length
  bounds every transfer time from below;
* "ruckig + free decay": that grid move, then waiting for the vibration to settle;
* input shaping of the time-optimal motion for the dominant modes with every shaper of
  optim.shapers.SHAPERS (ZV, ZVD, EI; several modes by convolving their shapers), with the
  number of shaped modes that gives the shortest cycle (the shortest worst-case cycle in
  robust mode).

Dominant modes are ranked by their quasi-static deflection along the move,
max_p |phi_i(p)| |Gamma_i . u| / omega_i^2 (u the unit direction of the move).

A path through via points (:func:`via_baselines`) has one baseline: ruckig's time-optimal
motion segment by segment, stopping at every via point (ruckig's community edition has no
intermediate waypoints), each segment on the grid as the kinematic floor is, then the free
decay. Its kinematic floor stays the straight move's: no path from A to B is faster.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from jaxflex.errors import InputError
from jaxflex.model import ModalModel
from jaxflex.response import Move, SettleReport, analyze_move, as_move
from jaxflex.runtime import progress_bar
from optim.budget import MAX_STEPS
from optim.defaults import MAX_SHAPED_MODES as MAX_SHAPED_MODES
from optim.kinematics import clean_distance
from optim.limits import Limits
from optim.options import RobustSpec
from optim.robust import perturbed
from optim.ruckig_move import (
    grid_steps,
    kinematic_floor_move,
    shaped_grid_move,
    time_optimal_move,
)
from optim.shapers import SHAPERS, convolve, shaper


def _broken_line(c: dict) -> str:
    """A cell constraint's certified value against its limit, short (optim.cell_rows)."""
    if "distance" in c["name"]:
        return f"{c['name']} {c['peak'] * 1e3:.3g} mm against {c['limit'] * 1e3:g} mm"
    scale, unit = (1e-6, " MPa") if "stress" in c["name"] else (1.0, "")
    return f"{c['name']} {c['peak'] * scale:.3g}{unit} against {c['limit'] * scale:.3g}{unit}"


@dataclass
class Baseline:
    """One baseline move (a checked Move: samples and step), its exact timing, and (robust
    mode) its worst case."""

    name: str
    move: Move
    timing: SettleReport
    shaped_freq_hz: list[float] = field(default_factory=list)
    worst_cycle_time_s: float | None = None
    worst_case: dict | None = None  # scenario of the worst case
    worst_grid: list[dict] | None = None  # cycle time at every point of the check grid
    constraints_ok: bool = True  # meets the cell's constraints (optim.cell_setup)
    constraints: list[dict] | None = None  # their certified values for this move
    clearance_ok: bool = True  # its deviation during the move within the clearance, if any
    angular_acc: np.ndarray | None = None  # (n+1,) rad/s^2: the turn with the move, if any
    neglected_bound_m: float | None = None  # turning moves: jaxflex._turning's bound

    @property
    def acc(self) -> np.ndarray:
        """The move's (n+1, 3) acceleration samples, m/s^2."""
        return self.move.acc

    @property
    def cycle_time_s(self) -> float:
        return self.timing.cycle_time_s

    def score(self) -> float:
        """What the baseline is ranked by: the worst case in robust mode, else nominal."""
        return self.cycle_time_s if self.worst_cycle_time_s is None else self.worst_cycle_time_s

    @property
    def allowed(self) -> bool:
        """Whether the move meets the cell's constraints and the clearance: a candidate."""
        return self.constraints_ok and self.clearance_ok

    def broken(self) -> str:
        """What the move breaks, in words ("" where it is allowed): each cell constraint over
        its limit with its certified value, the clearance."""
        if self.allowed:
            return ""
        parts = [_broken_line(c) for c in self.constraints or () if c["utilisation"] > 1]
        if not self.clearance_ok:
            parts.append("the clearance during the move")
        return "; ".join(parts) or "a cell constraint (within its certificate's tolerance)"

    def as_dict(self) -> dict:
        return {
            "name": self.name,
            "n_steps": self.move.n_steps,
            **self.timing.times(),
            "shaped_modes": len(self.shaped_freq_hz),
            "shaped_freq_hz": self.shaped_freq_hz,
            "worst_cycle_time_s": self.worst_cycle_time_s,
            "worst_case": self.worst_case,
            "constraints_ok": self.constraints_ok,
            "clearance_ok": self.clearance_ok,
            "constraints": self.constraints,
            **({} if self.angular_acc is None else {"neglected_bound_m": self.neglected_bound_m}),
        }


@dataclass
class BaselineSet:
    kinematic_floor_s: float  # continuous time-optimal (ruckig) duration
    floor_acc: np.ndarray  # its grid version: floor_steps = len - 1
    entries: list[Baseline]
    skipped: dict[str, str] = field(default_factory=dict)  # shaper kind -> why it is absent

    @property
    def floor_steps(self) -> int:
        return int(self.floor_acc.shape[0] - 1)

    def best(self) -> Baseline:
        """The entry with the shortest cycle (worst case in robust mode, else nominal)."""
        return min(self.entries, key=Baseline.score)

    def best_allowed(self) -> Baseline | None:
        """The shortest entry that meets the cell's constraints and the clearance (what an
        optimised move is compared with), or None where none does."""
        allowed = [b for b in self.entries if b.allowed]
        return min(allowed, key=Baseline.score) if allowed else None

    def as_dict(self) -> dict:
        return {
            "kinematic_floor_s": self.kinematic_floor_s,
            "floor_steps": self.floor_steps,
            "entries": [b.as_dict() for b in self.entries],
            "skipped": dict(self.skipped),
        }


def via_baselines(
    model: ModalModel,
    distance_m,
    via_offsets,
    limits: Limits,
    dt_s: float,
    threshold_m: float,
    *,
    robust: RobustSpec | None = None,
    max_steps: int = MAX_STEPS,
) -> tuple[BaselineSet, list[float]]:
    """The baseline of a path through the via points ``via_offsets`` ((3,) m from the start,
    in order) to ``distance_m`` (module docstring), and the fraction of its steps at which it
    passes each via point."""
    distance = clean_distance(distance_m)
    stops = [np.zeros(3), *(np.asarray(v, dtype=np.float64) for v in via_offsets), distance]
    pieces, fractions, steps = [], [], 0
    for i, (a, b) in enumerate(itertools.pairwise(stops)):
        if not np.any(np.abs(b - a) > 1e-12):
            raise InputError(f"via: point {i} and the next point of the path coincide")
        segment = kinematic_floor_move(b - a, limits, dt_s, max_steps).acc
        pieces.append(segment if not pieces else segment[1:])
        steps += segment.shape[0] - 1
        fractions.append(steps)
    move = as_move(np.concatenate(pieces), dt_s, at_rest=True)
    if move.n_steps > max_steps:
        raise InputError(
            f"distance_m: the path through the via points needs {move.duration_s:.3f} s "
            f"at these limits, more than the allowed {max_steps * dt_s:g} s (max_duration_s)"
        )
    entry = Baseline(
        "ruckig via points + free decay", move, analyze_move(model, move, threshold_m=threshold_m)
    )
    if robust is not None:
        entry.worst_cycle_time_s, entry.worst_case, entry.worst_grid = worst_case(
            model, move, threshold_m, robust.grid()
        )
    floor = kinematic_floor_move(distance, limits, dt_s, max_steps)
    continuous = time_optimal_move(distance, limits)
    return BaselineSet(continuous.duration_s, floor.acc, [entry]), [
        f / steps for f in fractions[:-1]
    ]


def dominant_modes(model: ModalModel, distance: np.ndarray) -> np.ndarray:
    """Mode indices, most important first (module docstring)."""
    unit = distance / np.linalg.norm(distance)
    omega = np.asarray(model.omega_rad_s)
    deflection = model.shape_norms.max(axis=0) * np.abs(np.asarray(model.gamma) @ unit) / omega**2
    return np.argsort(-deflection, kind="stable")


def worst_case(
    model: ModalModel, move: Move, threshold_m: float, grid
) -> tuple[float, dict, list[dict]]:
    """Largest exact cycle time of ``move`` over the (frequency scale, zeta) points of
    ``grid``: (worst, where, every point as {"freq_scale", "zeta", "cycle_time_s"})."""
    points = []
    move = as_move(move, at_rest=True)  # checked once (a Move passes) for the whole grid
    for scale, zeta in grid:
        timing = analyze_move(
            perturbed(model, scale, zeta), move, threshold_m=threshold_m, settle=False
        )
        points.append({"freq_scale": scale, "zeta": zeta, "cycle_time_s": timing.cycle_time_s})
    worst = max(points, key=lambda p: p["cycle_time_s"])
    where = {"freq_scale": worst["freq_scale"], "zeta": worst["zeta"]}
    return float(worst["cycle_time_s"]), where, points


def _selection_grid(robust: RobustSpec):
    """A coarse grid (5 frequency scales x the zeta end points) to choose shaped modes."""
    coarse = RobustSpec(
        robust.freq_scale, robust.zeta, min(robust.n_freq, 5), min(robust.n_zeta, 2)
    )
    return coarse.grid()


def mode_trains(kind: str, order, omega, zeta, skipped: dict[str, str], bar):
    """(count, modes, shaper train) of the shaper ``kind`` for the first 1, 2, ... modes of
    ``order`` (omega rad/s, zeta per mode), one step of ``bar`` each; stops where no such
    shaper exists (EI near zeta = 1), saying why in ``skipped``."""
    for count in range(1, len(order) + 1):
        bar.update(1)
        modes = order[:count]
        try:
            train = convolve(*(shaper(kind, omega[i], zeta[i]) for i in modes))
        except InputError as exc:
            skipped.setdefault(kind, str(exc))
            return
        yield count, modes, train


def baselines(
    model: ModalModel,
    distance_m,
    limits: Limits,
    dt_s: float,
    threshold_m: float,
    *,
    robust: RobustSpec | None = None,
    max_shaped_modes: int = MAX_SHAPED_MODES,
    max_steps: int = MAX_STEPS,
    progress: bool | None = False,
) -> BaselineSet:
    """Every baseline for the move ``distance_m`` (3,) m (module docstring). In robust mode
    each entry also carries its worst cycle time over ``robust``'s check grid."""
    distance = clean_distance(distance_m)
    floor = kinematic_floor_move(distance, limits, dt_s, max_steps)
    continuous = time_optimal_move(distance, limits)
    select_grid = None if robust is None else _selection_grid(robust)

    def timed(name, acc, freqs=None):
        move = as_move(acc, dt_s, at_rest=True)
        return Baseline(name, move, analyze_move(model, move, threshold_m=threshold_m), freqs or [])

    def evaluate(name, acc, freqs):
        entry = timed(name, acc, freqs)
        if select_grid is not None:
            entry.worst_cycle_time_s, entry.worst_case, _ = worst_case(
                model, entry.move, threshold_m, select_grid
            )
        return entry

    entries = [timed("ruckig + free decay", floor.acc)]
    order = dominant_modes(model, distance)[:max_shaped_modes]
    freq, omega, zeta = (
        np.asarray(model.freq_hz),
        np.asarray(model.omega_rad_s),
        np.asarray(model.zeta),
    )
    kinds = list(SHAPERS)
    skipped: dict[str, str] = {}
    bar = progress_bar(len(kinds) * len(order), "baselines", progress, unit="move")
    for kind in kinds:
        best: Baseline | None = None
        for count, modes, train in mode_trains(kind, order, omega, zeta, skipped, bar):
            if best is not None and continuous.duration_s + train.duration_s >= best.score():
                continue  # the move alone is longer than the best cycle so far
            if grid_steps(continuous.duration_s + train.duration_s, dt_s) > max_steps:
                skipped.setdefault(
                    kind,
                    f"{kind} x{count} lasts {continuous.duration_s + train.duration_s:.4g} s, "
                    f"more than the {max_steps} steps allowed",
                )
                break  # more modes only make it longer
            acc = shaped_grid_move(continuous, train, distance, limits, dt_s, max_steps=max_steps)
            if acc is None:
                continue
            entry = evaluate(f"{kind} x{count}", acc, [float(freq[i]) for i in modes])
            if best is None or entry.score() < best.score():
                best = entry
        if best is not None:
            count = len(best.shaped_freq_hz)
            best.name = f"{kind} ({count} mode{'s' if count > 1 else ''})"
            entries.append(best)
    bar.close()
    if robust is not None:  # the final figures over the full check grid
        for entry in entries:
            entry.worst_cycle_time_s, entry.worst_case, entry.worst_grid = worst_case(
                model, entry.move, threshold_m, robust.grid()
            )
    return BaselineSet(continuous.duration_s, floor.acc, entries, skipped)
