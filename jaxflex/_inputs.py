"""Input files users give: checked before they are opened, read within bounds.

* Every path is checked to be a regular file (:func:`check_input_file`): a directory, a
  FIFO (which would block the reader forever), a device (/dev/zero: endless) or a socket is
  refused naming what it is, as is a missing or unreadable file.
* Text (settings, CSV tables, decks) must be UTF-8 (:func:`read_text`): a byte that is not
  is refused with its line and column, and a file larger than ``MAX_TEXT_BYTES`` is refused
  before it is read.
* Settings files (cells, sweep specs; TOML or JSON, :func:`read_settings_file`) must not nest
  deeper than ``MAX_NESTING`` (checked on the text, before a recursive parser sees it), and
  integers must fit in 64 bits (a 5 000-digit integer is refused with its place in the
  file, not converted).
"""

from __future__ import annotations

import codecs
import json
import os
import stat
import tomllib
from pathlib import Path
from typing import Any

from jaxflex.errors import InputError

MAX_TEXT_BYTES = 256 * 2**20  # settings, tables and decks larger than this are not text input
MAX_NESTING = 64  # tables and lists within each other
MAX_INTEGER = 2**63  # integers of settings files fit in 64 bits
CHUNK_BYTES = 1 << 20  # text checked in pieces of this size


def file_kind(mode: int) -> str:
    """What a file of ``mode`` (os.stat) is, for messages."""
    kinds = (
        (stat.S_ISREG, "a regular file"),
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISLNK, "a symbolic link"),
    )
    return next((name for test, name in kinds if test(mode)), "not a regular file")


def named(path: str | os.PathLike) -> str:
    """``path`` quoted for a message, with the file it really names where that is not plain
    from the text: a path through ``..`` or a symbolic link gets ``(that is '/abs/path')``."""
    given = os.fspath(path)
    real = os.path.realpath(given)
    if ".." in Path(given).parts or real != os.path.abspath(given):
        return f"{given!r} (that is {real!r})"
    return repr(given)


def check_input_file(field: str, path: str | os.PathLike) -> Path:
    """``path`` as a Path if it is a readable regular file; InputError naming ``field``
    and what the path is otherwise (module docstring; a path through ``..`` or a link is
    named with the file it resolves to)."""
    if str(path) == "":
        raise InputError(f"{field}: an empty path")
    path = Path(path)
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise InputError(f"{field}: file {named(path)} does not exist") from None
    except OSError as exc:
        raise InputError(f"{field}: cannot open {named(path)} ({exc.strerror or exc})") from None
    if not stat.S_ISREG(mode):
        raise InputError(f"{field}: {named(path)} is {file_kind(mode)}, not a file")
    if not os.access(path, os.R_OK):
        raise InputError(f"{field}: cannot read {named(path)} (no permission)")
    return path


def _not_utf8(field: str, path: Path, data: bytes, start: int, line: int) -> InputError:
    """The error for the byte ``data[start]`` that is not UTF-8, on ``line`` + the lines
    before it in ``data``."""
    line += data.count(b"\n", 0, start)
    column = start - (data.rfind(b"\n", 0, start) + 1) + 1
    return InputError(
        f"{field}: {str(path)!r} is not UTF-8 text: byte 0x{data[start]:02x} at line {line}, "
        f"column {column} (a binary file, or text in another encoding: save it as UTF-8)"
    )


def check_text_file(field: str, path: str | os.PathLike) -> Path:
    """``path`` as a Path if it is a readable regular file of UTF-8 text, checked in chunks
    (files of any size: an R1 table may hold gigabytes); InputError naming ``field``, and
    the line and column of the first byte that is not UTF-8, otherwise."""
    path = check_input_file(field, path)
    decoder = codecs.getincrementaldecoder("utf-8")()
    line = 1
    with path.open("rb") as handle:
        while chunk := handle.read(CHUNK_BYTES):
            try:
                decoder.decode(chunk)
            except UnicodeDecodeError as exc:
                raise _not_utf8(field, path, chunk, max(exc.start, 0), line) from None
            line += chunk.count(b"\n")
        try:
            decoder.decode(b"", final=True)
        except UnicodeDecodeError:
            raise InputError(
                f"{field}: {str(path)!r} is not UTF-8 text: it ends inside a character"
            ) from None
    return path


def read_text(field: str, path: str | os.PathLike) -> str:
    """The UTF-8 text of the regular file ``path`` (a byte-order mark dropped); InputError
    naming ``field`` for a path that is no readable file, a file above MAX_TEXT_BYTES or
    bytes that are not UTF-8 (with their line and column)."""
    path = check_input_file(field, path)
    size = path.stat().st_size
    if size > MAX_TEXT_BYTES:
        raise InputError(
            f"{field}: {str(path)!r} holds {size / 1e6:.4g} MB, more than the "
            f"{MAX_TEXT_BYTES / 1e6:.4g} MB a text input may have"
        )
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{field}: cannot read {str(path)!r} ({exc.strerror or exc})") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise _not_utf8(field, path, data, exc.start, 1) from None


def _nesting(text: str) -> tuple[int, int]:
    """(deepest nesting of brackets and braces outside strings, the line where it is) of
    TOML or JSON text; strings in double quotes (with escapes) and single quotes (TOML's
    literal strings) are skipped, as are TOML comments."""
    depth = deepest = 0
    line = where = 1
    quote, i, n = None, 0, len(text)
    while i < n:
        char = text[i]
        if char == "\n":
            line += 1
        if quote is not None:
            if char == "\\" and quote == '"':
                i += 1
            elif char == quote:
                quote = None
        elif char in "\"'":
            quote = char
        elif char == "#":
            end = text.find("\n", i)
            i = n if end < 0 else end - 1
        elif char in "[{":
            depth += 1
            if depth > deepest:
                deepest, where = depth, line
        elif char in "]}":
            depth -= 1
        i += 1
    return deepest, where


def _check_values(field: str, value: Any, where: str) -> None:
    """Refuse integers beyond MAX_INTEGER anywhere in parsed settings (the nesting is bounded
    already)."""
    if isinstance(value, bool):
        return
    if isinstance(value, int) and abs(value) >= MAX_INTEGER:
        raise InputError(
            f"{field}: {where or 'the file'}: an integer of {len(str(abs(value)))} digits; "
            "integers must fit in 64 bits"
        )
    if isinstance(value, dict):
        for key, item in value.items():
            _check_values(field, item, f"{where}.{key}" if where else str(key))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            _check_values(field, item, f"{where}[{index}]")


def read_settings_file(field: str, path: str | os.PathLike) -> dict[str, Any]:
    """The table in a ``.toml`` or ``.json`` file (a cell, a sweep spec); InputError naming
    ``field`` for a path that is no readable file, another suffix, text that is not UTF-8,
    invalid syntax, nesting deeper than MAX_NESTING, integers beyond 64 bits or a top level
    that is not a table."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".json"):
        check_input_file(field, path)
        raise InputError(f"{field}: expected a .toml or .json file, got {path.name!r}")
    text = read_text(field, path)
    deepest, line = _nesting(text)
    if deepest > MAX_NESTING:
        raise InputError(
            f"{field}: {path.name} nests tables and lists {deepest} deep (line {line}); at most "
            f"{MAX_NESTING} levels are read"
        )
    try:
        data = tomllib.loads(text) if suffix == ".toml" else json.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"{field}: {path.name} is not valid {suffix[1:].upper()}: {exc}") from None
    except (ValueError, RecursionError) as exc:  # an integer beyond Python's digit limit
        raise InputError(f"{field}: {path.name} cannot be read: {exc}") from None
    if not isinstance(data, dict):
        raise InputError(f"{field}: {path.name} must hold a table, got {type(data).__name__}")
    _check_values(f"{field}: {path.name}", data, "")
    return data
