"""Orientations at via points: the part turns from its start through the orientation of each
oriented via point of the cell (``rotation_deg``, optim.cell_file) to the end orientation
(the turn of ``--rotate``, optim.turn.TurnSpec), one fixed-axis turn per segment, each
segment's turn synchronised with the via passage of the translation.

**The path.** In the posed model's frame (the cell's axes at the start,
jaxflex.geometry.Cell.posed) a via point's orientation is R_i = R_via R_A^T (R_via the part's
axes there, R_A at A) and the end's is the turn's (TurnSpec.end_rotation). Each segment
goes from one orientation to the next by the shortest turn (the geodesic: the axis and angle
of R_i^T R_i+1, an axis fixed in the body, as jaxflex.response.orientation_path), from rest to
rest: the part's orientation comes to rest at every via orientation, at the sample where the
translation passes that via point.

**When.** The exact route passes via point j at a fixed fraction f_j of the move (its via
rows, optim.search.Problem.via_rows: sample k_j = round(f_j n), optim.kinematics.via_step);
the turn's segment boundaries are the same samples, so both are synchronised for every move
length n. The fractions are fixed before the search (:func:`synchronised_fractions`): each
translation segment at ruckig's time-optimal duration, those a turn segment spans stretched
together where the turn alone takes longer. The via times are not free variables (the LP's
via rows fix them per move length); choosing them is part of the heuristic.

**The schedule.** For n steps each segment is ruckig's time-optimal turn by its angle
stretched to its steps and put on the grid within the angular limits (TurnSpec.stretched):
the limits hold on every segment, and the angular rate and acceleration are 0 at the
boundaries. It is one number per sample, the angular acceleration about the current
segment's axis (optim.turn's form, so the trajectory file's turn columns are the angle
turned along the path), and :meth:`ViaTurn.path` integrates it segment by segment exactly
(jaxflex.response.fixed_axis_path): the jaxflex.response.PosePath the turning engine takes. Within
every step the axis is fixed, so the orientation between samples (jaxflex._turning_collision)
stays exact. For this fixed schedule the turning engine's end state, loads and positions are
affine in the translation samples (optim.turn, optim.turn_cell, optim.turn_clearance), so
the LP over the translation stays exact and every answer is certified by the turning engine
(jaxflex.response.turning_settle); the schedule itself (rest at each via orientation, the
fractions, the stretch) is the heuristic.

The schedule's length fixes its via samples: it is never padded with rest (the search, the
baseline and the result hand it with the translation of the same length). The baseline:
optim.turn_via_baselines.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, fields

import numpy as np

from jaxflex.errors import InputError
from jaxflex.response import (
    Move,
    PosePath,
    Turn,
    axis_angle,
    fixed_axis_path,
    integrate,
    joined_paths,
)
from optim.kinematics import clean_distance, via_step
from optim.limits import Limits
from optim.ruckig_move import time_optimal_move
from optim.turn import TurnSpec


def _segments(stops) -> list[tuple[np.ndarray, float]]:
    """(unit axis (3,) in the body, angle in [0, pi] rad) of the geodesic turn from the start
    (identity) to ``stops[0]`` and from each stop to the next ((S, 3, 3) body to world)."""
    out, current = [], np.eye(3)
    for goal in np.asarray(stops, dtype=np.float64):
        out.append(axis_angle(current.T @ goal))
        current = goal
    return out


@dataclass(frozen=True)
class ViaTurn(TurnSpec):
    """The turn of a TurnSpec (``axis``, ``angle_rad``: the end orientation; the angular
    limits, gravity and pivot) through via orientations (module docstring): ``stops``
    (S, 3, 3) the orientations (body to world, posed model's frame) at the oriented via
    points and at the end, the last one the turn's; ``oriented`` (S-1,) the indices of those
    via points among all of the cell's; ``via_fractions`` (V,) the fraction of the move at
    which every via point is passed; ``duration_s`` the synchronised continuous path's."""

    stops: tuple = ()
    oriented: tuple[int, ...] = ()
    via_fractions: tuple[float, ...] = ()
    duration_s: float = 0.0

    def segments(self) -> list[tuple[np.ndarray, float]]:
        """(axis (3,), angle rad) of each segment's geodesic turn, in order."""
        return _segments(self.stops)

    def _segment_turns(self) -> list[TurnSpec]:
        limits = (self.rate_rad_s, self.acc_rad_s2, self.jerk_rad_s3)
        frame = (self.gravity_m_s2, self.pivot_m)
        return [
            TurnSpec(tuple(float(v) for v in axis), angle, *limits, *frame)
            for axis, angle in self.segments()
        ]

    @property
    def turns(self) -> bool:
        return any(angle != 0.0 for _, angle in self.segments())

    def boundaries(self, n_steps: int) -> list[int]:
        """The samples where the segments start and end in an n-step move: 0, the oriented
        via points' (optim.kinematics.via_step, as the via rows), n."""
        inner = [via_step(self.via_fractions[i], n_steps) for i in self.oriented]
        return [0, *inner, n_steps]

    def fastest_s(self) -> float:
        """The turn alone, segment after segment, each time-optimal from rest to rest (s)."""
        return sum(turn.fastest_s() for turn in self._segment_turns())

    def stretched(self, n_steps: int, dt_s: float, train=None):
        """(n+1,) angular acceleration samples (rad/s^2) about each segment's axis: every
        segment's turn stretched by ruckig to its steps (with ``train``: shaped too), on the
        grid within the angular limits (optim.turn.TurnSpec.stretched), or None if a segment
        does not fit in its steps."""
        k = self.boundaries(n_steps)
        pieces: list[np.ndarray] = []
        for turn, (k0, k1) in zip(self._segment_turns(), itertools.pairwise(k), strict=True):
            if k1 <= k0:
                return None
            alpha = turn.stretched(k1 - k0, dt_s, train)
            if alpha is None:
                return None
            pieces.append(alpha if not pieces else alpha[1:])
        return np.concatenate(pieces)

    def path(self, angular_acc: np.ndarray, dt_s: float) -> PosePath:
        """The orientation path of the schedule ``angular_acc`` (n+1,) rad/s^2 (one of
        :meth:`stretched`): each segment about its axis from the orientation the previous
        one reached (jaxflex.response.fixed_axis_path, exact)."""
        alpha = np.asarray(angular_acc, dtype=np.float64).reshape(-1)
        axes = [axis for axis, _ in self.segments()]
        return segmented_path(axes, self.boundaries(alpha.size - 1), alpha, dt_s)

    def as_dict(self) -> dict:
        ends = [*(self.via_fractions[i] for i in self.oriented), 1.0]
        segments = [
            {"axis": axis.tolist(), "angle_deg": float(np.degrees(angle)), "ends_at_fraction": f}
            for (axis, angle), f in zip(self.segments(), ends, strict=True)
        ]
        return {
            **super().as_dict(),
            "schedule": "through the via orientations: per segment the geodesic turn from rest "
            "to rest, ruckig's turn stretched to the segment's steps, the segments ending "
            "where the move passes the via points (optim.turn_via)",
            "via_turns": segments,
            "via_fractions": list(self.via_fractions),
        }


def segmented_path(axes, boundaries, angular_acc: np.ndarray, dt_s: float) -> PosePath:
    """The orientation path of a turn through via orientations: segment i about ``axes[i]``
    (body components) over the samples ``boundaries[i]``..``boundaries[i+1]`` of the
    schedule ``angular_acc`` (n+1,) rad/s^2, from the orientation the previous segment
    reached (jaxflex.response.fixed_axis_path, exact)."""
    pieces, current = [], np.eye(3)
    for axis, (k0, k1) in zip(axes, itertools.pairwise(boundaries), strict=True):
        piece = fixed_axis_path(axis, angular_acc[k0 : k1 + 1], dt_s, start=current)
        pieces.append(piece)
        current = piece.rotation[-1]
    return joined_paths(pieces)


def reported_path(turn: dict, angular_acc: np.ndarray, dt_s: float) -> PosePath:
    """The orientation path of a turn through via orientations as a report states it
    (:meth:`ViaTurn.as_dict`: ``via_turns``, each segment's axis, angle and the fraction of
    the move where it ends) with its schedule ``angular_acc`` (n+1,) rad/s^2 (the trajectory
    file's turn column). InputError if a segment's samples do not turn it by its angle (the
    two files do not belong together)."""
    alpha = np.asarray(angular_acc, dtype=np.float64).reshape(-1)
    n_steps = alpha.size - 1
    segments = turn["via_turns"]
    inner = [via_step(float(s["ends_at_fraction"]), n_steps) for s in segments[:-1]]
    boundaries = [0, *inner, n_steps]
    path = segmented_path([s["axis"] for s in segments], boundaries, alpha, dt_s)
    pairs = itertools.pairwise(boundaries)
    for i, (segment, (k0, k1)) in enumerate(zip(segments, pairs, strict=True)):
        turned_deg = np.degrees(axis_angle(path.rotation[k0].T @ path.rotation[k1])[1])
        if abs(turned_deg - float(segment["angle_deg"])) > 1e-6:
            raise InputError(
                f"turn: segment {i} of the via orientations turns the part by {turned_deg:.9g} "
                f"deg in the turn columns, the report says {segment['angle_deg']} deg; they do "
                "not belong together"
            )
    return path


def reported_turn(spec, turn_acc: np.ndarray, move: Move, gravity_m_s2) -> Turn:
    """The turning move (jaxflex.response.Turn) of a result of `jaxflex optimize --rotate`:
    its translation ``move`` (trajectory.csv's, a Move) turned by report.json's ``turn``
    entry ``spec`` (axis, angle, pivot, gravity; ``via_turns`` for a turn through via
    orientations) with the turn column of its trajectory.csv ``turn_acc`` (n+1,) rad/s^2;
    gravity ``gravity_m_s2`` where the report states none. InputError where the two files do
    not belong together (the angle turned, the angular acceleration)."""
    if not isinstance(spec, dict) or "axis" not in spec:
        raise InputError(
            "--trajectory: a turning move needs the turn columns of trajectory.csv and the turn "
            "of report.json of the same `jaxflex optimize --rotate` run; report.json's turn "
            "(axis, pivot) missing"
        )
    reported = np.asarray(spec.get("angular_acc_rad_s2", turn_acc), dtype=np.float64)
    scale = 1e-9 * max(1.0, float(np.abs(turn_acc).max()))
    if reported.shape != turn_acc.shape or np.abs(reported - turn_acc).max() > scale:
        raise InputError(
            "--trajectory: the turn's angular acceleration in trajectory.csv and report.json "
            "differ; they do not belong together"
        )
    if "via_turns" in spec:  # through via orientations: one fixed-axis turn per segment
        try:
            path = reported_path(spec, turn_acc, move.dt_s)
        except (InputError, KeyError, TypeError, ValueError) as exc:
            raise InputError(f"--trajectory: report.json's via_turns: {exc}") from None
    else:
        path = fixed_axis_path(spec["axis"], turn_acc, move.dt_s)
        padded = np.zeros((len(turn_acc), 3))
        padded[:, 0] = turn_acc
        angle = float(np.degrees(integrate(padded, move.dt_s)[1][-1, 0]))  # exact, as the CSV's
        if "angle_deg" in spec and abs(angle - float(spec["angle_deg"])) > 1e-6:
            raise InputError(
                f"--trajectory: the turn columns turn the part by {angle:.9g} deg, report.json "
                f"says {spec['angle_deg']} deg; they do not belong together"
            )
    pivot, gravity = spec.get("pivot_m", (0.0, 0.0, 0.0)), spec.get("gravity_m_s2", gravity_m_s2)
    try:
        return Turn(path, move, pivot_m=pivot, gravity_m_s2=gravity)
    except InputError as exc:
        raise InputError(f"--trajectory: report.json's turn: {exc}") from None


def synchronised_fractions(
    distance_m, via_offsets, limits: Limits, oriented, turns_s
) -> tuple[tuple[float, ...], float]:
    """(the fraction of the move at which each via point ``via_offsets`` ((3,) m from the
    start) is passed, the path's duration s): each translation segment at ruckig's
    time-optimal duration within ``limits``, those between two oriented via points (indices
    ``oriented``; the start and the end) stretched together where the turn segment there
    (``turns_s``, its time-optimal duration) takes longer."""
    stops = [np.zeros(3), *(np.asarray(v, dtype=np.float64) for v in via_offsets)]
    stops.append(np.asarray(distance_m, dtype=np.float64))
    durations = []
    for i, (a, b) in enumerate(itertools.pairwise(stops)):
        if not np.any(np.abs(b - a) > 1e-12):
            raise InputError(f"via: point {i} and the next point of the path coincide")
        durations.append(time_optimal_move(clean_distance(b - a), limits).duration_s)
    durations = np.array(durations)
    bounds = [0, *(i + 1 for i in oriented), len(durations)]
    for (lo, hi), turn_s in zip(itertools.pairwise(bounds), turns_s, strict=True):
        span = durations[lo:hi].sum()
        if turn_s > span:
            durations[lo:hi] *= turn_s / span
    cumulative = np.cumsum(durations)
    total = float(cumulative[-1])
    return tuple(float(c / total) for c in cumulative[:-1]), total


def with_via_orientations(turn: TurnSpec | None, cell, limits: Limits) -> TurnSpec | None:
    """``turn`` (in the cell's coordinates, optim.request) through the orientations of the
    cell's via points that have one (a :class:`ViaTurn`), or ``turn`` itself if none has.
    InputError naming the field for a via orientation without a turn."""
    vias = tuple(getattr(cell, "via", ()))
    oriented = tuple(i for i, v in enumerate(vias) if v.rotation is not None)
    if not oriented:
        return turn
    if turn is None:
        raise InputError(
            f"cell.path.via[{oriented[0]}].rotation_deg: an orientation at a via point needs a "
            "turning move: rotate (--rotate AXIS ANGLE_DEG) gives the end orientation (angle 0: "
            "back to the start's) and --angular-limits the limits of every segment"
        )
    start = np.asarray(cell.rotation, dtype=np.float64)
    stops = [vias[i].rotation @ start.T for i in oriented] + [turn.end_rotation]
    base = {f.name: getattr(turn, f.name) for f in fields(TurnSpec)}
    stops_t = tuple(tuple(tuple(float(v) for v in row) for row in r) for r in stops)
    draft = ViaTurn(**base, stops=stops_t, oriented=oriented)
    turns_s = [t.fastest_s() for t in draft._segment_turns()]
    offsets = [offset for offset, _, _ in cell.via_offsets()]
    fractions, total = synchronised_fractions(cell.distance_m, offsets, limits, oriented, turns_s)
    return ViaTurn(
        **base, stops=stops_t, oriented=oriented, via_fractions=fractions, duration_s=total
    )
