"""Where each method breaks, on one mode, against omega dt (data of the stability chart).

One mode q'' + 2 zeta w q' + w^2 q = -a(t), dt = 10 ms, w swept so that w dt runs over
``OMEGA_DT``. The reference is scipy.signal.lsim with linear interpolation of the input
(an augmented matrix exponential per step: exact for the piecewise-linear input, and
independent of jaxflex._discretize). Measured per w dt:

* ``error``: max |q - q_ref| / max |q_ref| over ``ERROR_STEPS`` steps (10 periods at the
  smallest w dt) after a hat impulse, for the exact scan (float64, float32), Newmark and
  central difference at the sample step (no substeps): central difference explodes above
  w dt = 2, Newmark's phase error grows like (w dt)^2 / 12 per radian;
* ``settle``: settle time of a damped mode (zeta 5 %) after a short pulse read from the
  deviation at the samples, and jaxflex.analyze_move's, each minus the settle time of the
  response evaluated 64 times finer than dt (s), for w dt >= 0.1 (the decay to 5 % then
  fits in ``SETTLE_STEPS``). Sampling misses peaks between the steps;
* ``drift``: float32 against float64 error of the scan over long horizons (1 Hz undamped
  mode, sine input), against the number of steps.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.signal

from fem.bench.metrics import settle_from_samples
from jaxflex import simulate
from jaxflex.defaults import DT_S
from jaxflex.model import ModalModel
from jaxflex.reference import central_difference_modal, newmark_modal
from jaxflex.response import analyze_move, upsample

OMEGA_DT = tuple(float(x) for x in np.round(np.logspace(-1.5, 1.5, 25), 4))
DRIFT_STEPS = (1_000, 10_000, 100_000)
DENSE_FACTOR = 64
ERROR_STEPS = 2000  # fixed lengths: one compilation per method for the whole sweep
SETTLE_STEPS = 1200
SETTLE_ZETA = 0.05
SETTLE_MIN_OMEGA_DT = 0.1
SETTLE_THRESHOLD_SHARE = 0.05
METHODS = ("scan64", "scan32", "newmark", "central_difference")


def one_mode(freq_hz: float, zeta: float = 0.0) -> ModalModel:
    """A single mode along z at one point, phi = Gamma = 1 (q is the displacement)."""
    shapes = np.zeros((1, 3, 1))
    shapes[0, 2, 0] = 1.0
    return ModalModel(
        freq_hz=[freq_hz], zeta=[zeta], gamma=[[0, 0, 1.0]], shapes=shapes, points=np.zeros((1, 3))
    )


def lsim_reference(freq_hz: float, zeta: float, acc_z: np.ndarray, dt_s: float) -> np.ndarray:
    """q at the samples by scipy.signal.lsim (exact first-order hold): (n+1,)."""
    omega = 2 * np.pi * freq_hz
    system = ([[0.0, 1.0], [-(omega**2), -2 * zeta * omega]], [[0.0], [-1.0]], [[1.0, 0.0]], 0.0)
    t = dt_s * np.arange(len(acc_z))
    return np.asarray(scipy.signal.lsim(system, acc_z, t, interp=True)[1], dtype=float)


def method_errors(omega_dt: float, dt_s: float = DT_S) -> dict[str, float]:
    """Relative max error of each method's q against lsim after a hat impulse."""
    freq = omega_dt / dt_s / (2 * np.pi)
    n = ERROR_STEPS
    acc = np.zeros((n + 1, 3))
    acc[1, 2] = 1.0
    model = one_mode(freq)
    ref = lsim_reference(freq, 0.0, acc[:, 2], dt_s)
    scale = np.abs(ref).max()
    runs = {
        "scan64": simulate(model, acc, dt_s).q,
        "scan32": simulate(model, acc, dt_s, dtype="float32").q,
        "newmark": newmark_modal(model, acc, dt_s),
        "central_difference": central_difference_modal(model, acc, dt_s),
    }
    out = {}
    for name, q in runs.items():
        q = np.asarray(q, dtype=float)[:, 0]
        with np.errstate(invalid="ignore", over="ignore"):
            err = np.abs(q - ref).max() / scale
        out[name] = float(err) if np.isfinite(err) else float("inf")
    return out


def settle_errors(
    omega_dt: float, dt_s: float = DT_S, zeta: float = SETTLE_ZETA
) -> dict[str, float]:
    """Settle-time errors (s) of sampling at the steps and of analyze_move after a 4-step
    triangular pulse, against the response evaluated DENSE_FACTOR times finer."""
    freq = omega_dt / dt_s / (2 * np.pi)
    model = one_mode(freq, zeta)
    n_move = 4
    acc = np.zeros((n_move + 1, 3))
    acc[1:n_move, 2] = [1.0, 2.0, 1.0]
    full = np.concatenate([acc, np.zeros((SETTLE_STEPS, 3))])
    dense = simulate(model, upsample(full, DENSE_FACTOR), dt_s / DENSE_FACTOR).deviation
    dense = np.asarray(dense)
    threshold_m = SETTLE_THRESHOLD_SHARE * dense.max()
    t_dense = dt_s / DENSE_FACTOR * np.arange(len(dense))
    truth = settle_from_samples(t_dense, dense, threshold_m)
    sampled = np.asarray(simulate(model, full, dt_s).deviation)
    t = dt_s * np.arange(len(sampled))
    return {
        "step_sampled": settle_from_samples(t, sampled, threshold_m) - truth,
        "analyze_move": analyze_move(model, acc, dt_s, threshold_m).settle_time_s - truth,
        "dense_resolution_s": dt_s / DENSE_FACTOR,
    }


def float32_drift(steps: Sequence[int] = DRIFT_STEPS, dt_s: float = DT_S) -> dict[int, float]:
    """max |q32 - q64| / max |q64| of an undamped 1 Hz mode under a 0.37 Hz sine input."""
    model = one_mode(1.0)
    out = {}
    for n in steps:
        t = dt_s * np.arange(n + 1)
        acc = np.zeros((n + 1, 3))
        acc[:, 2] = np.sin(2 * np.pi * 0.37 * t)
        q64 = np.asarray(simulate(model, acc, dt_s).q)[:, 0]
        q32 = np.asarray(simulate(model, acc, dt_s, dtype="float32").q, dtype=float)[:, 0]
        out[int(n)] = float(np.abs(q32 - q64).max() / np.abs(q64).max())
    return out


def breakdown(omega_dt: Sequence[float], errors: dict[str, list[float]], limit: float) -> dict:
    """Smallest swept omega dt at which each method's error exceeds ``limit`` (None: never)."""
    out = {}
    for name, values in errors.items():
        bad = [w for w, e in zip(omega_dt, values, strict=True) if not e <= limit]
        out[name] = min(bad) if bad else None
    return out


def run_stability(omega_dt: Sequence[float] = OMEGA_DT, drift_steps=DRIFT_STEPS) -> dict:
    """Every sweep of the module docstring as a JSON-ready dict."""
    errors = {m: [] for m in METHODS}
    settle = {"step_sampled": [], "analyze_move": []}
    for w in omega_dt:
        for name, value in method_errors(w).items():
            errors[name].append(value)
        s = settle_errors(w) if w >= SETTLE_MIN_OMEGA_DT else {}
        for name in settle:
            settle[name].append(s.get(name, float("nan")))
    return {
        "dt_s": DT_S,
        "omega_dt": list(omega_dt),
        "error_rel_peak": errors,
        "settle_error_s": settle,
        "float32_drift": {str(k): v for k, v in float32_drift(drift_steps).items()},
        "breaks_at_omega_dt": {
            "error_above_1pct": breakdown(omega_dt, errors, 0.01),
            "error_above_100pct": breakdown(omega_dt, errors, 1.0),
            "settle_error_above_5ms": breakdown(
                omega_dt,
                {k: np.nan_to_num(np.abs(v), nan=0.0).tolist() for k, v in settle.items()},
                0.005,
            ),
        },
    }
