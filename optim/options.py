"""The options of ``optim.optimize``, as frozen objects checked when made (light: NumPy and
jaxflex's light checks), so that ``jaxflex optimize`` builds them, and refuses a bad number
or a zero-length move, before it reads the model file or imports JAX.

* :class:`Search`: the method, its solver, the baselines' shaped modes, progress;
* :class:`Constraints`: the cell the part moves in and what the move must keep (the
  clearance, the distance to the cell's obstacles, the cups, the stress);
* :class:`Rotation`: a turn of the part with the move (axis, angle, angular limits, pivot);
* :class:`Budget`: the longest move, the most steps of an LP, the search's memory;
* :class:`RobustSpec`: the robust mode's range of frequency scales and damping ratios and
  its check grid (the models of the grid: optim.robust).

Each refuses a field with an InputError naming it and the command's option that sets it,
what is allowed and what was given (``max_steps (--max-steps): must be an integer >= 2,
got 1``). optim.request.Request checks the rest, what needs the model.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from jaxflex.defaults import MAX_DURATION_S
from jaxflex.errors import InputError
from jaxflex.files import check_positive
from jaxflex.geometry import Cell
from jaxflex.response import grid_values
from optim.defaults import (
    ANGULAR_LIMITS,
    FREQ_SCALE,
    GRADIENT_SOLVERS,
    GRID,
    LP_SOLVERS,
    MAX_SHAPED_MODES,
    MAX_STEPS,
    ZETA,
)

# the option of `jaxflex optimize` that sets each field (named in its errors)
OPTIONS = {
    "distance_m": "--distance",
    "threshold_m": "--threshold",
    "dt_s": "--dt",
    "max_duration_s": "--max-duration",
    "clearance_m": "--clearance",
    "method": "--method",
    "solver": "--solver",
    "min_distance_m": "--min-distance",
    "cup_safety": "--cup-safety",
    "max_stress_pa": "--max-stress",
    "cell": "--cell",
    "max_steps": "--max-steps",
    "max_memory_bytes": "--max-memory",
    "axis": "--rotate AXIS ANGLE_DEG",
    "angle_deg": "--rotate AXIS ANGLE_DEG",
    "angular_limits": "--angular-limits W A J",
    "pivot_m": "--pivot X Y Z",
    "freq_scale": "--freq-scale",
    "zeta": "--zeta",
    "n_freq": "--grid N_FREQ N_ZETA",
    "n_zeta": "--grid N_FREQ N_ZETA",
}
# each method's default solver and the solvers it accepts
METHODS = {"exact": ("highs", LP_SOLVERS), "gradient": ("ipopt", GRADIENT_SOLVERS)}
MOVE_ATOL_M = 1e-12  # axes moving less than this stay at rest (below the 1e-9 m check)


def label(field: str) -> str:
    """``field`` and the command's option that sets it: ``threshold_m (--threshold)``."""
    option = OPTIONS.get(field)
    return field if option is None else f"{field} ({option})"


def check_step(threshold_m, dt_s) -> tuple[float, float]:
    """(threshold_m, dt_s) as floats, each finite and > 0; InputError naming the field."""
    return check_positive(label("threshold_m"), threshold_m), check_positive(label("dt_s"), dt_s)


def _integer(field: str, value: Any, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < least:
        raise InputError(f"{label(field)}: must be an integer >= {least}, got {value!r}")
    return int(value)


def _positive(field: str, value: Any) -> float | None:
    """None, or ``value`` as a finite float > 0 (InputError naming the field otherwise)."""
    return None if value is None else check_positive(label(field), value)


def _three(field: str, value: Any, allowed: str) -> tuple[float, float, float]:
    """``value`` as three finite floats; InputError naming the field otherwise."""
    try:
        numbers = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        numbers = np.full(1, np.nan)
    if numbers.shape != (3,) or not np.isfinite(numbers).all():
        raise InputError(f"{label(field)}: three finite numbers, {allowed}; got {value!r}")
    return tuple(float(v) for v in numbers)  # type: ignore[return-value]


@dataclass(frozen=True)
class Search:
    """How the optimiser searches (``optim.optimize(..., search=Search(...))``).

    method: "exact" (LP feasibility tests; solver "highs" (default), "casadi" (Clp) or
        "casadi-highs") or "gradient" (smooth surrogate; solver "ipopt" (default) or
        "slsqp"); ``solver`` None: the method's default (set when made).
    max_shaped_modes: the most modes a shaped baseline cancels (optim.baselines; >= 0).
    progress: show progress on stderr (True), hide it (False) or follow the process's
        setting (None: shown unless ``jaxflex --quiet``).
    """

    method: str = "exact"
    solver: str | None = None
    max_shaped_modes: int = MAX_SHAPED_MODES
    progress: bool | None = None

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise InputError(f"{label('method')}: one of {sorted(METHODS)}, got {self.method!r}")
        default, allowed = METHODS[self.method]
        solver = default if self.solver is None else self.solver
        if solver not in allowed:
            raise InputError(
                f"{label('solver')}: method {self.method!r} accepts {allowed}, got {solver!r}"
            )
        object.__setattr__(self, "solver", solver)
        modes = _integer("max_shaped_modes", self.max_shaped_modes, 0)
        object.__setattr__(self, "max_shaped_modes", modes)
        if self.progress not in (None, True, False):
            raise InputError(f"progress: True, False or None, got {self.progress!r}")


@dataclass(frozen=True)
class Budget:
    """The search's budgets (optim.budget); a request that cannot fit them is refused
    before any work with a BudgetError that says what it needs.

    max_duration_s: the longest move considered, s (a request that needs more is an error).
    max_steps: the most steps of any move an LP is built for (an integer >= 2).
    max_memory_bytes: the search's memory, bytes; None: the process's budget when the
        optimiser runs (jaxflex.runtime.current_budget).
    """

    max_duration_s: float = MAX_DURATION_S
    max_steps: int = MAX_STEPS
    max_memory_bytes: float | None = None

    def __post_init__(self) -> None:
        duration = check_positive(label("max_duration_s"), self.max_duration_s)
        object.__setattr__(self, "max_duration_s", duration)
        object.__setattr__(self, "max_steps", _integer("max_steps", self.max_steps, 2))
        _positive("max_memory_bytes", self.max_memory_bytes)


@dataclass(frozen=True)
class Constraints:
    """The cell the part moves in and what the move must keep (each None: not asked).

    cell: a jaxflex.geometry.Cell (obstacles, the part's pose, via points, gravity;
        optim.load_cell reads one from a file); the move is then the cell's, from A through
        the via points to B, in cell coordinates (``distance_m`` None or equal).
    clearance_m: the nominal model's deviation during the move stays below this (m, at
        exact samples every dt / 8), e.g. to keep the part clear of a fixture.
    min_distance_m: every monitored point keeps this distance (m) from every obstacle of the
        cell, over the move and the settling (certified; needs a cell with obstacles).
    cup_safety: every cup's utilisation with this safety factor stays <= 1.
    max_stress_pa: the von Mises stress stays below this (Pa; "yield": the material's yield
        strength / 1.5).
    With a robust grid the cell's constraints hold for the nominal model and every model of
    the grid (certified on each). The gradient route takes the clearance only.
    """

    cell: Cell | None = None
    clearance_m: float | None = None
    min_distance_m: float | None = None
    cup_safety: float | None = None
    max_stress_pa: float | str | None = None

    def __post_init__(self) -> None:
        if self.cell is not None and not isinstance(self.cell, Cell):
            raise InputError(
                f"{label('cell')}: a jaxflex.geometry.Cell (optim.load_cell(path)) or None, "
                f"got {type(self.cell).__name__}"
            )
        for field in ("clearance_m", "min_distance_m", "cup_safety"):
            object.__setattr__(self, field, _positive(field, getattr(self, field)))
        if self.min_distance_m is not None and (self.cell is None or not self.cell.obstacles):
            raise InputError(
                f"{label('min_distance_m')}: needs a cell with obstacles (--cell FILE), "
                f"got {'no cell' if self.cell is None else 'a cell without obstacles'}"
            )
        stress = self.max_stress_pa
        if stress is not None and stress != "yield":
            if isinstance(stress, str):
                raise InputError(
                    f"{label('max_stress_pa')}: a stress in Pa or 'yield', got {stress!r}"
                )
            object.__setattr__(self, "max_stress_pa", _positive("max_stress_pa", stress))

    @property
    def has_via(self) -> bool:
        """Whether the cell's path has via points."""
        return bool(getattr(self.cell, "via", ()))

    @property
    def has_cell_limits(self) -> bool:
        """Whether any of the cell's constraints (distance, cups, stress) is asked for."""
        limits = (self.min_distance_m, self.cup_safety, self.max_stress_pa)
        return any(limit is not None for limit in limits)


@dataclass(frozen=True)
class Rotation:
    """A turn of the part with the move (optim.turn), under gravity -9.81 m/s^2 along z
    (with a cell: its axis turned with the part, the cell's gravity).

    axis: "x", "y", "z" or three numbers, not all zero (model frame).
    angle_deg: the angle, degrees (0: no turn, the straight move's turning response).
    angular_limits: (rate rad/s, acceleration rad/s^2, jerk rad/s^3) of the turn, each
        > 0; None: optim.defaults.ANGULAR_LIMITS (3, 20, 200), a typical robot wrist.
    pivot_m: (3,) m, the point (model frame) the axis passes through and whose
        acceleration the move's samples are; None: the origin (the gripper's).
    The model needs its rotation data (jaxflex.model.ModalModel.rotation).
    """

    axis: str | tuple[float, float, float]
    angle_deg: float
    angular_limits: tuple[float, float, float] | None = None
    pivot_m: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        axis = self.axis
        if isinstance(axis, str):
            if axis not in ("x", "y", "z"):
                raise InputError(f"{label('axis')}: 'x', 'y', 'z' or three numbers, got {axis!r}")
        else:
            axis = _three("axis", axis, "not all zero (model frame)")
            if not any(axis):
                raise InputError(f"{label('axis')}: three numbers not all zero, got {axis!r}")
        object.__setattr__(self, "axis", axis)
        object.__setattr__(self, "angle_deg", self._angle())
        limits = ANGULAR_LIMITS if self.angular_limits is None else self.angular_limits
        limits = _three("angular_limits", limits, "rate rad/s, acceleration rad/s^2, jerk rad/s^3")
        for name, value in zip(("rate_rad_s", "acc_rad_s2", "jerk_rad_s3"), limits, strict=True):
            if value <= 0:
                raise InputError(
                    f"{label('angular_limits')}: {name} must be > 0, got {self.angular_limits!r}"
                )
        object.__setattr__(self, "angular_limits", limits)
        pivot = (0.0, 0.0, 0.0) if self.pivot_m is None else self.pivot_m
        object.__setattr__(self, "pivot_m", _three("pivot_m", pivot, "m in the model frame"))

    def _angle(self) -> float:
        try:
            angle = float(self.angle_deg)
        except (TypeError, ValueError):
            angle = float("nan")
        if not np.isfinite(angle):
            raise InputError(
                f"{label('angle_deg')}: a finite number of degrees, got {self.angle_deg!r}"
            )
        if 0.0 < abs(np.radians(angle)) <= MOVE_ATOL_M:
            raise InputError(
                f"{label('angle_deg')}: a turn of {self.angle_deg!r} degrees is below the "
                f"smallest the optimiser resolves ({np.degrees(MOVE_ATOL_M):.2g} degrees, "
                f"{MOVE_ATOL_M:g} rad); give 0 for no turn"
            )
        return angle


def clean_distance(distance_m, name: str = "distance_m") -> np.ndarray:
    """The move as 3 finite values in m, components below MOVE_ATOL_M set to zero; raises
    InputError naming ``name`` otherwise (or for a move of zero length)."""
    try:
        dist = np.array(distance_m, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected 3 numbers (x, y, z) in m, got {distance_m!r}") from exc
    if dist.shape != (3,) or not np.isfinite(dist).all():
        raise InputError(f"{name}: expected 3 finite values (x, y, z) in m, got {distance_m!r}")
    dist[np.abs(dist) <= MOVE_ATOL_M] = 0.0
    if not np.any(dist):
        raise InputError(f"{name}: the move has zero length")
    return dist


@dataclass(frozen=True)
class RobustSpec:
    """Uncertainty range and its check grid.

    freq_scale: (min, max) factor on every natural frequency, 0 < min <= 1 <= max.
    zeta: (min, max) damping ratio for every mode, 0 < min <= max < 1, or None to keep
        the model's damping.
    n_freq, n_zeta: points of the check grid over each range (end points included).
    """

    freq_scale: tuple[float, float] = FREQ_SCALE
    zeta: tuple[float, float] | None = ZETA
    n_freq: int = GRID[0]
    n_zeta: int = GRID[1]

    def __post_init__(self) -> None:
        lo, hi = (float(v) for v in self.freq_scale)
        if not (0 < lo <= 1 <= hi and np.isfinite(hi)):
            raise InputError(
                f"{label('freq_scale')}: expected (min, max) with 0 < min <= 1 <= max, "
                f"got {self.freq_scale}"
            )
        object.__setattr__(self, "freq_scale", (lo, hi))
        if self.zeta is not None:
            zlo, zhi = (float(v) for v in self.zeta)
            if not 0 < zlo <= zhi < 1:
                raise InputError(
                    f"{label('zeta')}: expected (min, max) with 0 < min <= max < 1, "
                    f"got {self.zeta} (undamped modes never settle)"
                )
            object.__setattr__(self, "zeta", (zlo, zhi))
        for name in ("n_freq", "n_zeta"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise InputError(f"{label(name)}: must be an integer >= 1, got {value!r}")
            object.__setattr__(self, name, int(value))

    @property
    def n_scenarios(self) -> int:
        """The number of models on the check grid (what :meth:`grid` lists, without
        building the list)."""
        n_scale = self.n_freq if self.freq_scale[1] > self.freq_scale[0] else 1
        n_zeta = 1 if self.zeta is None or self.zeta[1] <= self.zeta[0] else self.n_zeta
        return n_scale * n_zeta

    def grid(self) -> list[tuple[float, float | None]]:
        """(frequency scale, zeta or None) of every model on the check grid."""
        lo, hi = self.freq_scale
        scales = grid_values(lo, hi, self.n_freq) if hi > lo else [lo]
        if self.zeta is None:
            zetas: list[float | None] = [None]
        else:
            zlo, zhi = self.zeta
            zetas = list(grid_values(zlo, zhi, self.n_zeta)) if zhi > zlo else [zlo]
        return [(s, z) for z in zetas for s in scales]

    def as_dict(self) -> dict:
        return {
            "freq_scale": list(self.freq_scale),
            "zeta": None if self.zeta is None else list(self.zeta),
            "n_freq": self.n_freq,
            "n_zeta": self.n_zeta,
        }

    @classmethod
    def from_dict(cls, data: dict) -> RobustSpec:
        zeta = data.get("zeta")
        return cls(
            tuple(data["freq_scale"]),
            None if zeta is None else tuple(zeta),
            data.get("n_freq", 21),
            data.get("n_zeta", 3),
        )
