"""Checks of user input at the public entry points (skipped for traced values under jit/vmap)."""

from __future__ import annotations

import json
import math
import os
import tomllib
import weakref
from pathlib import Path
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


def _first_existing(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path.cwd()


def _check_writable_dir(option: str, path: Path, target: Path) -> None:
    if not path.is_dir():
        raise InputError(
            f"{option}: {str(target)!r} cannot be created: {str(path)!r} is a file, not a directory"
        )
    if not os.access(path, os.W_OK | os.X_OK):
        raise InputError(
            f"{option}: cannot write into {str(path)!r} (no permission, or a read-only file "
            f"system), so {str(target)!r} cannot be written; choose another location"
        )


def check_output_dir(option: str, path: str | os.PathLike) -> Path:
    """An output directory that can be written, checked before any work: ``path`` is a
    directory or absent, and it (or the ancestor it will be created in) is writable.
    Raises InputError naming ``option`` otherwise. Nothing is created."""
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise InputError(f"{option}: {str(target)!r} exists and is not a directory")
    _check_writable_dir(option, _first_existing(target), target)
    return target


def check_output_file(option: str, path: str | os.PathLike) -> Path:
    """An output file that can be written, checked before any work: ``path`` is not a
    directory and its directory (or the ancestor it will be created in) is writable.
    Raises InputError naming ``option`` otherwise. Nothing is created."""
    target = Path(path)
    if target.is_dir():
        raise InputError(f"{option}: {str(target)!r} is a directory; give a file name")
    _check_writable_dir(option, _first_existing(target.parent), target)
    return target


def read_settings_file(field: str, path: str | os.PathLike) -> dict[str, Any]:
    """The table in a ``.toml`` or ``.json`` file (a cell, a sweep spec); InputError naming
    ``field`` for a missing file, another suffix, invalid syntax or a top level that is not a
    table."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{field}: no such file {str(path)!r}")
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise InputError(f"{field}: expected a .toml or .json file, got {path.name!r}")
    text = path.read_text(encoding="utf-8")
    try:
        data = tomllib.loads(text) if suffix == ".toml" else json.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"{field}: {path.name} is not valid {suffix[1:].upper()}: {exc}") from exc
    if not isinstance(data, dict):
        raise InputError(f"{field}: {path.name} must hold a table, got {type(data).__name__}")
    return data


# Arrays the package has validated (id -> array; an entry goes with its array): a model
# derived from a validated one (perturbed frequencies or damping: a robust grid derives
# hundreds) shares its arrays, which are then neither copied nor scanned again.
_VALIDATED: weakref.WeakValueDictionary[int, np.ndarray] = weakref.WeakValueDictionary()


def validated(arr: np.ndarray) -> np.ndarray:
    """``arr`` (a checked float64 array) made read-only and remembered as checked."""
    arr.setflags(write=False)
    _VALIDATED[id(arr)] = arr
    return arr


def is_validated(value: Any) -> bool:
    """Whether ``value`` is an array that :func:`validated` returned."""
    return _VALIDATED.get(id(value)) is value
