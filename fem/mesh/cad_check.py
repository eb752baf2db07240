"""A structural pre-check of CAD files before OpenCASCADE reads them (jaxflex.isolated's
``precheck``): a file that was cut off is refused at once, with what is missing, instead of
leaving the kernel to read garbage (a truncated BREP kept it busy for minutes without a
word).

* **STEP** (ISO 10303-21) ends with ``END-ISO-10303-21;``;
* **IGES** ends with its terminate section: a line marked ``T`` in column 73;
* **BREP** (OpenCASCADE's text format, ``CASCADE Topology V1``/``V3``) declares its shapes
  (``TShapes N``) and ends with the reference of the top shape (``+1 0``); binary BREP files
  are left to the kernel.

Only the file's tail is read (``TAIL_BYTES``), so the check costs nothing on large files.
"""

from __future__ import annotations

import re
from pathlib import Path

from jaxflex.errors import InputError

TAIL_BYTES = 4096
_SHAPE_REFERENCE = re.compile(rb"[+-]\d+\s+\d+\s*$")


def _tail(path: Path) -> bytes:
    with open(path, "rb") as handle:
        handle.seek(0, 2)
        size = handle.tell()
        handle.seek(max(0, size - TAIL_BYTES))
        return handle.read()


def _head(path: Path, count: int = 256) -> bytes:
    with open(path, "rb") as handle:
        return handle.read(count)


def check_cad_file(path: Path) -> None:
    """Refuse a STEP, IGES or BREP file that was cut off (module docstring)."""
    suffix = path.suffix.lower()
    tail = _tail(path).rstrip()
    name = repr(str(path))
    if suffix in (".step", ".stp"):
        if not tail.upper().endswith(b"END-ISO-10303-21;"):
            raise InputError(
                f"cad: {name} is cut off: a STEP file ends with END-ISO-10303-21; (its last "
                f"bytes: {tail[-40:].decode('latin-1')!r})"
            )
    elif suffix in (".iges", ".igs"):
        last = tail.splitlines()[-1] if tail else b""
        if last[72:73] != b"T":
            raise InputError(
                f"cad: {name} is cut off: an IGES file ends with its terminate section (a line "
                "marked T in column 73)"
            )
    elif suffix == ".brep" and b"CASCADE Topology" in _head(path):
        last = tail.splitlines()[-1] if tail else b""
        if not _SHAPE_REFERENCE.fullmatch(last.strip()):
            raise InputError(
                f"cad: {name} is cut off: a BREP file ends with the reference of its shape "
                f"after the TShapes section (its last line: {last[-40:].decode('latin-1')!r})"
            )
