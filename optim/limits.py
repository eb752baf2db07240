"""Robot limits and the exact check of a profile against them.

Per-axis limits |v_c| <= vmax_c, |a_c| <= amax_c, |jerk_c| <= jmax_c (m/s, m/s^2, m/s^3), and
optionally limits on the Euclidean norms of the path velocity, acceleration and jerk.

The profile is piecewise linear in acceleration (docs/design.md), so jerk is constant on each step
and acceleration is extreme at the samples: those two limits are exact on the samples. The
velocity is piecewise quadratic; it can peak inside a step where the acceleration changes
sign, so the check evaluates that interior extremum (per axis in closed form, and for the
path-speed norm from the roots of d|v|^2/dt, a cubic).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from jaxflex.errors import InputError
from jaxflex.files import check_positive
from jaxflex.response import Move, as_move, axis_limits, integrate

AXES = "xyz"
# A limit counts as broken only beyond this relative excess: float64 round-off of the
# integration is ~1e-15 and the LP solvers run with a 1e-9 feasibility tolerance.
CHECK_RTOL = 1e-9
# End position / velocity tolerance of a returned profile (m, m/s).
END_ATOL = 1e-9


@dataclass(frozen=True)
class Limits:
    """Kinematic limits of the robot, SI units.

    vmax, amax, jmax: per-axis limits (a scalar for all three axes or three values), > 0.
    vpath, apath, jpath: optional limits on |v|, |a|, |jerk| (Euclidean norm over the axes).
    Construction validates every field and raises InputError naming it.
    """

    vmax: np.ndarray
    amax: np.ndarray
    jmax: np.ndarray
    vpath: float | None = None
    apath: float | None = None
    jpath: float | None = None

    def __post_init__(self) -> None:
        for name in ("vmax", "amax", "jmax"):
            try:
                value = axis_limits(name, getattr(self, name))
            except ValueError as exc:
                if isinstance(exc, InputError):
                    raise
                raise InputError(
                    f"{name}: expected one value or three values (x, y, z) > 0, "
                    f"got {getattr(self, name)!r}"
                ) from exc
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        for name in ("vpath", "apath", "jpath"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, check_positive(name, value))

    def has_path_limits(self) -> bool:
        return any(v is not None for v in (self.vpath, self.apath, self.jpath))

    def shrunk(self, margin: float) -> Limits:
        """Every limit reduced by the fraction ``margin`` (a final solve keeps this distance
        from the limits so that solver tolerances cannot break them)."""

        def scale(value):
            return None if value is None else value * (1.0 - margin)

        return Limits(
            scale(self.vmax),
            scale(self.amax),
            scale(self.jmax),
            scale(self.vpath),
            scale(self.apath),
            scale(self.jpath),
        )

    def as_dict(self) -> dict:
        """JSON form: per-axis lists and optional path limits, keys with SI units."""
        return {
            "vmax_m_s": self.vmax.tolist(),
            "amax_m_s2": self.amax.tolist(),
            "jmax_m_s3": self.jmax.tolist(),
            "vpath_m_s": self.vpath,
            "apath_m_s2": self.apath,
            "jpath_m_s3": self.jpath,
        }

    @classmethod
    def from_dict(cls, data: dict) -> Limits:
        return cls(
            data["vmax_m_s"],
            data["amax_m_s2"],
            data["jmax_m_s3"],
            data.get("vpath_m_s"),
            data.get("apath_m_s2"),
            data.get("jpath_m_s3"),
        )


@dataclass(frozen=True)
class Violation:
    """One broken limit or boundary condition: ``value`` against ``limit`` at ``time_s``."""

    quantity: str  # velocity, acceleration, jerk, end position, end velocity, rest
    axis: str  # x, y, z or "path" (norm over the axes)
    time_s: float
    value: float
    limit: float

    @property
    def excess(self) -> float:
        return abs(self.value) - self.limit

    def __str__(self) -> str:
        return (
            f"{self.quantity} {self.axis} = {self.value:.9g} at t = {self.time_s:.4f} s "
            f"exceeds {self.limit:.9g} by {self.excess:.3g}"
        )


@dataclass(frozen=True)
class ConstraintCheck:
    """Result of :func:`check_profile`: every violation, and the peak use of each limit
    (max |value| / limit per quantity and axis, 1.0 = at the limit)."""

    violations: tuple[Violation, ...]
    usage: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return not self.violations

    def as_dict(self) -> dict:
        return {
            "ok": self.ok,
            "violations": [{**asdict(v), "excess": v.excess} for v in self.violations],
            "usage": self.usage,
        }

    def summary(self, limit: int = 5) -> str:
        if self.ok:
            return "all limits and boundary conditions hold"
        lines = [str(v) for v in self.violations[:limit]]
        more = len(self.violations) - limit
        if more > 0:
            lines.append(f"... and {more} more")
        return "; ".join(lines)


def velocity_extrema(acc: np.ndarray, vel: np.ndarray, dt_s: float) -> tuple[np.ndarray, ...]:
    """Interior extrema of the piecewise-quadratic velocity, per step and axis.

    On step k, v(tau) = v_k + a_k tau + (a_{k+1} - a_k) tau^2 / (2 dt) has a stationary point
    where the acceleration crosses zero, tau* = a_k dt / (a_k - a_{k+1}), with value
    v_k + a_k tau* / 2. Returns (value (n, 3), time offset tau* (n, 3), mask (n, 3)) where
    the mask marks steps with an interior extremum (elsewhere value = v_k).
    """
    a0, a1 = acc[:-1], acc[1:]
    crossing = a0 * a1 < 0
    denom = np.where(crossing, a0 - a1, 1.0)
    tau = np.where(crossing, a0 * dt_s / denom, 0.0)
    value = np.where(crossing, vel[:-1] + 0.5 * a0 * tau, vel[:-1])
    return value, tau, crossing


def _path_speed_peaks(acc: np.ndarray, vel: np.ndarray, dt_s: float):
    """Largest |v(t)| inside each step (n,) and its time offset, from the roots of
    d|v|^2/dtau = 2 v(tau) . a(tau), a cubic in tau."""
    a0, a1, v0 = acc[:-1], acc[1:], vel[:-1]
    slope = (a1 - a0) / dt_s
    # v(tau) = v0 + a0 tau + slope tau^2 / 2,  a(tau) = a0 + slope tau
    # v . a = (v0.a0) + (v0.slope + a0.a0) tau + (1.5 a0.slope) tau^2 + (0.5 slope.slope) tau^3
    coeffs = np.stack(
        [
            0.5 * np.sum(slope * slope, axis=1),
            1.5 * np.sum(a0 * slope, axis=1),
            np.sum(v0 * slope + a0 * a0, axis=1),
            np.sum(v0 * a0, axis=1),
        ],
        axis=1,
    )
    best = np.zeros(len(a0))
    best_tau = np.zeros(len(a0))
    for k, c in enumerate(coeffs):
        nz = np.flatnonzero(np.abs(c) > 0)
        if nz.size == 0:
            continue
        roots = np.roots(c[nz[0] :])
        roots = roots[np.abs(roots.imag) < 1e-12].real
        roots = roots[(roots > 0) & (roots < dt_s)]
        if roots.size:
            v = v0[k] + np.outer(roots, a0[k]) + 0.5 * np.outer(roots**2, slope[k])
            speed = np.linalg.norm(v, axis=1)
            i = int(np.argmax(speed))
            best[k], best_tau[k] = speed[i], roots[i]
    return best, best_tau


def check_profile(
    move: Move, limits: Limits, distance_m=None, *, rtol: float = CHECK_RTOL
) -> ConstraintCheck:
    """Check a :class:`~jaxflex.Move` (samples (n+1, 3) m/s^2 and their step, s)
    against ``limits`` and, if ``distance_m`` (3,) is given, the boundary conditions: rest at
    both ends (a_0 = a_n = 0, v_n = 0) and arrival at ``distance_m``. Velocity is checked
    between samples too. Returns every violation with its time and size."""
    move = as_move(move)
    acc, dt_s = move.acc, move.dt_s
    vel, pos = integrate(move)
    n = acc.shape[0] - 1
    t = dt_s * np.arange(n + 1)
    violations: list[Violation] = []
    usage: dict[str, dict[str, float]] = {}

    def collect(quantity, axis, values, times, limit):
        values, times = np.asarray(values), np.asarray(times)
        usage.setdefault(quantity, {})[axis] = (
            float(np.max(np.abs(values)) / limit) if values.size else 0.0
        )
        for i in np.flatnonzero(np.abs(values) > limit * (1.0 + rtol)):
            violations.append(Violation(quantity, axis, float(times[i]), float(values[i]), limit))

    jerk = np.diff(acc, axis=0) / dt_s
    v_mid, tau_mid, _ = velocity_extrema(acc, vel, dt_s)
    for c, axis in enumerate(AXES):
        collect("acceleration", axis, acc[:, c], t, float(limits.amax[c]))
        collect("jerk", axis, jerk[:, c], t[:-1] + 0.5 * dt_s, float(limits.jmax[c]))
        v_all = np.concatenate([vel[:, c], v_mid[:, c]])
        t_all = np.concatenate([t, t[:-1] + tau_mid[:, c]])
        collect("velocity", axis, v_all, t_all, float(limits.vmax[c]))
    if limits.apath is not None:
        collect("acceleration", "path", np.linalg.norm(acc, axis=1), t, limits.apath)
    if limits.jpath is not None:
        collect("jerk", "path", np.linalg.norm(jerk, axis=1), t[:-1] + 0.5 * dt_s, limits.jpath)
    if limits.vpath is not None:
        peaks, tau = _path_speed_peaks(acc, vel, dt_s)
        speeds = np.concatenate([np.linalg.norm(vel, axis=1), peaks])
        collect("velocity", "path", speeds, np.concatenate([t, t[:-1] + tau]), limits.vpath)
    if distance_m is not None:
        dist = np.asarray(distance_m, dtype=np.float64).reshape(3)
        tol = END_ATOL * max(1.0, float(np.max(np.abs(dist))))
        for c, axis in enumerate(AXES):
            for quantity, time_s, value, target, atol in (
                ("rest", 0.0, acc[0, c], 0.0, 0.0),
                ("rest", t[-1], acc[-1, c], 0.0, 0.0),
                ("end velocity", t[-1], vel[-1, c], 0.0, END_ATOL),
                ("end position", t[-1], pos[-1, c], dist[c], tol),
            ):
                if not abs(value - target) <= atol:
                    violations.append(
                        Violation(quantity, axis, float(time_s), float(value - target), atol)
                    )
    violations.sort(key=lambda v: (v.time_s, v.quantity, v.axis))
    return ConstraintCheck(tuple(violations), usage)
