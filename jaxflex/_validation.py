"""Checks of user input at the public entry points (skipped for traced values under jit/vmap)."""

from __future__ import annotations

import os
import stat
import sys
import tempfile
import weakref
from pathlib import Path
from typing import Any

import numpy as np

from jaxflex import _undo as undo
from jaxflex._atomic import link_refusal
from jaxflex._inputs import file_kind
from jaxflex.errors import InputError

# the longest file name an output may have: the system's 255 bytes less what its temporary
# name beside it adds (jaxflex._atomic: a dot, the process id, 16 hex digits, a suffix)
MAX_NAME_BYTES = 200


def is_traced(*values: Any) -> bool:
    """True if any value is a JAX tracer (inside jit/grad/vmap), where checks are impossible;
    False without a look when JAX is not loaded (the output checks run before it is)."""
    jax = sys.modules.get("jax")
    if jax is None:
        return False
    return any(isinstance(v, jax.core.Tracer) for v in jax.tree_util.tree_leaves(values))


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


def _check_writable_dir(option: str, path: Path, target: Path) -> None:
    """``path`` (the directory ``target`` goes into) exists, is a directory and takes a new
    file: probed by creating and removing one, so that a read-only or pseudo file system
    (/proc) is found before any work."""
    if not path.exists():
        raise InputError(
            f"{option}: {str(target)!r} cannot be written: the directory {str(path)!r} does "
            "not exist (jaxflex writes only into existing directories; create it first)"
        )
    if not path.is_dir():
        raise InputError(
            f"{option}: {str(target)!r} cannot be created: {str(path)!r} is a file, not a directory"
        )
    try:
        fd, probe = tempfile.mkstemp(prefix=".jaxflex-probe-", dir=path)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(
            f"{option}: cannot write into {str(path)!r} ({exc.strerror or exc}: no permission, "
            f"a read-only or special file system), so {str(target)!r} cannot be written; "
            "choose another location"
        ) from None


def _output_mode(option: str, path: str | os.PathLike) -> tuple[Path, int | None]:
    """(``path`` as a Path, the mode of what it names, None if nothing): a symbolic link
    (jaxflex never writes through one), an empty path or a name the system refuses (too
    long) is an InputError naming ``option``."""
    if str(path) == "":
        raise InputError(f"{option}: an empty path")
    target = Path(path)
    if len(os.fsencode(target.name)) > MAX_NAME_BYTES:
        raise InputError(
            f"{option}: the name {target.name[:40]!r}... has {len(os.fsencode(target.name))} "
            f"bytes; at most {MAX_NAME_BYTES} (the file is written through a temporary name "
            "beside it)"
        )
    try:
        mode = os.lstat(target).st_mode
    except FileNotFoundError:
        return target, None
    except OSError as exc:
        raise InputError(f"{option}: {str(target)!r}: {exc.strerror or exc}") from None
    if stat.S_ISLNK(mode):
        raise InputError(f"{option}: {str(target)!r} is {link_refusal(target)}")
    return target, mode


def check_output_dir(option: str, path: str | os.PathLike) -> Path:
    """An output directory that can be written, checked before any work: ``path`` is a
    directory (not a link to one), or absent in an existing writable directory (it is
    created there, one level). Raises InputError naming ``option`` otherwise. Nothing is
    created; the directory and everything in it are declared outputs of the command
    (jaxflex._undo: undone if the command fails)."""
    target, mode = _output_mode(option, path)
    if mode is not None and not stat.S_ISDIR(mode):
        raise InputError(
            f"{option}: {str(target)!r} exists and is {file_kind(mode)}, not a directory"
        )
    _check_writable_dir(option, target if mode is not None else target.parent, target)
    undo.declare(target)
    return target


def check_output_file(option: str, path: str | os.PathLike) -> Path:
    """An output file that can be written, checked before any work: ``path`` is absent or a
    regular file (never a symbolic link, which would be written through, nor a directory,
    device, FIFO or socket, which a write would replace), in an existing writable directory.
    Raises InputError naming ``option`` otherwise. Nothing is created; the file is declared
    an output of the command (jaxflex._undo: undone if the command fails)."""
    target, mode = _output_mode(option, path)
    if mode is not None and not stat.S_ISREG(mode):
        kind = file_kind(mode)
        hint = "give a file name" if kind == "a directory" else "only regular files are written"
        raise InputError(f"{option}: {str(target)!r} is {kind}; {hint}")
    _check_writable_dir(option, target.parent.resolve(), target)
    undo.declare(target)
    return target


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
