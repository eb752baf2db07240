"""A structural pre-check of MAPDL binary files (``.full``, ``.rst``) before
ansys-mapdl-reader's native code reads them.

A MAPDL binary file starts with the standard header, a record of 100 integers (the record's
length word, 100, then a flags word). Its item 27 is the file's length in 4-byte words as
MAPDL wrote it (the file is then padded to whole blocks; items 97-98 hold the same as a
64-bit number for large files). A file shorter than that was cut off: the reader would
follow pointers past its end (read garbage, or crash), so it is refused here with the
lengths. A ``.cdb`` archive is text: a NUL byte in it makes the native reader take garbage
line lengths (a crash or a hang, measured with a NUL in the title), so it is refused. The
archive declares its node block, ``NBLOCK,<fields>,SOLID,<largest node number>,<count>``,
then a format line, one line per node, and ``N,R5.3,LOC, -1,``: a block that holds fewer
lines or lacks its end was cut off (the reader would return fewer nodes). Other damage is
left to the reader, which runs in a child process
(jaxflex.isolated)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from jaxflex.errors import InputError

HEADER_WORDS = 100
SUFFIXES = (".full", ".rst")
_NBLOCK = re.compile(rb"^NBLOCK,[^\n]*", re.MULTILINE | re.IGNORECASE)
_NBLOCK_END = re.compile(rb"^N,R5\.3,LOC,\s*-1", re.MULTILINE | re.IGNORECASE)


def check_mapdl_file(path: Path) -> None:
    """InputError naming ``path`` if it is a ``.full`` or ``.rst`` whose standard header is
    missing or says the file is longer than it is, or a ``.cdb`` whose node block is
    missing or cut off (module docstring); other suffixes pass."""
    if path.suffix.lower() == ".cdb":
        _check_archive(path)
        return
    if path.suffix.lower() not in SUFFIXES:
        return
    size = path.stat().st_size
    words = np.fromfile(path, dtype="<i4", count=HEADER_WORDS + 3)
    if words.size < HEADER_WORDS + 3 or words[0] != HEADER_WORDS:
        raise InputError(
            f"--from-ansys: {str(path)!r}: not a MAPDL {path.suffix.lower()} file: it does not "
            f"start with MAPDL's standard header ({size} bytes)"
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


def _check_archive(path: Path) -> None:
    data = path.read_bytes()
    nul = data.find(b"\x00")
    if nul >= 0:  # the native reader takes NUL as a line's end: garbage lengths, a crash or a hang
        raise InputError(
            f"nodes: the archive {str(path)!r} is damaged or not an archive: it holds a NUL "
            f"byte at offset {nul} (MAPDL writes archives as text)"
        )
    block = _NBLOCK.search(data)
    if block is None:
        raise InputError(f"nodes: the archive {str(path)!r} holds no node block (NBLOCK)")
    end = _NBLOCK_END.search(data, block.end())
    if end is None:
        raise InputError(
            f"nodes: the archive {str(path)!r} is cut off: its node block (NBLOCK) has no end "
            "(N,R5.3,LOC,-1)"
        )
    fields = block.group().decode("ascii", "replace").split(",")
    lines = data[block.end() : end.start()].strip().count(b"\n")  # the format line's aside
    if len(fields) >= 5 and fields[4].strip().isdigit() and lines != int(fields[4]):
        raise InputError(
            f"nodes: the archive {str(path)!r} declares {int(fields[4])} nodes in its node "
            f"block and holds {lines} lines of them"
        )
