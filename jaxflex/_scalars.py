"""Scalar inputs checked without JAX or NumPy: the budget's readers (jaxflex._budget) run
where importing JAX would cost more than the work, and every other check shares them
through jaxflex._validation."""

from __future__ import annotations

import math
from typing import Any

from jaxflex.errors import InputError


def check_positive(name: str, value: Any) -> float:
    """A finite scalar > 0, returned as float; InputError naming ``name`` otherwise."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: must be a number > 0, got {value!r}") from exc
    if not math.isfinite(x) or x <= 0:
        raise InputError(f"{name}: must be a finite number > 0, got {value!r}")
    return x
