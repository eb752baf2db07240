"""A structural pre-check of MAPDL binary files (``.full``, ``.rst``) before
ansys-mapdl-reader's native code reads them.

A MAPDL binary file starts with the standard header, a record of 100 integers (the record's
length word, 100, then a flags word). Its item 27 is the file's length in 4-byte words as
MAPDL wrote it (the file is then padded to whole blocks; items 97-98 hold the same as a
64-bit number for large files). A file shorter than that was cut off: the reader would
follow pointers past its end (read garbage, or crash), so it is refused here with the
lengths. Other damage is left to the reader, which runs in a child process
(jaxflex.isolated)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jaxflex.errors import InputError

HEADER_WORDS = 100
SUFFIXES = (".full", ".rst")


def check_mapdl_file(path: Path) -> None:
    """InputError naming ``path`` if it is a ``.full`` or ``.rst`` whose standard header is
    missing or says the file is longer than it is (module docstring); other suffixes pass."""
    if path.suffix.lower() not in SUFFIXES:
        return
    size = path.stat().st_size
    words = np.fromfile(path, dtype="<i4", count=HEADER_WORDS + 3)
    if words.size < HEADER_WORDS + 3 or words[0] != HEADER_WORDS:
        raise InputError(
            f"--from-ansys: {str(path)!r} is not a MAPDL binary file: it does not start with "
            f"MAPDL's standard header ({size} bytes)"
        )
    # item i is word i + 1 (after the record's length and flags): item 27, and items 97-98 as
    # one 64-bit number (low word first)
    unsigned = words.view("<u4")
    length = max(int(words[28]), int(unsigned[98]) | (int(unsigned[99]) << 32))
    if 4 * length > size:
        raise InputError(
            f"--from-ansys: {str(path)!r} is cut off: its header says {4 * length} bytes, the "
            f"file has {size}"
        )
