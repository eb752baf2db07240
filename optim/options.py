"""The optimiser's inputs that need no model, checked before anything heavy loads (light:
NumPy and jaxflex's light checks), so that ``jaxflex optimize`` refuses a bad number or a
zero-length move before it reads the model file or imports JAX.

:class:`optim.request.Request` checks every request with these functions; the command calls
them first. Errors name the field and the command's option (``threshold_m (--threshold):
must be a finite number > 0``).
"""

from __future__ import annotations

import numpy as np

from jaxflex.errors import InputError
from jaxflex.files import check_positive

# the option of `jaxflex optimize` that sets each field (named in its errors)
OPTIONS = {
    "distance_m": "--distance",
    "threshold_m": "--threshold",
    "dt_s": "--dt",
    "max_duration_s": "--max-duration",
    "clearance_m": "--clearance",
    "max_steps": "--max-steps",
    "max_memory_bytes": "--max-memory",
    "rotate": "--rotate",
    "angular_limits": "--angular-limits",
    "pivot_m": "--pivot",
}
MOVE_ATOL_M = 1e-12  # axes moving less than this stay at rest (below the 1e-9 m check)


def label(field: str) -> str:
    """``field`` and the command's option that sets it: ``threshold_m (--threshold)``."""
    option = OPTIONS.get(field)
    return field if option is None else f"{field} ({option})"


def check_numbers(
    *, threshold_m, dt_s, max_duration_s, clearance_m=None, max_steps
) -> dict[str, float | int | None]:
    """The request's numbers checked and converted: threshold_m, dt_s, max_duration_s (s) and
    clearance_m (None or m) finite and > 0, max_steps an integer >= 2; InputError naming the
    field otherwise."""
    numbers: dict[str, float | int | None] = {
        field: check_positive(label(field), value)
        for field, value in (
            ("threshold_m", threshold_m),
            ("dt_s", dt_s),
            ("max_duration_s", max_duration_s),
        )
    }
    numbers["clearance_m"] = (
        None if clearance_m is None else check_positive(label("clearance_m"), clearance_m)
    )
    if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 2:
        raise InputError(f"{label('max_steps')}: must be an integer >= 2, got {max_steps!r}")
    numbers["max_steps"] = max_steps
    return numbers


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
