"""The cell's constraints as LP rows: distance to obstacles, cup utilisation, stress.

Each family checks a move, proposes rows where it is violated, and certifies:

* **loads** (cup utilisation u_c <= 1, von Mises stress <= limit): the outputs are
  y(t) = Q q + V q' + A a + offset (jaxflex._outputs), linear in the samples at any time
  (jaxflex.response.state_maps_at); the functional is convex and positively homogeneous, so the
  cut g at a violating (time, item) (jaxflex._loads: f(y') >= g . y', equality at the peak)
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
searches of jaxflex._peaks and jaxflex._collision over the move and the whole settling, and a
failure adds a row at the certified worst point. Rows keep ROW_MARGIN of the limit in
reserve, so that peaks between grid samples rarely fail the certification.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property, partial

import numpy as np

from jaxflex.geometry import (
    Clearance,
    close_approaches,
    distances,
    gravity_offset,
    min_distance,
    nearest_distances,
    positions_at,
)
from jaxflex.response import (
    CupUtilisation,
    Move,
    Peak,
    VonMises,
    acceleration_at,
    as_move,
    item_bounds,
    one_blas_thread,
    output_peak,
    outputs_above,
    position_weights,
    response_shapes,
    state_maps_at,
    states_at,
)
from optim.robust import output_scales, perturbed

ROW_MARGIN = 1e-3
SCAN_RTOL = 1e-7  # a row's own limit is met up to the LP's feasibility tolerance (1e-9)
BOUND_RTOL = 1e-12  # the certified searches stop refining at the limit: round-off of it
ITEM_BLOCK = 2048
CURVE_CHUNK = 256  # items per evaluation of a plot's curve, in the order of their bounds
SUBSTEPS = 8
TAIL_PERIODS = 2.0
PEAKS_PER_ROUND = 20  # violated local maxima in time
ITEMS_PER_PEAK = 8  # rows at each: the worst items (points, cups) above the limit
ROWS_PER_ROUND = 240  # loads: rows at the worst violated (time, item) samples
CERTIFY_ATOL_M = 1e-6  # the certified distance's accuracy, m
MAPS_KEPT = 256  # state maps kept per model (about 84 kB each at 175 steps and 20 modes)


@dataclass(frozen=True)
class Row:
    """A linear row sum(coef * a) <= rhs on the samples a of the moving axes, in units of the
    limit; ``time_s`` and ``item`` say where it came from. ``restriction``: the row may cut
    off moves that meet the constraint (a distance's separating plane), else it is a valid
    cut. ``moved(n_steps, dt_s, axes)``, where given, is the same cut on a move of
    ``n_steps`` steps at the same fraction of the move (after it: the same time after it)."""

    coef: np.ndarray  # (n+1, d)
    rhs: float
    time_s: float
    item: int
    restriction: bool = False
    moved: Callable[[int, float, tuple], Row | None] | None = field(default=None, repr=False)


def state_maps(model, n_steps: int, dt_s: float, time_s: float) -> np.ndarray:
    """(M, 2, n+1, 3) jaxflex.response.state_maps_at of one time, the last MAPS_KEPT kept per
    model (the rows of one round, and the rows moved to a length, share their times)."""
    cache = model.__dict__.setdefault("_cell_state_maps", {})
    key = (int(n_steps), float(dt_s), float(time_s))
    if key not in cache:
        while len(cache) >= MAPS_KEPT:
            del cache[next(iter(cache))]
        cache[key] = state_maps_at(model, n_steps, dt_s, np.array([time_s]))[0]
    return cache[key]


def moved_time(time_s: float, n_from: int, n_to: int, dt_s: float) -> float:
    """The time on an ``n_to``-step move that corresponds to ``time_s`` on an ``n_from``-step
    move: the same fraction of the move, or the same time after it."""
    end = n_from * dt_s
    if time_s <= end:
        return time_s * n_to / n_from
    return n_to * dt_s + (time_s - end)


def _add_along(coef: np.ndarray, along: np.ndarray, time_s: float, dt_s: float) -> None:
    """Add the row of along . a(t) at ``time_s`` to ``coef`` (n+1, 3) in place: a(t) is
    linear between the samples (nothing after the move)."""
    n = coef.shape[0] - 1
    if time_s < n * dt_s:
        k = min(int(time_s // dt_s), n - 1)
        w = time_s / dt_s - k
        coef[k] += (1 - w) * along
        coef[k + 1] += w * along


def check_times(model, n_steps: int, dt_s: float) -> np.ndarray:
    """The grid the families scan: every dt / 8 during the move, then every 1/16 of the
    shortest period for two periods of the longest (the certification sees the rest)."""
    t_end = n_steps * dt_s
    during = dt_s / SUBSTEPS * np.arange(n_steps * SUBSTEPS + 1)
    freq = np.asarray(model.freq_hz)
    step = 1.0 / (16 * freq.max())
    after = t_end + step * np.arange(1, int(np.ceil(TAIL_PERIODS / freq.min() / step)) + 1)
    return np.concatenate([during, after])


def _peak_times(values: np.ndarray, above: float) -> list[int]:
    """The time indices of the largest local maxima in time of max over items of ``values``
    (T, I) above ``above`` (at most PEAKS_PER_ROUND), largest first."""
    worst = values.max(axis=1)
    padded = np.concatenate([[-np.inf], worst, [-np.inf]])
    local = (worst >= padded[:-2]) & (worst >= padded[2:]) & (worst > above)
    return [int(j) for j in sorted(np.flatnonzero(local), key=lambda j: -worst[j])][
        :PEAKS_PER_ROUND
    ]


def _local_peaks(values: np.ndarray, above: float) -> list[tuple[int, int]]:
    """(time index, item) at the largest local maxima in time of max over items above
    ``above`` (:func:`_peak_times`), each with its ITEMS_PER_PEAK worst items above it,
    worst first: values (T, I). Several items per time: a tangent cut holds one direction of
    one item, and the LP's next answer moves the peak to the items next to it."""
    found = []
    for j in _peak_times(values, above):
        order = np.argsort(-values[j])[:ITEMS_PER_PEAK]
        found += [(j, int(i)) for i in order if values[j, i] > above]
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
    """Cup utilisation (limit 1) or von Mises stress (limit in Pa) of one model: the nominal,
    or (:meth:`scenario`) a model of a robust grid, which shares the nominal maps with each
    mode's column scaled (``state_scale``: jaxflex._peaks)."""

    def __init__(
        self, name: str, model, outputs, functional, limit: float, gravity_m_s2, state_scale=None
    ):
        self.name, self.model, self.outputs = name, model, outputs
        if model.stress is not None or model.cups is not None:  # where each item is, m
            stress = name == "von Mises stress"
            self.places = np.asarray(model.stress.points_m if stress else model.cups.centre_m)
        self.functional, self.limit = functional, float(limit)
        self.gravity = np.asarray(gravity_m_s2, dtype=np.float64)
        self.offset = outputs.offset(self.gravity)
        self.q_map, self.v_map = np.asarray(outputs.q_map), np.asarray(outputs.v_map)
        self.a_map = np.asarray(outputs.a_map)
        self.state_scale = state_scale
        ones = np.ones(model.n_modes)
        self.q_scale, self.v_scale = (ones, ones) if state_scale is None else state_scale

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

    def scenario(self, scale: float, zeta: float | None) -> LoadFamily:
        """The family of this model with its frequencies scaled by ``scale`` and its damping
        ratios set to ``zeta`` (or kept): the model of a robust grid (optim.robust), its
        outputs this family's maps with each mode's column scaled (optim.robust.output_scales;
        the maps are not copied), or scaled copies where the damping cannot be a column
        scale (a model with undamped modes)."""
        scales = output_scales(self.model, scale, zeta)
        if scales is None:
            model = perturbed(self.model, scale, zeta, outputs=True)
            outputs = model.cups.reaction if self.name == "cup utilisation" else model.stress.stress
            return LoadFamily(self.name, model, outputs, self.functional, self.limit, self.gravity)
        model = perturbed(self.model, scale, zeta)
        family = LoadFamily(
            self.name, model, self.outputs, self.functional, self.limit, self.gravity, scales
        )
        family.places = self.places
        return family

    def _rows_of(self, item: int) -> np.ndarray:
        r = self.functional.rows_per_item
        return np.arange(r * item, r * item + r)

    def values(self, move: Move, t: np.ndarray, items: np.ndarray | None = None) -> np.ndarray:
        """(T, I) the functional of ``items`` (default every item) at times ``t`` (s) during
        and after ``move`` (a Move), in blocks of ITEM_BLOCK items."""
        if items is None:
            items = np.arange(self.functional.n_items)
        with one_blas_thread():
            return self._values(move, t, items)

    def _values(self, move: Move, t: np.ndarray, items: np.ndarray):
        states = states_at(self.model, move, t)
        a = acceleration_at(move, t)
        r = self.functional.rows_per_item
        out = [np.zeros((len(t), 0))]
        for start in range(0, len(items), ITEM_BLOCK):
            block = items[start : start + ITEM_BLOCK]
            y = self._outputs(states, a, (r * block[:, None] + np.arange(r)).ravel())
            out.append(self.functional.values(y.reshape(len(t), len(block), r), block))
        return np.concatenate(out, axis=1)

    def _outputs(self, states: np.ndarray, a: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """(T, R) the outputs ``rows`` for modal states (T, M, 2) and accelerations (T, 3)."""
        return (
            (states[..., 0] * self.q_scale) @ self.q_map[rows].T
            + (states[..., 1] * self.v_scale) @ self.v_map[rows].T
            + a @ self.a_map[rows].T
            + self.offset[rows]
        )

    def scan(self, move: Move, axes) -> list[Row]:
        """Rows at the worst sampled violations of ``move`` (a Move); only the items whose
        bound over the whole move and settling (jaxflex.response.item_bounds) reaches the row
        threshold are evaluated (an inactive constraint costs almost nothing), at the
        samples and, between them, where a curvature bound reaches it
        (jaxflex.response.outputs_above: the samples above the threshold are those of
        every time)."""
        above = self.limit * (1 - ROW_MARGIN + SCAN_RTOL)
        t = check_times(self.model, move.n_steps, move.dt_s)
        candidates, values = outputs_above(
            self.model, self.outputs, self.functional, as_move(move, at_rest=True), t, above,
            offset=self.offset, state_scale=self.state_scale,
        )  # fmt: skip
        if candidates.size == 0:
            return []
        found = _worst_samples(values, above)
        by_time: dict[int, list[int]] = {}
        for j, column in found:
            by_time.setdefault(j, []).append(int(candidates[column]))
        return [r for j, items in by_time.items() for r in self.rows(move, t[j], items, axes)]

    def row(self, move: Move, time_s: float, item: int, axes) -> Row:
        """The cut at (``time_s``, ``item``) of ``move`` (a Move; module docstring)."""
        return self.rows(move, time_s, [item], axes)[0]

    def rows(self, move: Move, time_s: float, items, axes) -> list[Row]:
        """The cuts of ``items`` at ``time_s`` (one state map for all of them)."""
        n, dt_s = move.n_steps, move.dt_s
        t = np.array([time_s])
        states = states_at(self.model, move, t)
        a = acceleration_at(move, t)
        maps = state_maps(self.model, n, dt_s, time_s)  # (M, 2, n+1, 3)
        found = []
        for item in items:
            rows = self._rows_of(item)
            g = self.functional.cut(self._outputs(states, a, rows)[0], item)
            found.append(self.cut(g, item, time_s, n, dt_s, axes, maps))
        return found

    def cut(self, g, item: int, time_s: float, n_steps: int, dt_s: float, axes, maps=None) -> Row:
        """The row g . y_item(``time_s``) <= limit on an ``n_steps``-step move (``maps``: its
        state maps at that time, if known): valid for every move and time, as f(y) >= g . y
        (module docstring)."""
        if maps is None:
            maps = state_maps(self.model, n_steps, dt_s, time_s)
        rows = self._rows_of(item)
        coef = np.einsum("m,mkc->kc", (g @ self.q_map[rows]) * self.q_scale, maps[:, 0])
        coef += np.einsum("m,mkc->kc", (g @ self.v_map[rows]) * self.v_scale, maps[:, 1])
        _add_along(coef, g @ self.a_map[rows], time_s, dt_s)
        limit = self.limit * (1 - ROW_MARGIN)
        rhs = (limit - g @ self.offset[rows]) / self.limit
        moved = partial(self._moved_cut, g, int(item), float(time_s), n_steps)
        return Row(
            coef[:, list(axes)] / self.limit, float(rhs), float(time_s), int(item), False, moved
        )

    def _moved_cut(self, g, item, time_s, n_from, n_to, dt_s, axes) -> Row:
        return self.cut(g, item, moved_time(time_s, n_from, n_to, dt_s), n_to, dt_s, axes)

    def certify(self, move: Move) -> Peak:
        """The certified peak over ``move`` (a Move) and the settling (jaxflex._peaks), decided
        against the limit: located where it may exceed it, else a value found with ``bound``
        at most the limit (what the search needs)."""
        return self._peak(move, self.limit)

    def measure(self, move: Move, worst: Peak | None = None) -> Peak:
        """The certified peak of ``move`` located to 1e-5 (reports): everywhere, or only where
        it may exceed ``worst`` (the peak of another model of a robust grid, the worst so far:
        a model below it is certified without locating its peak) or the limit."""
        return self._peak(move, None if worst is None else min(worst.value, self.limit))

    def _peak(self, move: Move, limit: float | None) -> Peak:
        """jaxflex.response.output_peak of ``move`` to 1e-5, decided against ``limit``."""
        return output_peak(
            self.model,
            self.outputs,
            self.functional,
            move,
            offset=self.offset,
            rtol=1e-5,
            limit=limit,
            state_scale=self.state_scale,
        )

    def holds(self, peak: Peak) -> bool:
        return peak.bound <= self.limit * (1 + BOUND_RTOL)

    def failure_row(self, peak: Peak, move: Move, axes) -> Row:
        """The cut at the certified worst point of ``move`` (a Move), which failed."""
        return self.row(move, *self.worst(peak), axes)

    def curve(self, move: Move, t) -> np.ndarray:
        """(T,) the largest load of ``move`` (a Move) at times ``t`` (for plots), exact: the
        items in the order of their bound over the move and the settling
        (jaxflex.response.item_bounds), a chunk evaluated only at the times where its largest
        bound exceeds the largest load found."""
        t = np.asarray(t, dtype=np.float64)
        bounds = item_bounds(
            self.model, self.outputs, self.functional, move, offset=self.offset,
            state_scale=self.state_scale,
        )  # fmt: skip
        order = np.argsort(-bounds, kind="stable")
        largest = np.full(len(t), -np.inf)
        for start in range(0, len(order), CURVE_CHUNK):
            chunk = order[start : start + CURVE_CHUNK]
            times = np.flatnonzero(bounds[chunk[0]] > largest)
            if times.size == 0:
                break
            found = self.values(move, t[times], chunk).max(axis=1)
            largest[times] = np.maximum(largest[times], found)
        return largest

    def worst(self, peak: Peak) -> tuple[float, int]:
        """(time, item) of the certified peak (a finite time: the part at rest after the
        move is checked before the search, optim.optimize)."""
        return peak.time_s, peak.item

    def describe(self, peak: Peak) -> dict:
        where = self.places[peak.item].tolist() if peak.item >= 0 else None
        out = {
            "name": self.name,
            "limit": self.limit,
            "peak": peak.value,
            "bound": peak.bound,
            "utilisation": peak.value / self.limit,
            "time_s": peak.time_s,
            "item": peak.item,
            "where_m": where,
        }
        error = stress_discretisation(self.model) if self.name == "von Mises stress" else None
        if error is not None:  # the FE's own estimate: the real part's stress may be this much
            out["discretisation_error"] = error  # higher than the model's (fem.discretisation)
            out["peak_with_discretisation"] = peak.value * (1 + error)
        return out


def stress_discretisation(model) -> float | None:
    """The relative discretisation error of the peak stress that the FE analysis behind
    ``model`` estimated (its meta's ``discretisation``, fem.discretisation), or None."""
    found = dict(model.meta).get("discretisation")
    if not isinstance(found, dict):
        return None
    error = found.get("max_stress_error")
    return None if error is None else float(error)


def certified_distance(family, measure, move, *, limit_m=None, **frame):
    """The certified clearance of a distance family (this module's or optim.turn_cell's):
    ``measure`` (jaxflex.geometry.min_distance or turning_min_distance) of the family's model
    and obstacles for ``move`` (a Move, or a jaxflex.response.Turn) and the
    ``frame`` keywords (a straight move's gravity), with the family's skin half thickness
    (m), to 1e-6 m, decided against ``limit_m`` (m; None: located everywhere)."""
    return measure(
        family.model,
        family.obstacles,
        move,
        **frame,
        half_thickness_m=family.half,
        atol=CERTIFY_ATOL_M,
        limit_m=limit_m,
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

    @cached_property
    def shapes(self) -> np.ndarray:
        """(K, 3, M') the modes, then the static residual (for rows: a model of a robust
        grid that never gives rows never builds them)."""
        return response_shapes(self.model)

    def positions(self, move: Move, t, points=None, coords=None) -> np.ndarray:
        """(T, P, 3) mid-surface positions of ``points`` (default all) at times ``t`` (s)
        during and after ``move`` (a Move)."""
        return positions_at(self.model, move, t, self.gravity, points, coords)

    def scan(self, move: Move, axes) -> list[Row]:
        """Separating planes at the sampled closest approaches of ``move`` (a Move): the
        closest point at each check time, and every point that may come closer than the row
        threshold at the times of the worst approaches (jaxflex.geometry.close_approaches;
        the rows of evaluating every point at every check time)."""
        t = check_times(self.model, move.n_steps, move.dt_s)
        threshold = self.limit * (1 + ROW_MARGIN - SCAN_RTOL)
        found = close_approaches(
            self.model, self.obstacles, move, t, threshold, gravity_m_s2=self.gravity,
            half_thickness_m=self.half,
        )  # fmt: skip
        if found.points.size == 0:  # the whole part provably keeps the distance
            return []
        found.fill(_peak_times(-found.distances, -threshold))
        peaks = _local_peaks(-found.distances, -threshold)
        rows = (self.row(move, t[j], int(found.points[k]), axes) for j, k in peaks)
        return [r for r in rows if r is not None]

    def row(self, move: Move, time_s: float, point: int, axes) -> Row | None:
        """The separating plane at (``time_s``, ``point``) of ``move`` (a Move; module
        docstring); None where the point touches the obstacle's surface exactly (no
        direction)."""
        p = self.positions(move, np.array([time_s]), [point])[0, 0]
        d, _, c = distances(self.obstacles, p[None])
        gap = p - c[0]
        if np.linalg.norm(gap) < 1e-12:
            return None
        normal = np.sign(d[0]) * gap / np.linalg.norm(gap)
        return self.plane(normal, c[0], point, time_s, move.n_steps, move.dt_s, axes)

    def plane(self, normal, closest, point: int, time_s: float, n_steps: int, dt_s: float, axes):
        """The row n . (p(``time_s``) - c) >= margin of ``point`` on an ``n_steps``-step move,
        for the plane through ``closest`` c with unit ``normal`` n (out of the obstacle): a
        restriction (module docstring)."""
        t = np.array([time_s])
        along = normal @ self.shapes[point]  # (M',)
        m = self.model.n_modes
        coef = np.einsum(
            "m,mkc->kc", along[:m], state_maps(self.model, n_steps, dt_s, time_s)[:, 0]
        )
        if along.size > m:  # D a(t)
            _add_along(coef, along[m:], time_s, dt_s)
        coef += np.outer(position_weights(n_steps, dt_s, t)[0], normal)
        margin = self.limit * (1 + ROW_MARGIN) + self.half
        rhs = normal @ (self.base[point] - closest) - margin  # -(n . p) <= n . (base - c) - margin
        moved = partial(self._moved_plane, normal, closest, point, float(time_s), n_steps)
        return Row(
            -coef[:, list(axes)] / self.limit, float(rhs / self.limit), float(time_s), point, True,
            moved,
        )  # fmt: skip

    def _moved_plane(self, normal, closest, point, time_s, n_from, n_to, dt_s, axes) -> Row:
        time = moved_time(time_s, n_from, n_to, dt_s)
        return self.plane(normal, closest, point, time, n_to, dt_s, axes)

    def scenario(self, scale: float, zeta: float | None) -> DistanceFamily:
        """The family of this model with its frequencies scaled by ``scale`` and its damping
        ratios set to ``zeta`` (or kept): a model of a robust grid (optim.robust)."""
        return DistanceFamily(
            perturbed(self.model, scale, zeta), self.obstacles, self.limit, self.gravity, self.half
        )

    def certify(self, move: Move) -> Clearance:
        """The certified clearance over ``move`` (a Move) and the settling, decided against
        the limit: located where the part may come closer, else a distance found with
        ``bound_m`` at least the limit (what the search needs)."""
        return self._clearance(move, self.limit)

    def measure(self, move: Move, worst: Clearance | None = None) -> Clearance:
        """The certified clearance of ``move`` located to 1e-6 m (reports): everywhere, or
        only where it may be below ``worst`` (another model's, the worst so far) or the
        limit."""
        return self._clearance(move, None if worst is None else max(worst.distance_m, self.limit))

    def _clearance(self, move: Move, limit_m: float | None) -> Clearance:
        return certified_distance(
            self, min_distance, move, gravity_m_s2=self.gravity, limit_m=limit_m
        )

    def holds(self, found: Clearance) -> bool:
        return found.bound_m >= self.limit * (1 - BOUND_RTOL)

    def failure_row(self, found: Clearance, move: Move, axes) -> Row | None:
        """The separating plane at the certified closest point of ``move``, which failed."""
        return self.row(move, *self.worst(found), axes)

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
        """(T,) the smallest skin distance of ``move`` (a Move) at times ``t`` (for plots;
        jaxflex.geometry.nearest_distances)."""
        return nearest_distances(
            self.model, self.obstacles, move, t, gravity_m_s2=self.gravity,
            half_thickness_m=self.half,
        )  # fmt: skip
