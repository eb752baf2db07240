"""Closed-form responses of one damped mode to piecewise-linear forcing (test oracle).

q'' + 2 zeta w q' + w^2 q = f(t), at rest at t = 0. A ramp f = t (from t = 0) gives

    r(t) = (1/w^2) [t - 2 zeta / w
                    + e^{-zeta w t} ((2 zeta / w) cos(wd t) - ((1 - 2 zeta^2) / wd) sin(wd t))]

and any piecewise-linear force with breakpoints t_k is a sum of ramps started at t_k with
the change of slope there. This derivation is independent of jaxflex.discretize.
"""

from __future__ import annotations

import numpy as np


def ramp_response(t, omega: float, zeta: float):
    t = np.asarray(t, dtype=float)
    tp = np.maximum(t, 0.0)
    wd = omega * np.sqrt(1 - zeta**2)
    decay = np.exp(-zeta * omega * tp)
    r = (
        tp
        - 2 * zeta / omega
        + decay
        * ((2 * zeta / omega) * np.cos(wd * tp) - ((1 - 2 * zeta**2) / wd) * np.sin(wd * tp))
    ) / omega**2
    return np.where(t > 0, r, 0.0)


def piecewise_linear_response(t, force_samples, dt_s: float, omega: float, zeta: float):
    """Response at times t to a force linear between samples f_k at k dt (f_0 = 0 required,
    constant f_n after the last sample)."""
    f = np.asarray(force_samples, dtype=float)
    assert f[0] == 0.0
    slopes = np.diff(f) / dt_s
    slope_change = np.diff(np.concatenate([[0.0], slopes, [0.0]]))  # at t_0 .. t_n
    out = np.zeros_like(np.asarray(t, dtype=float))
    for k, c in enumerate(slope_change):
        if c != 0.0:
            out += c * ramp_response(np.asarray(t) - k * dt_s, omega, zeta)
    return out


def step_response(t, omega: float, zeta: float):
    """Response to a unit force switched on at t = 0."""
    t = np.asarray(t, dtype=float)
    wd = omega * np.sqrt(1 - zeta**2)
    s = zeta * omega
    return np.where(
        t >= 0, (1 - np.exp(-s * t) * (np.cos(wd * t) + s / wd * np.sin(wd * t))) / omega**2, 0.0
    )
