"""Output that C libraries print on the process's standard output (file descriptor 1), kept
off it: Clp's log (optim.lp), OpenCASCADE's IGES counts (fem.mesh.cad). Python's own sys.stdout
is flushed first, so nothing printed before is lost or reordered."""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator

__all__ = ["silenced_stdout"]


@contextlib.contextmanager
def silenced_stdout() -> Iterator[None]:
    """File descriptor 1 sent to /dev/null for the duration of the block."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
