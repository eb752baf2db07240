"""Baselines of a move that turns the part (optim.turn), each with its exact cycle time
(jaxflex.response.turning_settle) and the bound on the terms the turning engine neglects.

* "ruckig + free decay": ruckig's time-optimal motion of every axis, the angle as a fourth
  synchronised axis: the translation and the turn both stretched by ruckig to the slower
  one's duration T (ruckig's time synchronisation), on the grid (optim.ruckig_move's L1 fit,
  the angular limits met exactly); its length is the kinematic floor of the turning moves,
  and the search starts there;
* input shaping of every axis, the angle included: each shaper of optim.shapers.SHAPERS for
  the dominant modes, convolved with the synchronised motion of every axis, on the grid;
  the number of shaped modes with the shortest cycle is kept.

Dominant modes are ranked by their share of the synchronised ruckig move's residual
vibration, max_p |phi_i(p)| R_i (R_i the amplitude of mode i's free decay from the end
state): a turn loads modes that the translation's quasi-static deflection does not rank.
"""

from __future__ import annotations

import numpy as np

from jaxflex.errors import InputError
from jaxflex.model import ModalModel
from jaxflex.response import Move, amplitudes, as_move
from jaxflex.runtime import progress_bar
from optim.baselines import Baseline, BaselineSet, mode_trains, via_baselines
from optim.kinematics import clean_distance
from optim.limits import Limits
from optim.request import Request
from optim.robust import perturbed
from optim.ruckig_move import (
    MAX_EXTRA_STEPS,
    fit_to_grid,
    grid_steps,
    shaped_grid_move,
    time_optimal_move,
)
from optim.search import pad_to
from optim.shapers import SHAPERS, Shaper
from optim.turn import TurnSpec

SHAPED_SCHEDULES = 2  # the search's shaped turn schedules: those of the best 2 baselines


def _evaluate(model, request: Request, name, acc, alpha, freqs) -> Baseline:
    """The baseline ``name`` with its exact timing and, in robust mode, its worst case."""
    turn, threshold_m = request.turn, request.threshold_m
    move = as_move(acc, request.dt_s)  # checked once, for every certificate below
    timing, response = turn.timing(model, alpha, move, threshold_m)
    entry = Baseline(
        name,
        move,
        timing,
        freqs,
        angular_acc=alpha,
        neglected_bound_m=response.neglected_bound_m,
    )
    if request.robust is not None:
        entry.worst_cycle_time_s, entry.worst_case, entry.worst_grid = turn_worst_case(
            model, turn, move, alpha, threshold_m, request.robust.grid()
        )
    return entry


def turn_worst_case(
    model: ModalModel, turn: TurnSpec, move: Move, alpha, threshold_m: float, grid
) -> tuple[float, dict, list[dict]]:
    """The largest exact cycle time (jaxflex.response.turning_settle) of the turning move
    (the translation ``move``, a Move, with the turn ``alpha`` rad/s^2 at its step) over the
    (frequency scale, zeta) points of ``grid``: (worst, where, every point), as
    optim.baselines.worst_case of a straight move."""
    points = []
    move = as_move(move, name="move")  # checked once (a Move passes) for the whole grid
    for scale, zeta in grid:
        timing = turn.timing(perturbed(model, scale, zeta), alpha, move, threshold_m)[0]
        points.append({"freq_scale": scale, "zeta": zeta, "cycle_time_s": timing.cycle_time_s})
    worst = max(points, key=lambda p: p["cycle_time_s"])
    where = {"freq_scale": worst["freq_scale"], "zeta": worst["zeta"]}
    return float(worst["cycle_time_s"]), where, points


def synchronised_floor(
    distance: np.ndarray, turn: TurnSpec, limits: Limits, dt_s: float, max_steps: int
) -> tuple[np.ndarray, np.ndarray, float]:
    """(translation samples (n+1, 3), angular acceleration (n+1,), T s): the fewest steps
    n >= ceil(T / dt) at which both, stretched by ruckig to n dt, have grid versions."""
    duration = max(time_optimal_move(distance, limits).duration_s, turn.fastest_s())
    start = grid_steps(duration, dt_s)
    for n_steps in range(start, min(max_steps, start + MAX_EXTRA_STEPS) + 1):
        stretched = time_optimal_move(distance, limits, minimum_duration_s=n_steps * dt_s)
        reference = stretched.acceleration(dt_s * np.arange(n_steps + 1))
        acc = fit_to_grid(reference, dt_s, distance, limits)
        alpha = turn.stretched(n_steps, dt_s)
        if acc is not None and alpha is not None:
            return acc, alpha, duration
    raise InputError(
        f"distance_m / rotate: the move and the turn need at least {duration:.3f} s at these "
        f"limits (time-optimal jerk-limited motion), more than the {max_steps} steps of "
        f"{dt_s:g} s allowed; raise max_duration_s or the limits"
    )


def _shaped_turn(turn: TurnSpec, train, duration_s: float, dt_s: float, max_steps: int):
    """The turn stretched to ``duration_s`` and convolved with ``train`` on the grid
    ((n+1,) rad/s^2; zeros for no turn; None if no grid version exists)."""
    if turn.angle_rad == 0.0:
        return np.zeros(grid_steps(duration_s + train.duration_s, dt_s) + 1)
    motion = time_optimal_move(turn.angle_move, turn.limits, minimum_duration_s=duration_s)
    acc = shaped_grid_move(motion, train, turn.angle_move, turn.limits, dt_s, max_steps=max_steps)
    return None if acc is None else acc[:, 0]


def turn_baselines(
    request: Request, model: ModalModel, distance_m, max_steps: int
) -> tuple[BaselineSet, list[Shaper]]:
    """Every baseline of the turning move of ``request`` (its turn, limits, step, threshold,
    number of shaped modes and progress) for ``model`` over ``distance_m`` within
    ``max_steps`` (module docstring; ``kinematic_floor_s`` is the synchronised continuous
    duration T) and the shapers of the best SHAPED_SCHEDULES shaped baselines, best first
    (the search's shaped turn schedules, optim.turn.TurnSchedule)."""
    turn, limits, dt_s = request.turn, request.limits, request.dt_s
    max_shaped_modes = request.search.max_shaped_modes
    distance = clean_distance(distance_m)
    floor_acc, floor_alpha, duration = synchronised_floor(distance, turn, limits, dt_s, max_steps)
    floor = _evaluate(model, request, "ruckig + free decay", floor_acc, floor_alpha, [])
    entries = [floor]
    end = turn.response(model, floor_alpha, floor.move).end_state
    share = np.asarray(model.shape_norms).max(axis=0) * amplitudes(model, end)
    order = np.argsort(-share, kind="stable")[:max_shaped_modes]
    freq, omega, zeta = (np.asarray(v) for v in (model.freq_hz, model.omega_rad_s, model.zeta))
    stretched = time_optimal_move(distance, limits, minimum_duration_s=duration)
    skipped: dict[str, str] = {}
    trains: dict[str, Shaper] = {}
    bar = progress_bar(
        len(SHAPERS) * len(order), "turning baselines", request.search.progress, unit="move"
    )
    for kind in SHAPERS:
        best: Baseline | None = None
        for count, modes, train in mode_trains(kind, order, omega, zeta, skipped, bar):
            if best is not None and duration + train.duration_s >= best.score():
                continue  # the move alone is longer than the best cycle so far
            if grid_steps(duration + train.duration_s, dt_s) > max_steps:
                skipped.setdefault(kind, f"{kind} x{count} needs more than {max_steps} steps")
                break
            acc = shaped_grid_move(stretched, train, distance, limits, dt_s, max_steps=max_steps)
            alpha = _shaped_turn(turn, train, duration, dt_s, max_steps)
            if acc is None or alpha is None:
                continue
            n_steps = max(acc.shape[0], alpha.size) - 1
            acc, alpha = pad_to(acc, n_steps), np.pad(alpha, (0, n_steps + 1 - alpha.size))
            freqs = [float(freq[i]) for i in modes]
            entry = _evaluate(model, request, f"{kind} x{count}", acc, alpha, freqs)
            if best is None or entry.score() < best.score():
                best, trains[kind] = entry, train
        if best is not None:
            count = len(best.shaped_freq_hz)
            best.name = f"{kind} ({count} mode{'s' if count > 1 else ''})"
            trains[best.name] = trains.pop(kind)
            entries.append(best)
    bar.close()
    shaped = sorted(entries[1:], key=Baseline.score)[:SHAPED_SCHEDULES]
    return BaselineSet(duration, floor_acc, entries, skipped), [trains[e.name] for e in shaped]


def turn_via_baselines(
    request: Request, model: ModalModel, distance_m, via_offsets, max_steps: int
) -> tuple[BaselineSet, list[float]]:
    """The baseline of a turning move along a cell's via points: ruckig through the via
    points, stopping at each (optim.baselines.via_baselines), with the turn stretched by
    ruckig over the whole path on the grid (padded with rest where the turn alone takes
    longer), plus free decay; and the fractions of its steps at which it passes each via
    point (the search's via rows). The kinematic floor is the longer of the path's and the
    turn's."""
    turn, dt_s = request.turn, request.dt_s
    moves, fractions = via_baselines(
        model, distance_m, via_offsets, request.limits, dt_s, request.threshold_m,
        max_steps=max_steps,
    )  # fmt: skip
    path_steps = moves.entries[0].acc.shape[0] - 1
    start = max(path_steps, grid_steps(turn.fastest_s(), dt_s))
    for n_steps in range(start, min(max_steps, start + MAX_EXTRA_STEPS) + 1):
        alpha = turn.stretched(n_steps, dt_s)
        if alpha is not None:
            break
    else:
        raise InputError(
            f"rotate: the turn does not fit in {max_steps} steps of {dt_s:g} s along the via "
            "points; raise max_duration_s or the angular limits"
        )
    acc = pad_to(moves.entries[0].acc, n_steps)
    entry = _evaluate(model, request, "ruckig via points + turn + free decay", acc, alpha, [])
    floor_steps = max(moves.floor_acc.shape[0] - 1, grid_steps(turn.fastest_s(), dt_s))
    floor_s = max(moves.kinematic_floor_s, turn.fastest_s())
    scale = path_steps / n_steps  # the via points' samples stay where the path passes them
    return (
        BaselineSet(floor_s, pad_to(moves.floor_acc, floor_steps), [entry]),
        [f * scale for f in fractions],
    )
