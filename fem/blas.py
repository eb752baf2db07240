"""Run a block with single-threaded OpenBLAS.

ARPACK's reverse-communication loop does many small vector operations; with OpenBLAS's
thread pool on 2 cores they cost ~10x more than single-threaded (measured: eigsh 1.15 s ->
0.13 s on an 18k-DOF plate). This sets the thread count of the OpenBLAS libraries loaded by
numpy/scipy through their C API (what threadpoolctl does); a no-op where none is found.
"""

from __future__ import annotations

import contextlib
import ctypes
import sys
from collections.abc import Iterator


def _openblas_handles() -> list[tuple[object, object]]:
    if not sys.platform.startswith("linux"):
        return []
    try:
        with open("/proc/self/maps") as maps:
            paths = {line.split()[-1] for line in maps if "openblas" in line.lower()}
    except OSError:
        return []
    handles = []
    for path in sorted(paths):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for prefix, suffix in (("scipy_openblas", "64_"), ("scipy_openblas", ""), ("openblas", "")):
            setter = getattr(lib, f"{prefix}_set_num_threads{suffix}", None)
            getter = getattr(lib, f"{prefix}_get_num_threads{suffix}", None)
            if setter is not None and getter is not None:
                getter.restype = ctypes.c_int
                handles.append((setter, getter))
                break
    return handles


@contextlib.contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Context in which the loaded OpenBLAS libraries use one thread."""
    handles = _openblas_handles()
    previous = [getter() for _, getter in handles]
    try:
        for setter, _ in handles:
            setter(1)
        yield
    finally:
        for (setter, _), n in zip(handles, previous, strict=True):
            setter(n)
