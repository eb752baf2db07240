"""The records and tables of a Nastran OP2 file (the binary results of PARAM,POST,-1/-2).

An OP2 file is a Fortran unformatted sequential file: every block is ``[n][n bytes][n]`` with
4-byte lengths; its words are 4 bytes (32-bit files) or 8 bytes (MSC's 64-bit files), in
either byte order. A *marker* is a block holding one word. A *record* is a positive marker
(its length in words) followed by a block, continued by further such pairs while the next
marker is positive. The file starts with an optional header (marker 3: date, the
``NASTRAN FORT TAPE ID CODE``, the version, markers -1 0; absent for PARAM,POST,-2) and
holds a sequence of tables:

    record            table name (2 words), e.g. LAMA, OUGV1, GEOM1S
    marker -1         record: trailer (7 words)
    markers -2 1 0    record: subtable name (2 words, with a date in some files)
    markers -3 1 0    record 3 (146 words: the header of what follows), markers -4 1 0,
                      record 4 (the data), markers -5 1 0, record 5 ... and marker 0
                      (MEFF writes 1 for the third marker of each record but the last)

This module reads that structure (fem.imports.op2_modes interprets the tables). The layout follows
pyNastran's reader (BSD-3-Clause; read for the format, not used: it pins numpy < 2).
"""

from __future__ import annotations

import mmap
import os
from dataclasses import dataclass, field

import numpy as np

from jaxflex.errors import InputError


@dataclass(eq=False)
class Op2Table:
    """One table: ``name`` (e.g. "OUGV1"), ``trailer`` (7 ints), ``subtable`` name, and
    ``records`` 3, 4, 5, ... in order, each as the blocks it was written in (a matrix
    column: one block per string of rows; an empty column: no block)."""

    name: str
    trailer: tuple[int, ...]
    subtable: str
    records: list[list[bytes]] = field(default_factory=list)

    def record(self, index: int) -> bytes:
        """Record ``index`` (0: record 3) as one byte string."""
        return b"".join(self.records[index])


@dataclass(eq=False)
class Op2Contents:
    """The tables of an OP2 file, ``endian`` ("<" or ">"), ``word`` (4 or 8 bytes),
    ``version`` (the header's, "" if none), ``stopped`` (why reading ended early, "" if it
    reached the end)."""

    path: str
    endian: str
    word: int
    version: str
    tables: list[Op2Table]
    stopped: str = ""

    def ints(self, data: bytes) -> np.ndarray:
        return np.frombuffer(data, dtype=f"{self.endian}i{self.word}")

    def floats(self, data: bytes) -> np.ndarray:
        return np.frombuffer(data, dtype=f"{self.endian}f{self.word}")

    def text(self, data: bytes) -> str:
        """Characters of ``data``; 64-bit files hold 4 characters per 8-byte word."""
        if self.word == 8:
            words = np.frombuffer(data, dtype="S8")
            data = b"".join(w[:4] for w in words.tolist())
        return data.decode("latin-1").strip()


class _Reader:
    def __init__(self, buffer, path: str) -> None:
        self.buf, self.path, self.pos = buffer, path, 0
        size = len(buffer)
        if size < 12:
            raise InputError(f"op2: {path!r} is too short for an OP2 file ({size} bytes)")
        for endian in ("<", ">"):
            first = int(np.frombuffer(buffer[:4], dtype=f"{endian}i4")[0])
            if first in (4, 8):
                self.endian, self.word = endian, first
                return
        raise InputError(
            f"op2: {path!r} does not start as a Fortran binary OP2 file (first block of "
            "4 or 8 bytes)"
        )

    def block(self) -> bytes:
        head = self.buf[self.pos : self.pos + 4]
        if len(head) < 4:
            raise EOFError
        (n,) = np.frombuffer(head, dtype=f"{self.endian}i4")
        n = int(n)
        end = self.pos + 4 + n
        if n < 0 or end + 4 > len(self.buf):
            raise ValueError(f"a block of {n} bytes at byte {self.pos} runs past the end")
        (tail,) = np.frombuffer(self.buf[end : end + 4], dtype=f"{self.endian}i4")
        if int(tail) != n:
            raise ValueError(f"block at byte {self.pos}: lengths {n} and {int(tail)} differ")
        data = bytes(self.buf[self.pos + 4 : end])
        self.pos = end + 4
        return data

    def marker(self) -> int:
        data = self.block()
        if len(data) != self.word:
            raise ValueError(f"expected a marker before byte {self.pos}, got {len(data)} bytes")
        return int(np.frombuffer(data, dtype=f"{self.endian}i{self.word}")[0])

    def peek(self) -> int:
        pos = self.pos
        try:
            return self.marker()
        finally:
            self.pos = pos

    def expect(self, *values: int) -> None:
        for value in values:
            got = self.marker()
            if got != value:
                raise ValueError(f"expected marker {value} before byte {self.pos}, got {got}")

    def strings(self) -> list[bytes]:
        """A record as the blocks it was written in (a matrix column: one per string)."""
        parts = []
        while True:
            words = self.marker()
            data = self.block()
            if len(data) not in (words * self.word, (words + 1) * self.word):  # MEFF: + 1
                raise ValueError(
                    f"record before byte {self.pos}: marker says {words} words, block has "
                    f"{len(data)} bytes"
                )
            parts.append(data)
            if self.pos >= len(self.buf) or self.peek() <= 0:
                return parts

    def record(self) -> bytes:
        return b"".join(self.strings())


def read_op2(path: str | os.PathLike) -> Op2Contents:
    """Every table of the OP2 file ``path`` (see the module). A file whose structure breaks
    off keeps the tables read before it, with ``stopped`` saying where and why."""
    path = str(path)
    if not os.path.isfile(path):
        raise InputError(f"op2: file {path!r} does not exist")
    with open(path, "rb") as handle:
        if os.path.getsize(path) == 0:
            raise InputError(f"op2: {path!r} is empty")
        with mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as buffer:
            return _read(_Reader(buffer, path))


def _read(reader: _Reader) -> Op2Contents:
    contents = Op2Contents(reader.path, reader.endian, reader.word, "", [])
    try:
        if reader.peek() == 3:  # PARAM,POST,-1 header
            reader.expect(3)
            reader.block()  # date
            reader.expect(7)
            reader.block()  # NASTRAN FORT TAPE ID CODE -
            contents.version = contents.text(reader.record())
            reader.expect(-1, 0)
    except (ValueError, EOFError) as exc:
        raise InputError(f"op2: {reader.path!r}: not an OP2 header ({exc})") from exc
    while reader.pos < len(reader.buf):
        start = reader.pos
        try:
            if reader.peek() == 0:  # the end of the file's last table
                reader.expect(0)
                continue
            contents.tables.append(_table(reader, contents))
        except EOFError:
            contents.stopped = f"the file ends inside a table starting at byte {start}"
            break
        except ValueError as exc:
            contents.stopped = f"unreadable table at byte {start} ({exc})"
            break
    return contents


def _table(reader: _Reader, contents: Op2Contents) -> Op2Table:
    name = contents.text(reader.record())
    reader.expect(-1)
    trailer = tuple(int(i) for i in contents.ints(reader.record()))
    reader.expect(-2, 1, 0)
    subtable = contents.text(reader.record()[: 2 * reader.word])
    table = Op2Table(name, trailer, subtable)
    reader.expect(-3, 1)
    reader.marker()
    index = -3
    while True:
        following = reader.peek()
        if following == 0:
            reader.expect(0)
            return table
        table.records.append(reader.strings() if following > 0 else [])  # < 0: empty
        index -= 1
        reader.expect(index, 1)
        reader.marker()  # 0, or 1 in some tables (MEFF)
