"""The preprint's accuracy metrics of a deviation curve against a reference curve.

A deviation curve is d(t) = max_p |u_p(t)| (m) sampled at times t (s). Against a reference
d_ref on the same times:

* R^2 = 1 - sum (d - d_ref)^2 / sum (d_ref - mean d_ref)^2 (dimensionless, 1 is perfect);
* RMSE = sqrt(mean (d - d_ref)^2) in m;
* L-infinity = max |d - d_ref| / max d_ref (relative to the reference peak);
* settle-time error: settle time of d minus that of d_ref (s), both at the same threshold.

Curves sampled more coarsely than the reference are compared in two ways: at their own
samples only (what the preprint does) and "dense", linearly interpolated onto the reference
times, so that peaks a coarse method does not see count as its error.
"""

from __future__ import annotations

import numpy as np

from jaxflex.errors import InputError


def curve_errors(reference_m, estimate_m, peak_m: float | None = None) -> dict[str, float]:
    """R^2, RMSE (m) and L-infinity relative to the reference peak of ``estimate_m`` against
    ``reference_m`` (both (T,) on the same times). ``peak_m``: the peak to divide by (default
    max |reference_m|). Non-finite estimates (a diverged method) give R^2 = -inf and infinite
    errors."""
    ref = np.asarray(reference_m, dtype=float)
    est = np.asarray(estimate_m, dtype=float)
    if ref.shape != est.shape or ref.ndim != 1 or ref.size < 2:
        raise InputError(
            f"curve_errors: need two (T,) curves, T >= 2; got {ref.shape}, {est.shape}"
        )
    peak = float(np.max(np.abs(ref))) if peak_m is None else float(peak_m)
    if not np.all(np.isfinite(est)):
        return {"r2": -np.inf, "rmse_m": np.inf, "linf_rel_peak": np.inf}
    err = est - ref
    spread = float(np.sum((ref - ref.mean()) ** 2))
    with np.errstate(over="ignore"):
        sq = float(np.sum(err**2))
    return {
        "r2": 1.0 - sq / spread if spread > 0 else (1.0 if sq == 0 else -np.inf),
        "rmse_m": float(np.sqrt(sq / err.size)),
        "linf_rel_peak": float(np.max(np.abs(err)) / peak) if peak > 0 else float("inf"),
    }


def settle_from_samples(t_s, deviation_m, threshold_m: float) -> float:
    """Settle time (s) read from a sampled deviation curve the usual way: the last sample
    above ``threshold_m``, then linear interpolation to the crossing with the next sample.
    0 if no sample exceeds it; the last time if the curve ends above it (not settled)."""
    t = np.asarray(t_s, dtype=float)
    d = np.asarray(deviation_m, dtype=float)
    if not np.all(np.isfinite(d)):
        return float("inf")
    above = np.flatnonzero(d > threshold_m)
    if above.size == 0:
        return 0.0
    k = int(above[-1])
    if k == d.size - 1:
        return float(t[-1])
    frac = (d[k] - threshold_m) / (d[k] - d[k + 1])
    return float(t[k] + frac * (t[k + 1] - t[k]))


def on_grid(t_s, deviation_m, t_grid_s) -> np.ndarray:
    """``deviation_m`` sampled at ``t_s`` linearly interpolated onto ``t_grid_s`` (s); the
    grid must lie within [t_s[0], t_s[-1]] (up to 1e-9 s)."""
    t = np.asarray(t_s, dtype=float)
    grid = np.asarray(t_grid_s, dtype=float)
    if grid[0] < t[0] - 1e-9 or grid[-1] > t[-1] + 1e-9:
        raise InputError(
            f"on_grid: grid [{grid[0]}, {grid[-1]}] s lies outside the samples [{t[0]}, {t[-1]}] s"
        )
    return np.interp(grid, t, np.asarray(deviation_m, dtype=float))


def compare(
    t_ref_s, reference_m, t_s, deviation_m, threshold_m: float, settle_ref_s: float
) -> dict[str, float]:
    """Every metric of a method's curve (t_s, deviation_m) against the reference curve
    (t_ref_s, reference_m): errors at the method's own samples (``samples_*``, the reference
    is interpolated there when the grids differ; L-infinity still relative to the peak of the
    whole reference curve), dense errors on the reference grid, and the
    settle-time error (s) of the sampled curve against ``settle_ref_s``."""
    t_ref = np.asarray(t_ref_s, dtype=float)
    ref = np.asarray(reference_m, dtype=float)
    t = np.asarray(t_s, dtype=float)
    d = np.asarray(deviation_m, dtype=float)
    at_samples = curve_errors(on_grid(t_ref, ref, t), d, peak_m=float(np.max(np.abs(ref))))
    dense = curve_errors(
        ref, on_grid(t, d, t_ref) if np.all(np.isfinite(d)) else np.full_like(ref, np.inf)
    )
    settle = settle_from_samples(t, d, threshold_m)
    return {
        **dense,
        **{f"samples_{k}": v for k, v in at_samples.items()},
        "settle_time_s": settle,
        "settle_error_s": settle - settle_ref_s,
    }
