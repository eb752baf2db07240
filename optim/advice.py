"""Input that is allowed but probably not meant, caught before or after the work: a threshold
in millimetres given as metres, a threshold finer than the model resolves, a robust check
grid that checks one model. ``optim.optimize`` puts every message on its result (report
``warnings``) and issues it as a jaxflex.errors.JaxflexWarning, which the command line prints
as ``jaxflex optimize: warning: ...``.

Each advice is a (key, message) pair; the key names the kind, so that a sweep can count the
cases that got the same advice.
"""

from __future__ import annotations

import warnings

import numpy as np

from jaxflex.errors import JaxflexWarning
from jaxflex.model import ModalModel
from optim.robust import RobustSpec

# Relative accuracy of a model's deviation when its file does not say: the reduced model
# against the full-order FE transient (docs/design.md targets: L-inf <= 0.2 % of the peak;
# the preprint's reduced model reached 0.53 %). A threshold below this share of the peak
# deviation is decided by model error, not by the part.
DEFAULT_RESOLUTION = 1e-3
# Fewest check-grid points over a range with width: the cycle time jumps with the frequency
# scale (a peak crosses the threshold), so its range needs its ends and its middle at least;
# it falls with the damping, so the damping range needs its ends.
MIN_GRID_POINTS = {"n_freq": 3, "n_zeta": 2}

Advice = tuple[str, str]


def model_resolution(model: ModalModel, direction: np.ndarray) -> float:
    """Relative accuracy of the model's deviation for a move along ``direction`` (3,): the
    static deflection the truncated modes leave out (meta of a fem model: effective_mass.
    static_residual_fraction per direction), at least DEFAULT_RESOLUTION."""
    fractions = dict(model.meta).get("effective_mass", {}).get("static_residual_fraction")
    weights = np.abs(np.asarray(direction, dtype=float))
    weights = weights / weights.sum()
    missing = 0.0
    if fractions is not None and len(fractions) == 3:
        missing = sum(w * (f or 0.0) for w, f in zip(weights, fractions, strict=True))
    return max(DEFAULT_RESOLUTION, float(missing))


def threshold_advice(
    threshold_m: float, floor_settle_s: float, floor_peak_m: float, resolution: float
) -> list[Advice]:
    """Advice on the threshold from the fastest move (the kinematic floor): its settle time
    (0: its deviation never exceeds the threshold) and its peak deviation during the move (m);
    ``resolution``: the model's relative accuracy (:func:`model_resolution`)."""
    mm = threshold_m * 1e3
    if floor_settle_s == 0.0:
        return [
            (
                "threshold_above_peak",
                f"threshold_m = {threshold_m:g} m ({mm:g} mm) is above the deviation of even the "
                f"fastest move (peak {floor_peak_m * 1e3:.3g} mm): vibration does not limit the "
                "cycle, which is the kinematic floor. Thresholds are in metres: 0.5 mm is "
                "0.0005",
            )
        ]
    if threshold_m < resolution * floor_peak_m:
        return [
            (
                "threshold_below_resolution",
                f"threshold_m = {threshold_m:g} m is {threshold_m / floor_peak_m:.1e} of the peak "
                f"deviation ({floor_peak_m * 1e3:.3g} mm), below what the model resolves "
                f"(about {resolution:.1e} of the peak: modal truncation and FE discretisation), "
                "so the settle time it gives is decided by model error. Thresholds are in "
                "metres: 0.5 mm is 0.0005",
            )
        ]
    return []


def grid_advice(robust: RobustSpec | None) -> list[Advice]:
    """Advice on a robust check grid with too few points over a range that has width."""
    if robust is None:
        return []
    found = []
    lo, hi = robust.freq_scale
    ranges = [("n_freq", "frequency scale", lo, hi, robust.n_freq)]
    if robust.zeta is not None:
        ranges.append(("n_zeta", "damping ratio", *robust.zeta, robust.n_zeta))
    for name, what, low, high, count in ranges:
        if high > low and count < MIN_GRID_POINTS[name]:
            checked = f"{low:g} only" if count == 1 else f"{low:g} and {high:g} only"
            found.append(
                (
                    "sparse_robust_grid",
                    f"robust {name} = {count}: the {what} range {low:g}-{high:g} is checked at "
                    f"{checked}, so the worst case inside it is not; use at least "
                    f"{MIN_GRID_POINTS[name]} points (default 21 x 3)",
                )
            )
    return found


def issue(advice: list[Advice]) -> list[dict]:
    """Issue every message as a JaxflexWarning; returns them as {"kind", "message"}."""
    for _key, message in advice:
        warnings.warn(message, JaxflexWarning, stacklevel=3)
    return [{"kind": key, "message": message} for key, message in advice]
