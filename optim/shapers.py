"""Input shapers for damped modes, a registry of their designers, and their convolution
(multi-mode shaping).

A shaper is a train of impulses (amplitudes A_j > 0 summing to 1, times t_j >= 0). Convolving
a motion with it leaves the distance unchanged and keeps every limit (a convex combination of
delayed copies), and for one damped mode (natural frequency w, damping ratio zeta) leaves the
residual vibration

    V(w) = e^{-zeta w t_N} | sum_j A_j e^{zeta w t_j} e^{i w_d t_j} |,   w_d = w sqrt(1 - zeta^2),

relative to the unshaped motion's (Singer & Seering 1990; Singhose, Seering & Singer 1996).

* ZV:  V(w_n) = 0; two impulses over half a damped period.
* ZVD: V(w_n) = 0 and dV/dw(w_n) = 0; three impulses over a damped period.
* EI:  V(w_n) = Vtol (5 %), dV/dw(w_n) = 0 and V = 0 at two frequencies around w_n; wider
  insensitivity than ZVD for the same length. The damped EI shaper has no closed form; it is
  solved here from those seven conditions (Newton from the undamped closed form
  A = ((1 + V)/4, (1 - V)/2, (1 + V)/4), t = (0, T/2, T)).

``SHAPERS`` maps a name to its designer ``(omega_rad_s, zeta) -> Shaper``; every registered
shaper is tried as a baseline (optim.baselines). A new shaper is one function decorated with
``@register_shaper("NAME")``, here or in the caller's code.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jaxflex.errors import InputError

EI_VTOL = 0.05


@dataclass(frozen=True)
class Shaper:
    """Impulse train: ``amplitudes`` (J,) summing to 1 and ``times_s`` (J,) ascending, s."""

    amplitudes: np.ndarray
    times_s: np.ndarray

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1])

    def residual_vibration(self, omega_rad_s, zeta):
        """V(w) of this shaper for modes of circular frequency ``omega_rad_s`` (array, rad/s)
        and damping ``zeta``."""
        return residual_vibration(self.amplitudes, self.times_s, omega_rad_s, zeta)


ShaperDesigner = Callable[[float, float], Shaper]
SHAPERS: dict[str, ShaperDesigner] = {}


def register_shaper(name: str) -> Callable[[ShaperDesigner], ShaperDesigner]:
    """Decorator: register ``designer(omega_rad_s, zeta) -> Shaper`` under ``name`` (omega in
    rad/s > 0, 0 <= zeta < 1, both checked by :func:`shaper`)."""

    def add(designer: ShaperDesigner) -> ShaperDesigner:
        SHAPERS[name] = designer
        return designer

    return add


def residual_vibration(amplitudes, times, omega, zeta):
    """Relative residual vibration V (module docstring) for circular frequencies ``omega``."""
    omega = np.asarray(omega, dtype=np.float64)[..., None]
    sigma = zeta * omega
    omega_d = omega * np.sqrt(1.0 - zeta**2)
    phasor = amplitudes * np.exp(sigma * (times - times[-1])) * np.exp(1j * omega_d * times)
    return np.abs(phasor.sum(axis=-1))


def _ei_equations(params, zeta, vtol):
    a1, a2, t2, t3, w1, w2 = params
    amps = np.array([a1, a2, 1.0 - a1 - a2])
    times = np.array([0.0, t2, t3])

    def phasor(w):
        sigma, wd = zeta * w, w * np.sqrt(1.0 - zeta**2)
        return np.sum(amps * np.exp(sigma * (times - t3)) * np.exp(1j * wd * times))

    def magnitude(w):
        return abs(phasor(w))

    h = 1e-6
    slope = (magnitude(1.0 + h) - magnitude(1.0 - h)) / (2 * h)
    z1, z2 = phasor(w1), phasor(w2)
    return [magnitude(1.0) - vtol, slope, z1.real, z1.imag, z2.real, z2.imag]


def _newton(equations, params: np.ndarray, args: tuple, iterations: int = 50) -> np.ndarray:
    """A root of the square system ``equations(params, *args)`` near ``params``: Newton steps
    on a forward-difference Jacobian, each halved until the residual's norm falls, stopped
    when none does (the residual's rounding floor; the EI conditions hold a central
    difference, so about 1e-10)."""
    x = np.asarray(params, dtype=np.float64)
    r = np.asarray(equations(x, *args))
    for _ in range(iterations):
        h = np.diag(1e-7 * np.maximum(1.0, np.abs(x)))
        shifted = [np.asarray(equations(x + column, *args)) for column in h]
        jacobian = np.column_stack([(r_j - r) / h[j, j] for j, r_j in enumerate(shifted)])
        step = np.linalg.lstsq(jacobian, -r, rcond=None)[0]
        for scale in 0.5 ** np.arange(12):
            trial = x + scale * step
            r_trial = np.asarray(equations(trial, *args))
            if np.linalg.norm(r_trial) < np.linalg.norm(r):
                break
        else:
            return x
        x, r = trial, r_trial
    return x


@functools.lru_cache(maxsize=64)
def _ei_normalised(zeta: float, vtol: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """EI impulses for w_n = 1 rad/s: Newton's method on the six conditions, continued in
    zeta from the undamped closed form in steps of at most 0.01 (a direct start at
    zeta = 0.02 already fails to converge)."""
    w_zero = np.arccos(-(1 - vtol) / (1 + vtol)) / np.pi
    params = np.array([(1 + vtol) / 4, (1 - vtol) / 2, np.pi, 2 * np.pi, w_zero, 2 - w_zero])
    steps = int(np.ceil(zeta / 0.01))
    for z in np.linspace(0.0, zeta, steps + 1)[1:]:
        params = _newton(_ei_equations, params, (z, vtol))
    residual = np.max(np.abs(_ei_equations(params, zeta, vtol)))
    a1, a2, t2, t3 = params[:4]
    amps = (a1, a2, 1.0 - a1 - a2)
    if residual > 1e-8 or min(amps) <= 0 or not 0 < t2 < t3:
        raise InputError(
            f"zeta: no EI shaper with positive impulses exists for zeta = {zeta} "
            f"(condition residual {residual:.1e}); use ZV or ZVD"
        )
    return amps, (0.0, t2, t3)


def _damped_half_period_s(omega_rad_s: float, zeta: float) -> tuple[float, float]:
    """Half a damped period (s) and the decay K = exp(-zeta pi / sqrt(1 - zeta^2)) over it."""
    root = np.sqrt(1.0 - zeta**2)
    return np.pi / (omega_rad_s * root), np.exp(-zeta * np.pi / root)


@register_shaper("ZV")
def zv_shaper(omega_rad_s: float, zeta: float) -> Shaper:
    """Zero vibration: two impulses over half a damped period."""
    half_period, k = _damped_half_period_s(omega_rad_s, zeta)
    return Shaper(np.array([1.0, k]) / (1.0 + k), np.array([0.0, half_period]))


@register_shaper("ZVD")
def zvd_shaper(omega_rad_s: float, zeta: float) -> Shaper:
    """Zero vibration and derivative: three impulses over a damped period."""
    half_period, k = _damped_half_period_s(omega_rad_s, zeta)
    return Shaper(
        np.array([1.0, 2 * k, k * k]) / (1.0 + k) ** 2,
        np.array([0.0, half_period, 2 * half_period]),
    )


@register_shaper("EI")
def ei_shaper(omega_rad_s: float, zeta: float, *, vtol: float = EI_VTOL) -> Shaper:
    """Extra insensitive with V(w_n) = ``vtol`` (module docstring)."""
    amps, times = _ei_normalised(round(float(zeta), 12), float(vtol))
    return Shaper(np.array(amps), np.array(times) / omega_rad_s)


def shaper(kind: str, omega_rad_s: float, zeta: float, **options) -> Shaper:
    """The ``kind`` shaper (a name in SHAPERS) for a mode of circular frequency
    ``omega_rad_s`` rad/s and damping ratio ``zeta`` (0 <= zeta < 1); ``options`` go to its
    designer (EI: ``vtol``)."""
    if kind not in SHAPERS:
        raise InputError(f"kind: must be one of {list(SHAPERS)}, got {kind!r}")
    if not omega_rad_s > 0:
        raise InputError(f"omega_rad_s: must be > 0, got {omega_rad_s}")
    if not 0 <= zeta < 1:
        raise InputError(f"zeta: must satisfy 0 <= zeta < 1, got {zeta}")
    return SHAPERS[kind](float(omega_rad_s), float(zeta), **options)


def convolve(*shapers: Shaper) -> Shaper:
    """The impulse train of applying several shapers in series (multi-mode shaping)."""
    amps, times = np.ones(1), np.zeros(1)
    for s in shapers:
        amps = np.outer(amps, s.amplitudes).ravel()
        times = np.add.outer(times, s.times_s).ravel()
    order = np.argsort(times, kind="stable")
    return Shaper(amps[order], times[order])
