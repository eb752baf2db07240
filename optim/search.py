"""The shortest move after which the part stays within the threshold: shared outer loops.

Feasibility of "n steps suffice" is monotone in n (one more zero sample keeps any solution),
so the minimum is found by bisection between the kinematic floor (infeasible below it) and
a baseline's cycle time (a baseline padded with zeros to its cycle time is feasible).

Each test at a fixed n asks a subproblem solver (the LP of the exact route or the smooth NLP
of the gradient route) for samples that keep the deviation below the threshold at a pool of
sampled (scenario, point, time-after-the-move) rows, then

1. samples the free response of every training scenario densely and adds the worst
   exceedances to the pool (rows depend on the time after the move only, so they stay valid
   for every n and the pool is shared by the whole search);
2. once no sampled exceedance is left, certifies the profile with the exact cycle time of
   every scenario (``jaxflex.analyze_move``); a scenario that fails adds a row at its worst
   peak near the certified crossing (and joins the training set, in robust mode).

Rows use the threshold reduced by RESIDUAL_MARGIN (0.1 %), so peaks between samples rarely
fail the certification; the result is exact regardless, because only certified profiles
count as feasible.

The cell's constraints (optim.cell_rows: distance to obstacles, cup utilisation, stress) add
their rows the same way, per n, and are certified after the cycle time; via points pass at
fixed fractions of the move (:attr:`Problem.via`, taken from the via-point baseline's timing).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from jaxflex.model import ModalModel
from jaxflex.response import (
    Move,
    SettleReport,
    analyze_move,
    as_move,
    end_state_map,
    enforce_end_state,
)
from jaxflex.runtime import check_time, progress_bar
from optim.cell_rows import Row
from optim.kinematics import ViaRow, moving_axes, via_step
from optim.limits import Limits
from optim.move_response import ClearancePeak, MoveResponse
from optim.options import RobustSpec
from optim.residual import Peak, ResidualModel
from optim.robust import perturbed
from optim.turn_clearance import TurnMoveResponse

RESIDUAL_MARGIN = 1e-3
MAX_ROUNDS = 60
PEAKS_PER_ROUND = 40
TIME_RTOL = 1e-12
SOLVER_FAILURES = ("failed", "row generation did not converge")
PROOFS = ("infeasible", "rows cannot all hold")  # an LP of valid rows only: no move exists
EXCLUDED = "excluded by the necessary test"  # (:func:`necessary`): no move exists
KEPT_LENGTHS = 2
SEEDED_CUTS = 120  # valid cuts of a certified length moved to the next length tested
TIGHT_SLACK = 0.01  # ... those its certified move meets within 1 % of their limit


@dataclass
class Scenario:
    """One model the profile must work for (the nominal one, or a point of the robust grid)."""

    label: str
    scale: float
    zeta: float | None
    model: ModalModel
    residual: ResidualModel
    zscale: np.ndarray  # (M, 2): modal amplitudes that give ~threshold deviation

    def as_dict(self) -> dict:
        return {"freq_scale": self.scale, "zeta": self.zeta}


@dataclass
class PoolRow:
    scenario: int
    peak: Peak
    coef: np.ndarray  # (M, 2): coef . x_end = the cut's value in m


@dataclass
class Problem:
    """Everything a search needs: data, scenarios, training set and the row pool."""

    model: ModalModel
    distance_m: np.ndarray  # (3,) m
    limits: Limits
    threshold_m: float
    dt_s: float
    max_steps: int
    robust: RobustSpec | None
    scenarios: list[Scenario]
    training: list[int]
    components: tuple[int, ...]
    clearance_m: float | None = None  # limit on the deviation during the move (nominal)
    via: list[tuple[np.ndarray, str, float, float]] = field(default_factory=list)
    families: list = field(default_factory=list)  # optim.cell_rows families
    pool: list[PoolRow] = field(default_factory=list)
    clearance_pool: dict[int, list[ClearancePeak]] = field(default_factory=dict)
    cell_rows: dict[int, list[Row]] = field(default_factory=dict)
    turn: Any = None  # optim.turn.TurnSchedule: a fixed turn with the move (affine end state)
    certified: set[int] = field(default_factory=set)  # lengths with a certified move
    certified_moves: dict[int, np.ndarray] = field(default_factory=dict)  # their samples
    excluded: set[int] = field(default_factory=set)  # lengths proven too short (no move)
    seeded: dict[int, int] = field(default_factory=dict)  # length: certified length it took rows of
    _maps: dict = field(default_factory=dict)
    _move_maps: dict = field(default_factory=dict)

    @property
    def limit_m(self) -> float:
        return self.threshold_m * (1.0 - RESIDUAL_MARGIN)

    def via_rows(self, n_steps: int) -> list[ViaRow]:
        """The via points of an n-step move, each at its fraction of the move (rounded to a
        sample, kept inside the move)."""
        rows = []
        for offset, mode, tolerance, fraction in self.via:
            rows.append(ViaRow(via_step(fraction, n_steps), offset, mode, tolerance))
        return rows

    @property
    def axes(self) -> tuple[int, ...]:
        """The axes the move uses (distance or via points)."""
        return moving_axes(self.distance_m, [ViaRow(0, v[0], v[1], v[2]) for v in self.via])

    @property
    def clearance_limit_m(self) -> float:
        return self.clearance_m * (1.0 - RESIDUAL_MARGIN)

    def move_map(self, n_steps: int) -> MoveResponse | TurnMoveResponse:
        """The nominal model's response during an n-step move (optim.move_response), with a
        turn that of its active schedule (optim.turn_clearance)."""
        if n_steps not in self._move_maps:
            _forget_lengths(self._move_maps, n_steps, _length)
            self._move_maps[n_steps] = MoveResponse(self.model, self.components, n_steps, self.dt_s)
        if self.turn is None:
            return self._move_maps[n_steps]
        key = (n_steps, self.turn.variant)
        if key not in self._move_maps:
            alpha = self.turn.angular_acc(n_steps)
            self._move_maps[key] = TurnMoveResponse(self._move_maps[n_steps], self.turn.spec, alpha)
        return self._move_maps[key]

    def end_map(self, scenario: int, n_steps: int) -> np.ndarray:
        key = (scenario, n_steps)
        if key not in self._maps:
            _forget_lengths(self._maps, n_steps, lambda key: key[1])
            self._maps[key] = end_state_map(self.scenarios[scenario].model, n_steps, self.dt_s)
        if self.turn is not None:
            return self.turn.rotated_map(self._maps[key], n_steps, scenario)
        return self._maps[key]

    def end_offset(self, scenario: int, n_steps: int) -> np.ndarray:
        """(M, 2) end state with the translation at rest: zero, or the turn's own."""
        model = self.scenarios[scenario].model
        if self.turn is None:
            return np.zeros((model.n_modes, 2))
        return self.turn.end_offset(model, n_steps, scenario)

    def end_state(self, scenario: int, acc: np.ndarray) -> np.ndarray:
        n_steps = acc.shape[0] - 1
        linear = np.einsum("mikc,kc->mi", self.end_map(scenario, n_steps), acc)
        return linear + self.end_offset(scenario, n_steps)

    def timing(self, scenario: int, move: Move) -> SettleReport:
        """Exact cycle time of ``move`` (a Move) for one scenario: the straight move's, or
        the turning move's (optim.turn)."""
        model = self.scenarios[scenario].model
        if self.turn is None:
            return analyze_move(model, move, threshold_m=self.threshold_m, settle=False)
        return self.turn.timing(model, move, self.threshold_m)

    def add_peak(self, scenario: int, peak: Peak) -> None:
        coef = self.scenarios[scenario].residual.row(peak)
        self.pool.append(PoolRow(scenario, peak, coef))

    def restricted(self, n_steps: int) -> bool:
        """Whether the cell's rows of ``n_steps`` include restrictions (separating planes,
        optim.cell_rows): rows that can cut off a move that meets the constraints."""
        return any(r.restriction for r in self.cell_rows.get(n_steps, []))

    def seed(self, n_steps: int) -> int | None:
        """Before a test of ``n_steps`` that has no certified move: the separating planes of
        the nearest certified length moved to it (the same planes at the same fractions of
        the move), in place of its own (its valid cuts stay). A plane chosen where a
        certified move passed is on the side that move keeps, not where an LP's answer that
        runs into the obstacle happens to be. Returns that length, or None (none certified
        yet, this length certified, already seeded from it, or a turning move: its rows
        belong to the turn's schedule)."""
        if self.turn is not None or n_steps in self.certified or not self.certified:
            return None
        source = min(self.certified, key=lambda n: (abs(n - n_steps), n))
        if self.seeded.get(n_steps) == source:
            return None
        own = [r for r in self.cell_rows.get(n_steps, []) if not r.restriction]
        rows = [r for r in self.cell_rows.get(source, []) if r.moved is not None]
        planes = [r for r in rows if r.restriction]
        moved = (r.moved(n_steps, self.dt_s, self.axes) for r in planes + self._tight(source))
        self.cell_rows[n_steps] = own + [r for r in moved if r is not None]
        self.seeded[n_steps] = source
        return source

    def _tight(self, n_steps: int) -> list[Row]:
        """The valid cuts of the certified length ``n_steps`` that its certified move meets
        within TIGHT_SLACK of their limit, the tightest SEEDED_CUTS: the ones that shaped it,
        which a neighbouring length then starts from (any valid cut may; these are the ones
        likely to matter, and moving all of them would cost more than the rounds they save)."""
        move = self.certified_moves[n_steps][:, list(self.axes)]
        cuts = [r for r in self.cell_rows.get(n_steps, []) if not r.restriction and r.moved]
        slack = np.array([r.rhs - np.sum(r.coef * move) for r in cuts])
        order = np.argsort(slack, kind="stable")[:SEEDED_CUTS]
        return [cuts[i] for i in order if slack[i] <= TIGHT_SLACK]

    def nominal(self) -> Problem:
        """The same problem for the nominal model alone: its scenario and, of every robust
        family (optim.cell_scenarios), the nominal model's family."""
        grid, training = scenarios(self.model, None, self.threshold_m)
        families = [getattr(f, "nominal", f) for f in self.families]
        return Problem(
            self.model, self.distance_m, self.limits, self.threshold_m, self.dt_s,
            self.max_steps, None, grid, training, self.components, self.clearance_m,
            via=self.via, families=families,
        )  # fmt: skip

    def adopt(self, nominal: Problem) -> None:
        """Take the cell's rows of the :meth:`nominal` problem's search (rows of the nominal
        model, which every robust family certifies too) and, where the nominal model is one
        of the robust scenarios (:meth:`covers_nominal`), the lengths it proved too short."""
        for n, rows in nominal.cell_rows.items():
            self.cell_rows.setdefault(n, []).extend(rows)
        if self.covers_nominal():
            self.excluded |= nominal.excluded

    def covers_nominal(self) -> bool:
        """Whether the nominal model is one of the scenarios (frequency scale 1, its own
        damping): then every move certified for the scenarios is certified for it."""
        return any(s.scale == 1.0 and _same_damping(s, self.model) for s in self.scenarios)


def _same_damping(scenario: Scenario, model: ModalModel) -> bool:
    """Whether ``scenario`` has the damping of ``model`` (its own, or equal ratios)."""
    return scenario.zeta is None or bool(np.allclose(model.zeta, scenario.zeta, rtol=1e-12))


def _length(key: int | tuple[int, int]) -> int:
    """The move length of a key of the response cache: n, or (n, the turn's schedule)."""
    return key if isinstance(key, int) else key[0]


def _forget_lengths(cache: dict, n_steps: int, length) -> None:
    """Keep the maps of at most KEPT_LENGTHS move lengths (the search tests one length at a
    time and the polish pass the best one and the next): memory stays that of the longest."""
    lengths = list(dict.fromkeys(length(key) for key in cache))
    if n_steps not in lengths and len(lengths) >= KEPT_LENGTHS:
        for key in [k for k in cache if length(k) == lengths[0]]:
            del cache[key]


def active_components(model: ModalModel) -> tuple[int, ...]:
    """Displacement components the mode shapes use (all three for a general part)."""
    shapes = np.abs(np.asarray(model.shapes))
    peak = shapes.max()
    comps = tuple(int(c) for c in range(3) if shapes[:, c, :].max() > 1e-12 * peak)
    return comps or (2,)


def make_problem(
    model: ModalModel,
    distance_m: np.ndarray,
    limits: Limits,
    dt_s: float,
    threshold_m: float,
    max_steps: int,
    robust: RobustSpec | None,
    clearance_m: float | None = None,
) -> Problem:
    """The problem of a move without via points or cell constraints (optim.stages builds
    the full one from :func:`scenarios`)."""
    grid, training = scenarios(model, robust, threshold_m)
    comps = active_components(model)
    return Problem(
        model, distance_m, limits, threshold_m, dt_s, max_steps, robust, grid, training, comps,
        clearance_m,
    )  # fmt: skip


def scenarios(
    model: ModalModel, robust: RobustSpec | None, threshold_m: float
) -> tuple[list[Scenario], list[int]]:
    """The models every move is certified on (the nominal one, or the robust grid's) and
    the indices of those the search starts training on."""
    comps = active_components(model)
    grid = [(1.0, None)] if robust is None else robust.grid()
    found = []
    for scale, zeta in grid:
        m = perturbed(model, scale, zeta) if robust is not None else model
        res = ResidualModel(m, comps)
        zq = threshold_m / np.where(res.weights.max(axis=0) > 0, res.weights.max(axis=0), 1.0)
        label = "nominal" if robust is None else f"f x{scale:.3f}, zeta {zeta}"
        found.append(Scenario(label, scale, zeta, m, res, np.stack([zq, res.omega * zq], -1)))
    if robust is None:
        return found, [0]
    # start from the corners and the middle of the frequency range at the lowest zeta
    scales = sorted({s for s, _ in grid})
    zmin = min(z for _, z in grid) if robust.zeta is not None else None
    wanted = {scales[0], scales[len(scales) // 2], scales[-1]}
    return found, [i for i, (s, z) in enumerate(grid) if s in wanted and z == zmin]


def add_end_states(builder, problem: Problem, layout) -> dict[int, np.ndarray]:
    """Add each training scenario's scaled end state z_hat = x_end / zscale (2 M variables,
    contiguous, in training order) tied to the samples by z_hat - (E / zscale) a = 0.
    Returns the variable indices per scenario."""
    a_cols = layout.a.ravel()  # axis-major, like E[..., axes] transposed below
    z_cols = {}
    for i in problem.training:
        emap = problem.end_map(i, layout.n_steps)[..., list(layout.axes)]  # (M, 2, n+1, d)
        m = emap.shape[0]
        e_flat = np.transpose(emap, (0, 1, 3, 2)).reshape(2 * m, -1)
        zscale = problem.scenarios[i].zscale.reshape(-1)
        e_flat = e_flat / zscale[:, None]
        offset = problem.end_offset(i, layout.n_steps).reshape(-1) / zscale
        z = builder.variables(2 * m)
        builder.dense_rows(
            np.hstack([np.eye(2 * m), -e_flat]), np.concatenate([z, a_cols]), offset, offset
        )
        z_cols[i] = z
    return z_cols


@dataclass
class SubResult:
    """A subproblem's answer at fixed n: samples (raw, before the exact end-state correction)
    and the largest pool row value in units of the limit (<= 1 means all rows hold)."""

    status: str  # "solved", "infeasible" (kinematically, or rows cannot all hold) or "failed"
    acc: np.ndarray | None
    value: float
    stats: dict


class Subsolver(Protocol):
    name: str
    clearance_rows: bool  # True: takes the clearance as pooled rows; False: as a whole

    def solve(self, problem: Problem, n_steps: int, warm: np.ndarray) -> SubResult:
        """Minimise the largest pool row over moves of ``n_steps`` steps (a polishing
        subsolver: a smoothness measure subject to every row holding)."""


@dataclass
class Attempt:
    n_steps: int
    feasible: bool
    acc: np.ndarray | None
    timings: dict[int, SettleReport]
    value: float
    rounds: int
    wall_s: float
    reason: str
    solver_stats: list[dict]
    turn_acc: np.ndarray | None = None  # (n+1,) rad/s^2: the turn's schedule (optim.turn)

    def summary(self) -> dict:
        return {
            "n_steps": self.n_steps,
            "feasible": self.feasible,
            "max_row_value": self.value,
            "rounds": self.rounds,
            "wall_s": self.wall_s,
            "reason": self.reason,
        }


def _certify(problem: Problem, move: Move):
    """Exact cycle time of every scenario for ``move`` (a Move). Training scenarios that fail
    get a row at their worst peak near the certified crossing; of the others, only the worst
    failure joins the training set (adding every failing scenario floods the LP with
    near-duplicates). Returns (timings, number of failures)."""
    transfer = move.duration_s
    timings: dict[int, SettleReport] = {}
    failed = []
    for i in range(len(problem.scenarios)):
        timing = problem.timing(i, move)
        timings[i] = timing
        if timing.cycle_time_s > transfer * (1 + TIME_RTOL):
            failed.append(i)
    outside = [i for i in failed if i not in problem.training]
    chosen = [i for i in failed if i in problem.training]
    if outside:
        worst = max(outside, key=lambda i: timings[i].cycle_time_s)
        problem.training.append(worst)
        chosen.append(worst)
    for i in chosen:
        x_end = problem.end_state(i, move.acc)
        tau = timings[i].settle_time_s - transfer
        problem.add_peak(
            i,
            problem.scenarios[i].residual.worst_near(x_end, tau, problem.limit_m),
        )
    return timings, len(failed)


def _certify_families(problem: Problem, move: Move) -> int:
    """Certify the cell's constraints (optim.cell_rows) for ``move`` (a Move); each family
    that fails adds a row at its certified worst point. Returns the number of failures."""
    failed = 0
    for family in problem.families:
        found = family.certify(move)
        if family.holds(found):
            continue
        failed += 1
        row = family.failure_row(found, move, problem.axes)
        if row is not None:
            problem.cell_rows.setdefault(move.n_steps, []).append(row)
    return failed


def _rejected(n_steps, value, rounds, start, reason, stats) -> Attempt:
    return Attempt(
        n_steps, False, None, {}, value, rounds, time.perf_counter() - start, reason, stats
    )


def attempt(
    problem: Problem, solver: Subsolver, n_steps: int, warm: np.ndarray, gate=None
) -> Attempt:
    """Is there a certified move of ``n_steps`` steps? (module docstring). With a turn,
    each of its schedules for n steps in order (optim.turn.TurnSchedule) until one is.
    ``gate``: a test run once the first LP has a solution, before any scan (the necessary
    test of :func:`_below`); where it returns False the length is rejected."""
    turn = problem.turn
    if turn is None:
        return _straight_attempt(problem, solver, n_steps, warm, gate)
    start = time.perf_counter()
    found = _rejected(n_steps, np.inf, 0, start, "the turn does not fit in the move", [])
    for variant in turn.variants(n_steps):
        turn.variant = variant
        problem.cell_rows = turn.cell_rows()  # the cell's rows hold for their schedule only
        found = _attempt(problem, solver, n_steps, warm, gate)
        if found.feasible:
            found.turn_acc = turn.angular_acc(n_steps)
            break
    return found


def _straight_attempt(
    problem: Problem, solver: Subsolver, n: int, warm: np.ndarray, gate=None
) -> Attempt:
    """The test of :func:`attempt` for a straight move, with the cell's rows seeded from the
    nearest certified length (:meth:`Problem.seed`). A length whose LP has no solution
    without any separating plane is proven too short (``problem.excluded``)."""
    problem.seed(n)
    found = _attempt(problem, solver, n, warm, gate)
    if found.feasible:
        problem.certified.add(n)
        problem.certified_moves[n] = found.acc
    elif found.reason in PROOFS and not problem.restricted(n) and n not in problem.certified:
        problem.excluded.add(n)
    return found


def necessary(problem: Problem, solver: Subsolver, n_steps: int, warm: np.ndarray) -> bool:
    """The cheap necessary test of a length: one LP with every row a move of ``n_steps``
    steps must meet (limits, via points at their fractions, the pooled cuts of the residual
    vibration and of the loads) and none of the separating planes; with a turn, one per
    schedule the turn has for that length (none: the turn does not fit). False (and the
    length recorded as proven too short) where none has a solution."""
    if n_steps in problem.excluded:
        return False
    if n_steps in problem.certified:
        return True
    turn = problem.turn
    if turn is None:
        possible = _necessary(problem, solver, n_steps, warm)
    else:
        variant, pool = turn.variant, problem.cell_rows
        possible = False
        try:
            for schedule in turn.variants(n_steps):
                turn.variant = schedule
                problem.cell_rows = turn.cell_rows()
                possible = _necessary(problem, solver, n_steps, warm)
                if possible:
                    break
        finally:
            turn.variant, problem.cell_rows = variant, pool
    if not possible:
        problem.excluded.add(n_steps)
    return possible


def _necessary(problem: Problem, solver: Subsolver, n_steps: int, warm: np.ndarray) -> bool:
    """:func:`necessary`'s LP with the active rows (with a turn: its active schedule's)."""
    rows = problem.cell_rows.get(n_steps, [])
    problem.cell_rows[n_steps] = [r for r in rows if not r.restriction]
    try:
        sub = solver.solve(problem, n_steps, warm)
    finally:
        problem.cell_rows[n_steps] = rows
    return not (sub.status == "infeasible" or (sub.status == "solved" and sub.value > 1.0 + 1e-7))


def _attempt(
    problem: Problem, solver: Subsolver, n_steps: int, warm: np.ndarray, gate=None
) -> Attempt:
    """One certified-move test of :func:`attempt` (with the turn's active schedule)."""
    start = time.perf_counter()
    stats: list[dict] = []
    value = np.inf
    for rounds in range(1, MAX_ROUNDS + 1):
        check_time(f"the search (a move of {n_steps} steps, round {rounds})")
        sub = solver.solve(problem, n_steps, warm)
        stats.append(sub.stats)
        value = sub.value
        if sub.status != "solved" or sub.value > 1.0 + 1e-7:
            reason = "rows cannot all hold" if sub.status == "solved" else sub.status
            return _rejected(n_steps, value, rounds, start, reason, stats)
        if rounds == 1 and gate is not None and not gate():
            return _rejected(n_steps, value, rounds, start, EXCLUDED, stats)
        acc = sub.acc
        warm = acc
        added = 0
        for i in list(problem.training):
            x_end = problem.end_state(i, acc)
            peaks = problem.scenarios[i].residual.exceedances(
                x_end,
                problem.limit_m,
                max_peaks=PEAKS_PER_ROUND,
            )
            for peak in peaks:
                problem.add_peak(i, peak)
            added += len(peaks)
        if problem.clearance_m is not None:
            peaks = problem.move_map(n_steps).peaks(acc, problem.clearance_limit_m)
            if peaks and not solver.clearance_rows:
                return _rejected(n_steps, value, rounds, start, "clearance cannot be met", stats)
            problem.clearance_pool.setdefault(n_steps, []).extend(peaks)
            added += len(peaks)
        lp_move = as_move(acc, problem.dt_s)  # the LP's answer, checked once for the families
        for family in problem.families:
            rows = family.scan(lp_move, problem.axes)
            problem.cell_rows.setdefault(n_steps, []).extend(rows)
            added += len(rows)
        if added:
            continue
        move = as_move(enforce_end_state(lp_move, problem.distance_m), at_rest=True)
        timings, failures = _certify(problem, move)
        if not failures:
            failures = _certify_families(problem, move)
        if not failures:
            return Attempt(
                n_steps,
                True,
                move.acc,
                timings,
                value,
                rounds,
                time.perf_counter() - start,
                "certified",
                stats,
            )
    return _rejected(n_steps, value, MAX_ROUNDS, start, "row generation did not converge", stats)


def pad_to(acc: np.ndarray, n_steps: int) -> np.ndarray:
    """A move of at most ``n_steps`` steps padded with zero samples to n_steps + 1 samples."""
    return np.vstack([acc, np.zeros((n_steps + 1 - acc.shape[0], 3))])


def _warm_start(moves: list[np.ndarray], n_steps: int) -> np.ndarray:
    """The longest known feasible-kinematics move that fits in ``n_steps``, padded."""
    fitting = [m for m in moves if m.shape[0] <= n_steps + 1]
    return pad_to(max(fitting, key=len), n_steps)


def _tests_left(lo: int, hi: int) -> int:
    """Tests a bisection needs to find the shortest length in (lo, hi] (hi feasible)."""
    return max(0, (hi - lo - 1).bit_length()) if hi > lo + 1 else 0


def bisect(
    problem: Problem,
    solver: Subsolver,
    floor_move: np.ndarray,
    upper_steps: int,
    warm_moves: list[np.ndarray],
    *,
    progress: bool | None = None,
    start_steps: int | None = None,
    lowest_steps: int | None = None,
) -> tuple[Attempt | None, list[Attempt]]:
    """Fewest steps n with a certified move. ``floor_move`` is the kinematic floor (no move
    is shorter); ``upper_steps`` is a length known to be feasible in principle (a baseline
    padded to its cycle time). The search gallops upwards from the floor (or from
    ``start_steps``: a shorter problem's answer) in steps of 4 %, doubling, until a length is
    feasible, then bisects: optima usually lie near the floor, and short moves make small
    LPs. ``warm_moves`` (kinematically feasible moves, e.g. the baselines) seed the
    subproblems. ``lowest_steps``: no shorter length is tested (a smaller problem's
    answer, whose search tried the shorter ones). Returns (best attempt or None, every
    attempt)."""
    history: list[Attempt] = []
    floor_steps = floor_move.shape[0] - 1
    moves = [floor_move, *warm_moves]
    cap = min(max(upper_steps, floor_steps), problem.max_steps)
    lowest = floor_steps if lowest_steps is None else min(max(lowest_steps, floor_steps), cap)
    first = lowest if start_steps is None else min(max(start_steps, lowest), cap)
    lo, n, stride = lowest - 1, first, max(1, int(np.ceil(0.04 * floor_steps)))
    best: Attempt | None = None
    bar = progress_bar(
        max(1, _tests_left(lo, cap)), f"{solver.name}: shortest move", progress, "test"
    )

    def test(n_steps: int, gate=None) -> Attempt:
        result = attempt(problem, solver, n_steps, _warm_start(moves, n_steps), gate)
        history.append(result)
        if result.feasible:
            moves.append(result.acc)
        low = lo if result.feasible else n_steps
        high = n_steps if result.feasible else (best.n_steps if best is not None else cap)
        bar.total = bar.n + 1 + _tests_left(low, high)  # what bisecting the bracket takes
        bar.update(1)
        bar.set_postfix_str(
            f"n = {n_steps} {'ok' if result.feasible else 'too short'}; "
            f"shortest in ({low}, {high}] steps"
        )
        return result

    try:
        while best is None:
            result = test(n)
            if result.feasible:
                best = result
            elif n >= problem.max_steps:
                return None, history
            elif n == cap and result.reason in SOLVER_FAILURES:
                raise RuntimeError(
                    f"{solver.name}: the subproblem failed ({result.reason}) at n = {n}, a "
                    "length a baseline shows to be feasible; see solver_stats"
                )
            else:
                lo, n = n, n + stride
                stride *= 2
                if lo < cap < n:
                    n = cap
                n = min(n, problem.max_steps)
        hi = best.n_steps
        while hi - lo > 1:
            mid = (lo + hi) // 2
            result = test(mid)
            if result.feasible:
                best, hi = result, mid
            else:
                lo = mid
        if any(problem.restricted(n) for n in problem.cell_rows):
            best = _below(problem, solver, best, (lowest, moves), test)
    finally:
        bar.close()
    return best, history


def _below(problem: Problem, solver: Subsolver, best: Attempt, start, test) -> Attempt:
    """Where separating planes took part, a length the bisection declared too short is no
    proof (the planes are a restriction, and feasibility need not be monotone): every length
    from the answer down to the kinematic floor that has not been tried with the rows of the
    current answer is tested again with them (:func:`attempt` seeds it from the nearest
    certified length, the answer), unless the necessary test (:func:`necessary`) excludes
    it. The test's first LP comes first: where it has no solution the length is done (tried
    with the answer's rows) at the cost of one LP, and only where it has one does the
    necessary test run, before any scan (on the press scene with the stress limited, the
    planes, not the loads, rule the shorter lengths out: the necessary test never excluded
    one). ``start``: (the kinematic floor's steps, the moves that seed the subproblems).
    Returns the shortest certified attempt."""
    floor_steps, moves = start
    for n in range(best.n_steps - 1, floor_steps - 1, -1):
        if problem.seeded.get(n) == best.n_steps or n in problem.excluded:
            continue
        warm = _warm_start(moves, n)
        result = test(n, lambda n=n, warm=warm: necessary(problem, solver, n, warm))
        if result.feasible:
            best = result
    return best
