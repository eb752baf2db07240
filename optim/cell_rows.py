"""The cell's constraints as LP rows: distance to obstacles, cup utilisation, stress.

Each family checks a move, proposes rows where it is violated, and certifies:

* **loads** (cup utilisation u_c <= 1, von Mises stress <= limit): the outputs are
  y(t) = Q q + V q' + A a + offset (jaxflex.outputs), linear in the samples at any time
  (jaxflex.engine.state_maps_at); the functional is convex and positively homogeneous, so the
  cut g at a violating (time, item) (jaxflex.loads: f(y') >= g . y', equality at the peak)
  is a valid row g . y(t) <= limit: every feasible move satisfies it, and repeated at the
  worst peaks these rows converge to the exact constraint (as the residual rows do: convex
  and exact at the rows' times);
* **distance** (every monitored point at least ``margin`` from every obstacle): the point's
  position p(t) = x + g + s(t) + u(t) is linear in the samples; at a violating (time, point)
  the plane through the obstacle's closest point c with normal n = (p - c) / |p - c| (out of
  the obstacle, which lies behind it: every obstacle piece is convex) gives the row
  n . (p(t) - c) >= margin. It implies the distance, but it is a *restriction* chosen at the
  LP's current answer: a move that passes the obstacle on another side is cut off. The
  distance constraint is not convex (staying out of a box is not), so this part is a
  heuristic (sequential convex programming); via points choose the side.

Rows are checked on a grid (every dt / 8 during the move, every 1/16 of the shortest period
after it for two periods of the longest); a clean move is then certified with the exact
searches of jaxflex.peaks and jaxflex.collision over the move and the whole settling, and a
failure adds a row at the certified worst point. Rows keep ROW_MARGIN of the limit in
reserve, so that peaks between grid samples rarely fail the certification.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from jaxflex.geometry import (
    Clearance,
    block_lower_bounds,
    displacement_coordinates,
    distances,
    gravity_offset,
    min_distance,
    part_blocks,
    positions_at,
)
from jaxflex.response import (
    CupUtilisation,
    Move,
    Peak,
    VonMises,
    acceleration_at,
    item_bounds,
    kinematics_at,
    output_peak,
    outputs_at,
    position_weights,
    response_shapes,
    state_maps_at,
    states_at,
)

ROW_MARGIN = 1e-3
SCAN_RTOL = 1e-7  # a row's own limit is met up to the LP's feasibility tolerance (1e-9)
BOUND_RTOL = 1e-12  # the certified searches stop refining at the limit: round-off of it
ITEM_BLOCK = 2048
SUBSTEPS = 8
TAIL_PERIODS = 2.0
PEAKS_PER_ROUND = 20  # violated local maxima in time
ITEMS_PER_PEAK = 8  # rows at each: the worst items (points, cups) above the limit
ROWS_PER_ROUND = 240  # loads: rows at the worst violated (time, item) samples
PAIR_CHUNK = 100_000  # (time, point) pairs per evaluation of the distance
CERTIFY_ATOL_M = 1e-6  # the certified distance's accuracy, m


@dataclass(frozen=True)
class Row:
    """A linear row sum(coef * a) <= rhs on the samples a of the moving axes, in units of the
    limit; ``time_s`` and ``item`` say where it came from."""

    coef: np.ndarray  # (n+1, d)
    rhs: float
    time_s: float
    item: int


def check_times(model, n_steps: int, dt_s: float) -> np.ndarray:
    """The grid the families scan: every dt / 8 during the move, then every 1/16 of the
    shortest period for two periods of the longest (the certification sees the rest)."""
    t_end = n_steps * dt_s
    during = dt_s / SUBSTEPS * np.arange(n_steps * SUBSTEPS + 1)
    freq = np.asarray(model.freq_hz)
    step = 1.0 / (16 * freq.max())
    after = t_end + step * np.arange(1, int(np.ceil(TAIL_PERIODS / freq.min() / step)) + 1)
    return np.concatenate([during, after])


def _local_peaks(values: np.ndarray, above: float) -> list[tuple[int, int]]:
    """(time index, item) at the largest local maxima in time of max over items above
    ``above`` (at most PEAKS_PER_ROUND), each with its ITEMS_PER_PEAK worst items above it,
    worst first: values (T, I). Several items per time: a tangent cut holds one direction of
    one item, and the LP's next answer moves the peak to the items next to it."""
    worst = values.max(axis=1)
    padded = np.concatenate([[-np.inf], worst, [-np.inf]])
    local = (worst >= padded[:-2]) & (worst >= padded[2:]) & (worst > above)
    found = []
    for j in sorted(np.flatnonzero(local), key=lambda j: -worst[j])[:PEAKS_PER_ROUND]:
        order = np.argsort(-values[j])[:ITEMS_PER_PEAK]
        found += [(int(j), int(i)) for i in order if values[j, i] > above]
    return found


def _worst_samples(values: np.ndarray, above: float) -> list[tuple[int, int]]:
    """(time index, item) of the ROWS_PER_ROUND largest samples above ``above``: values
    (T, I). Loads get a row at every violated sample, not only at the peaks: the LP's next
    answer would move the peak to the samples beside it (the rows' times are fixed)."""
    flat = np.flatnonzero(values > above)
    if flat.size > ROWS_PER_ROUND:
        flat = flat[np.argpartition(-values.ravel()[flat], ROWS_PER_ROUND)[:ROWS_PER_ROUND]]
    return [tuple(int(x) for x in np.unravel_index(f, values.shape)) for f in flat]


class LoadFamily:
    """Cup utilisation (limit 1) or von Mises stress (limit in Pa) of the nominal model."""

    def __init__(self, name: str, model, outputs, functional, limit: float, gravity_m_s2):
        self.name, self.model, self.outputs = name, model, outputs
        self.functional, self.limit = functional, float(limit)
        self.offset = outputs.offset(gravity_m_s2)
        self.q_map, self.v_map = np.asarray(outputs.q_map), np.asarray(outputs.v_map)
        self.a_map = np.asarray(outputs.a_map)

    @classmethod
    def cups(cls, model, safety: float, gravity_m_s2) -> LoadFamily:
        functional = CupUtilisation(model.cups, safety)
        return cls("cup utilisation", model, model.cups.reaction, functional, 1.0, gravity_m_s2)

    @classmethod
    def stress(cls, model, limit_pa: float, gravity_m_s2) -> LoadFamily:
        functional = VonMises(model.stress.n_points)
        return cls(
            "von Mises stress", model, model.stress.stress, functional, limit_pa, gravity_m_s2
        )

    def _rows_of(self, item: int) -> np.ndarray:
        r = self.functional.rows_per_item
        return np.arange(r * item, r * item + r)

    def values(
        self, acc: np.ndarray, dt_s: float, t: np.ndarray, items: np.ndarray | None = None
    ) -> np.ndarray:
        """(T, I) the functional of ``items`` (default every item) at times ``t`` (in blocks
        of ITEM_BLOCK items)."""
        if items is None:
            items = np.arange(self.functional.n_items)
        with threadpool_limits(limits=1, user_api="blas"):
            return self._values(acc, dt_s, t, items)

    def _values(self, acc: np.ndarray, dt_s: float, t: np.ndarray, items: np.ndarray):
        states = states_at(self.model, acc, dt_s, t)
        a = acceleration_at(acc, dt_s, t)
        r = self.functional.rows_per_item
        out = [np.zeros((len(t), 0))]
        for start in range(0, len(items), ITEM_BLOCK):
            block = items[start : start + ITEM_BLOCK]
            rows = (r * block[:, None] + np.arange(r)).ravel()
            y = (
                states[..., 0] @ self.q_map[rows].T
                + states[..., 1] @ self.v_map[rows].T
                + a @ self.a_map[rows].T
                + self.offset[rows]
            )
            out.append(self.functional.values(y.reshape(len(t), len(block), r), block))
        return np.concatenate(out, axis=1)

    def scan(self, move: Move, axes) -> list[Row]:
        """Rows at the worst sampled violations of ``move`` (a Move); only the items whose
        bound over the whole move and settling (jaxflex.peaks.item_bounds) reaches the row
        threshold are evaluated (an inactive constraint costs almost nothing)."""
        acc, dt_s = move.acc, move.dt_s
        above = self.limit * (1 - ROW_MARGIN + SCAN_RTOL)
        bounds = item_bounds(
            self.model, self.outputs, self.functional, acc, dt_s, offset=self.offset
        )
        candidates = np.flatnonzero(bounds > above)
        if candidates.size == 0:
            return []
        t = check_times(self.model, acc.shape[0] - 1, dt_s)
        found = _worst_samples(self.values(acc, dt_s, t, candidates), above)
        by_time: dict[int, list[int]] = {}
        for j, column in found:
            by_time.setdefault(j, []).append(int(candidates[column]))
        return [r for j, items in by_time.items() for r in self.rows(acc, dt_s, t[j], items, axes)]

    def row(self, acc: np.ndarray, dt_s: float, time_s: float, item: int, axes) -> Row:
        """The cut at (``time_s``, ``item``) of the move ``acc`` (module docstring)."""
        return self.rows(acc, dt_s, time_s, [item], axes)[0]

    def rows(self, acc: np.ndarray, dt_s: float, time_s: float, items, axes) -> list[Row]:
        """The cuts of ``items`` at ``time_s`` (one state map for all of them)."""
        n = acc.shape[0] - 1
        t = np.array([time_s])
        y_all = outputs_at(self.model, self.outputs, acc, dt_s, t, self.offset)[0]
        maps = state_maps_at(self.model, n, dt_s, t)[0]  # (M, 2, n+1, 3)
        return [self._cut_row(y_all, maps, acc, dt_s, time_s, item, axes) for item in items]

    def _cut_row(self, y_all, maps, acc, dt_s, time_s, item, axes) -> Row:
        n = acc.shape[0] - 1
        rows = self._rows_of(item)
        y = y_all[rows]
        g = self.functional.cut(y, item)
        coef = np.einsum("m,mkc->kc", g @ self.q_map[rows], maps[:, 0])
        coef += np.einsum("m,mkc->kc", g @ self.v_map[rows], maps[:, 1])
        if time_s < n * dt_s:  # a(t) = (1 - w) a_k + w a_k+1
            k = min(int(time_s // dt_s), n - 1)
            w = time_s / dt_s - k
            along = g @ self.a_map[rows]
            coef[k] += (1 - w) * along
            coef[k + 1] += w * along
        limit = self.limit * (1 - ROW_MARGIN)
        rhs = (limit - g @ self.offset[rows]) / self.limit
        return Row(coef[:, list(axes)] / self.limit, float(rhs), float(time_s), int(item))

    def certify(self, move: Move) -> Peak:
        """The certified peak over ``move`` (a Move) and the settling (jaxflex.peaks)."""
        return output_peak(
            self.model,
            self.outputs,
            self.functional,
            move,
            move.dt_s,
            offset=self.offset,
            rtol=1e-5,
            limit=self.limit,
        )

    def holds(self, peak: Peak) -> bool:
        return peak.bound <= self.limit * (1 + BOUND_RTOL)

    def failure_row(self, peak: Peak, move: Move, axes) -> Row:
        """The cut at the certified worst point of ``move`` (a Move), which failed."""
        return self.row(move.acc, move.dt_s, *self.worst(peak), axes)

    def curve(self, move: Move, t) -> np.ndarray:
        """(T,) the largest load of ``move`` (a Move) at times ``t`` (for plots)."""
        return self.values(move.acc, move.dt_s, t).max(axis=1)

    def worst(self, peak: Peak) -> tuple[float, int]:
        """(time, item) of the certified peak (a finite time: the part at rest after the
        move is checked before the search, optim.optimize)."""
        return peak.time_s, peak.item

    def describe(self, peak: Peak) -> dict:
        where = None
        if self.name == "von Mises stress" and peak.item >= 0:
            where = np.asarray(self.model.stress.points_m)[peak.item].tolist()
        elif peak.item >= 0:
            where = np.asarray(self.model.cups.centre_m)[peak.item].tolist()
        return {
            "name": self.name,
            "limit": self.limit,
            "peak": peak.value,
            "bound": peak.bound,
            "utilisation": peak.value / self.limit,
            "time_s": peak.time_s,
            "item": peak.item,
            "where_m": where,
        }


def certified_distance(family, measure, *move, **frame):
    """The certified clearance of a distance family (this module's or optim.turn_cell's):
    ``measure`` (jaxflex.geometry.min_distance or turning_min_distance) of the family's model
    and obstacles for the ``move`` arguments and the ``frame`` keywords (gravity, pivot), with
    the family's skin half thickness (m) and limit (m), to 1e-6 m."""
    return measure(
        family.model,
        family.obstacles,
        *move,
        **frame,
        half_thickness_m=family.half,
        atol=CERTIFY_ATOL_M,
        limit_m=family.limit,
    )


class DistanceFamily:
    """The part (every point of the model, its skins ``half_thickness_m`` off the mid-surface)
    at least ``margin_m`` from every obstacle (one model: the nominal, or one scenario)."""

    name = "distance to obstacles"

    def __init__(
        self, model, obstacles, margin_m: float, gravity_m_s2, half_thickness_m: float = 0.0
    ) -> None:
        self.model, self.obstacles, self.limit = model, tuple(obstacles), float(margin_m)
        self.half = float(half_thickness_m)
        self.gravity = np.asarray(gravity_m_s2, dtype=np.float64)
        self.base = np.asarray(model.points) + gravity_offset(model, self.gravity)
        self.shapes = response_shapes(model)  # (K, 3, M'): the modes, then the static residual
        self.blocks = part_blocks(model)
        self.extents = self.blocks.extents(self.base)

    def positions(self, acc, dt_s, t, points=None, coords=None) -> np.ndarray:
        """(T, P, 3) mid-surface positions of ``points`` (default all) at times ``t``."""
        return positions_at(self.model, acc, dt_s, t, self.gravity, points, coords)

    def near(self, acc: np.ndarray, dt_s: float, t: np.ndarray, within_m: float | None):
        """(points (P,), their skin distances (T, P)): the points that may come closer than
        ``within_m`` (None: than the nearest block centre at that time) at some time of
        ``t``, evaluated at the times where they may (elsewhere inf: every point provably
        keeps the distance there, its block's centre bounds it: jaxflex.collision.PartBlocks).
        """
        coords = displacement_coordinates(self.model, acc, dt_s, t)
        centres = self.positions(acc, dt_s, t, self.blocks.centre, coords)  # (T, nB, 3)
        moving = np.abs(coords) @ self.blocks.spread_shapes.T
        lower = block_lower_bounds(self.obstacles, centres, self.extents, moving) - self.half
        if within_m is None:  # the nearest centre's distance: attained, so a bound of the min
            d_centre, _, _ = distances(self.obstacles, centres.reshape(-1, 3))
            within_m = (d_centre.reshape(centres.shape[:2]) - self.half).min(axis=1)[:, None]
        close = lower <= within_m  # (T, nB)
        points = self.blocks.points_of(np.flatnonzero(close.any(axis=0)))
        times, blocks = np.nonzero(close)
        members = self.blocks.members[blocks]  # (pairs, b)
        real = members < len(self.base)
        pair_t = np.broadcast_to(times[:, None], members.shape)[real]
        pair_p = members[real]
        d = np.full((len(t), len(points)), np.inf)
        path = kinematics_at(acc, dt_s, t)[0]
        for chunk in np.array_split(np.arange(len(pair_p)), max(1, len(pair_p) // PAIR_CHUNK)):
            tt, pp = pair_t[chunk], pair_p[chunk]
            u = np.einsum("kcm,km->kc", self.shapes[pp], coords[tt])
            dist, _, _ = distances(self.obstacles, self.base[pp] + path[tt] + u)
            d[tt, np.searchsorted(points, pp)] = dist - self.half
        return points, d

    def scan(self, move: Move, axes) -> list[Row]:
        """Separating planes at the sampled closest approaches of ``move`` (a Move)."""
        acc, dt_s = move.acc, move.dt_s
        t = check_times(self.model, move.n_steps, dt_s)
        threshold = self.limit * (1 + ROW_MARGIN - SCAN_RTOL)
        points, d = self.near(acc, dt_s, t, threshold)
        if points.size == 0:  # the whole part provably keeps the distance
            return []
        found = _local_peaks(-d, -threshold)
        rows = (self.row(acc, dt_s, t[j], int(points[k]), axes) for j, k in found)
        return [r for r in rows if r is not None]

    def row(self, acc: np.ndarray, dt_s: float, time_s: float, point: int, axes) -> Row | None:
        """The separating plane at (``time_s``, ``point``) (module docstring); None where the
        point touches the obstacle's surface exactly (no direction)."""
        n = acc.shape[0] - 1
        t = np.array([time_s])
        p = self.positions(acc, dt_s, t, [point])[0, 0]
        d, _, c = distances(self.obstacles, p[None])
        gap = p - c[0]
        if np.linalg.norm(gap) < 1e-12:
            return None
        normal = np.sign(d[0]) * gap / np.linalg.norm(gap)
        along = normal @ self.shapes[point]  # (M',)
        coef = np.einsum(
            "m,mkc->kc", along[: self.model.n_modes], state_maps_at(self.model, n, dt_s, t)[0, :, 0]
        )
        if along.size > self.model.n_modes and time_s < n * dt_s:  # D a(t), a linear in steps
            k = min(int(time_s // dt_s), n - 1)
            w = time_s / dt_s - k
            coef[k] += (1 - w) * along[self.model.n_modes :]
            coef[k + 1] += w * along[self.model.n_modes :]
        coef += np.outer(position_weights(n, dt_s, t)[0], normal)
        margin = self.limit * (1 + ROW_MARGIN) + self.half
        rhs = normal @ (self.base[point] - c[0]) - margin  # -(n . p) <= n . (base - c) - margin
        return Row(-coef[:, list(axes)] / self.limit, float(rhs / self.limit), time_s, point)

    def certify(self, move: Move) -> Clearance:
        """The certified clearance over ``move`` (a Move) and the settling."""
        return certified_distance(self, min_distance, move, move.dt_s, gravity_m_s2=self.gravity)

    def holds(self, found: Clearance) -> bool:
        return found.bound_m >= self.limit * (1 - BOUND_RTOL)

    def failure_row(self, found: Clearance, move: Move, axes) -> Row | None:
        """The separating plane at the certified closest point of ``move``, which failed."""
        return self.row(move.acc, move.dt_s, *self.worst(found), axes)

    def worst(self, found: Clearance) -> tuple[float, int]:
        return found.time_s, found.point

    def describe(self, found: Clearance) -> dict:
        """The report's entry of the certified clearance ``found`` (jaxflex.geometry
        Clearance) against this family's limit; shared by the turning part's family."""
        return {
            "name": self.name,
            "limit": self.limit,
            "peak": found.distance_m,
            "bound": found.bound_m,
            "utilisation": self.limit / found.distance_m if found.distance_m > 0 else float("inf"),
            "time_s": found.time_s,
            "item": found.point,
            "obstacle": found.obstacle_name,
            # where the point is at the closest approach (the witness), and where it starts
            "where_m": None if found.position_m is None else list(found.position_m),
            "start_m": np.asarray(self.model.points)[found.point].tolist()
            if found.point >= 0
            else None,
            "points": self.model.n_points,
            "half_thickness_m": self.half,
        }

    def curve(self, move: Move, t):
        """(T,) the smallest skin distance of ``move`` (a Move) at times ``t`` (for plots)."""
        return self.near(move.acc, move.dt_s, t, None)[1].min(axis=1)
