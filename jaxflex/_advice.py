"""Input that is allowed but probably not meant: a threshold in millimetres given as metres,
or finer than the model resolves. Each advice is a (kind, message) pair: callers issue it
as a jaxflex.errors.JaxflexWarning (:func:`issue`; the command line prints it as
``jaxflex COMMAND: warning: ...``) and keep it in their reports, and a sweep counts the
cases that got the same kind.
"""

from __future__ import annotations

import warnings

import numpy as np

from jaxflex.errors import JaxflexWarning
from jaxflex.model import ModalModel

# Relative accuracy of a model's deviation when its file does not say: the reduced model
# against the full-order FE transient (docs/design.md targets: L-inf <= 0.2 % of the peak;
# the preprint's reduced model reached 0.53 %). A threshold below this share of the peak
# deviation is decided by model error, not by the part.
DEFAULT_RESOLUTION = 1e-3
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


FLOOR_MOVE = (
    "even the fastest move",
    "vibration does not limit the cycle, which is the kinematic floor",
)


def threshold_advice(
    threshold_m: float,
    settle_s: float,
    peak_m: float,
    resolution: float,
    *,
    name: str = "threshold_m",
    move: tuple[str, str] = FLOOR_MOVE,
) -> list[Advice]:
    """Advice on the threshold ``name`` (m) from a move's exact settle time (0: its deviation
    never exceeds the threshold) and its peak deviation during the move (m); ``resolution``:
    the model's relative accuracy (:func:`model_resolution`); ``move``: what the move is and
    what a threshold above its deviation means (default: the kinematic floor's)."""
    what, consequence = move
    unit = "Thresholds are in metres: 0.5 mm is 0.0005"
    if settle_s == 0.0:
        return [
            (
                "threshold_above_peak",
                f"{name} = {threshold_m:g} m ({threshold_m * 1e3:g} mm) is above the deviation "
                f"of {what} (peak {peak_m * 1e3:.3g} mm): {consequence}. {unit}",
            )
        ]
    if threshold_m < resolution * peak_m:
        return [
            (
                "threshold_below_resolution",
                f"{name} = {threshold_m:g} m is {threshold_m / peak_m:.1e} of the peak deviation "
                f"of {what} ({peak_m * 1e3:.3g} mm), below what the model resolves (about "
                f"{resolution:.1e} of the peak: modal truncation and FE discretisation), so the "
                f"settle time it gives is decided by model error. {unit}",
            )
        ]
    return []


def issue(advice: list[Advice]) -> list[dict]:
    """Issue every message as a JaxflexWarning; returns them as {"kind", "message"}."""
    for _key, message in advice:
        warnings.warn(message, JaxflexWarning, stacklevel=3)
    return [{"kind": key, "message": message} for key, message in advice]
