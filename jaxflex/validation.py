"""Checks of user input at the public entry points (skipped for traced values under jit/vmap)."""

from __future__ import annotations

import math
from typing import Any

import jax
import numpy as np

from jaxflex.errors import InputError


def is_traced(*values: Any) -> bool:
    """True if any value is a JAX tracer (inside jit/grad/vmap), where checks are impossible."""
    return any(isinstance(v, jax.core.Tracer) for v in jax.tree_util.tree_leaves(values))


def check_positive(name: str, value: Any) -> float:
    """A finite scalar > 0, returned as float."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: must be a number > 0, got {value!r}") from exc
    if not math.isfinite(x) or x <= 0:
        raise InputError(f"{name}: must be a finite number > 0, got {value!r}")
    return x


def check_acc(acc: Any, *, name: str = "acc", rest_at_ends: bool = False) -> np.ndarray:
    """Acceleration samples: shape (n+1, 3) with n >= 1, finite; optionally a_0 = a_n = 0."""
    arr = np.asarray(acc)
    if arr.dtype == object or not np.issubdtype(arr.dtype, np.number):
        raise InputError(
            f"{name}: must be a numeric array of shape (n+1, 3), got dtype {arr.dtype}"
        )
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] < 2:
        raise InputError(
            f"{name}: expected acceleration samples of shape (n+1, 3) in m/s^2 with n >= 1 "
            f"(one row per time step t_k = k*dt, columns x, y, z), got shape {arr.shape}"
        )
    finite = np.isfinite(arr)
    if not finite.all():
        k, c = np.argwhere(~finite)[0]
        raise InputError(
            f"{name}: sample {k} (axis {'xyz'[c]}) is {arr[k, c]}; every sample must be finite"
        )
    if rest_at_ends and (np.any(arr[0] != 0) or np.any(arr[-1] != 0)):
        raise InputError(
            f"{name}: a move starts and ends at rest, so the first and last samples must be 0 "
            f"(got a_0 = {arr[0].tolist()}, a_n = {arr[-1].tolist()})"
        )
    return arr
