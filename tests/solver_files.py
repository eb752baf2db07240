"""Writers of other solvers' result files, for the --from-modes tests: a Nastran OP2 (LAMA,
OUGV1/BOUGV1, GEOM1 GRID, MPFACS) and a punch file, written from the numbers of a known
model as the formats define them (fem.op2, fem.punch describe the layouts; these writers
share no code with the readers)."""

from __future__ import annotations

import struct

import numpy as np


class _Op2Writer:
    def __init__(self, word: int) -> None:
        self.word, self.parts = word, []
        self.int = "<i" if word == 4 else "<q"
        self.real = "<f" if word == 4 else "<d"

    def block(self, data: bytes) -> None:
        self.parts.append(struct.pack("<i", len(data)) + data + struct.pack("<i", len(data)))

    def marker(self, *values: int) -> None:
        for value in values:
            self.block(struct.pack(self.int, value))

    def record(self, data: bytes) -> None:
        self.marker(len(data) // self.word)
        self.block(data)

    def text(self, name: str) -> bytes:
        chars = name.ljust(8).encode()
        if self.word == 4:
            return chars
        return chars[:4] + b"    " + chars[4:8] + b"    "

    def words(self, values, kinds: str) -> bytes:
        return b"".join(
            struct.pack(self.int if k == "i" else self.real, v)
            for v, k in zip(values, kinds, strict=True)
        )

    def table(self, name: str, trailer, records) -> None:
        self.record(self.text(name))
        self.marker(-1)
        self.record(self.words(trailer, "i" * 7))
        self.marker(-2, 1, 0)
        self.record(self.text(name))
        self.marker(-3, 1, 0)
        for k, strings in enumerate(records):
            for data in strings:
                self.record(data)
            self.marker(-4 - k, 1, 0)
        self.marker(0)


def write_op2(
    path,
    freq_hz,
    node_ids,
    nodes,
    shapes,
    *,
    generalized_mass=None,
    gamma=None,
    word: int = 8,
    table: str = "OUGV1",
) -> None:
    """An OP2 of real modes: shapes (N, 3, M) (rotations written as zeros), freq_hz (M,),
    nodes (N, 3) in the basic system, generalized_mass (M,) (default 1), gamma (M, 3) as
    MPFACS (Nastran's phi^T M R / generalized mass; rotations 0) or None."""
    out = _Op2Writer(word)
    n_modes = len(freq_hz)
    mass = np.ones(n_modes) if generalized_mass is None else np.asarray(generalized_mass)
    out.marker(3)
    out.block(struct.pack("<3i", 11, 26, 26))
    out.marker(7)
    out.block(b"NASTRAN FORT TAPE ID CODE - ".ljust(7 * out.word))
    out.record(out.text("XXXXXXXX"))
    out.marker(-1, 0)
    grids = b"".join(
        out.words([int(n), 0, *map(float, p), 0, 0, 0], "iifffiii")
        for n, p in zip(node_ids, nodes, strict=True)
    )
    out.table("GEOM1", (101, 0, 0, 8, 0, 0, 0), [[out.words([4501, 45, 1], "iii") + grids]])
    omega = 2 * np.pi * np.asarray(freq_hz)
    lama = b"".join(
        out.words([i + 1, i + 1, w**2, w, f, m, m * w**2], "iifffff")
        for i, (w, f, m) in enumerate(zip(omega, freq_hz, mass, strict=True))
    )
    header = [0] * 146
    out.table("LAMA", (101, 10, 0, 0, 0, 0, 0), [[out.words(header, "i" * 146)], [lama]])
    records = []
    for j in range(n_modes):
        head = [21, 7, 0, 1, j + 1, 0, 0, 0, 1, 8] + [0] * 136
        kinds = "iiiiifiiii" + "i" * 136
        head[5] = float(omega[j] ** 2)
        rows = b"".join(
            out.words([int(n) * 10 + 1, 1, *map(float, shapes[i, :, j]), 0.0, 0.0, 0.0], "iiffffff")
            for i, n in enumerate(node_ids)
        )
        records += [[out.words(head, kinds)], [rows]]
    out.table(table, (101, 0, 0, 0, 0, 0, 0), records)
    if gamma is not None:
        columns = [
            [out.words([1], "i") + struct.pack(f"<{3}d", *map(float, gamma[j]))]
            for j in range(n_modes)
        ]
        out.table("MPFACS", (101, n_modes, 6, 2, 2, 0, 0), columns)
    with open(path, "wb") as handle:
        handle.write(b"".join(out.parts))


def write_punch(path, freq_hz, node_ids, shapes, digits: int = 11) -> None:
    """A punch file of real eigenvectors (translations; rotations 0), E fields of 18
    columns with ``digits`` significant digits."""
    lines = []

    def field(value: float) -> str:
        return f"{value:18.{digits - 1}E}"

    for j, f in enumerate(freq_hz):
        eigenvalue = (2 * np.pi * f) ** 2
        lines += [
            "$TITLE   = PLATE",
            "$SUBTITLE=",
            "$LABEL   =",
            "$EIGENVECTOR",
            "$REAL OUTPUT",
            "$SUBCASE ID =           1",
            f"$EIGENVALUE = {eigenvalue:18.{digits - 1}E}  MODE = {j + 1:5d}",
        ]
        for i, n in enumerate(node_ids):
            t = "".join(field(v) for v in shapes[i, :, j])
            lines.append(f"{int(n):10d}{'G':>8s}{t}")
            lines.append(f"{'-CONT-':18s}{field(0.0) * 3}")
    numbered = [f"{line:72s}{k + 1:8d}" for k, line in enumerate(lines)]
    with open(path, "w") as handle:
        handle.write("\n".join(numbered) + "\n")
