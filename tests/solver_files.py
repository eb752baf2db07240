"""Writers of other solvers' result files, for the --from-modes tests: a Nastran OP2 (LAMA,
OUGV1/BOUGV1, GEOM1 GRID, MPFACS) and a punch file, written from the numbers of a known
model as the formats define them (fem.imports.op2, fem.imports.punch describe the layouts; these
writers share no code with the readers)."""

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
    lama: bool = True,
    cd=None,
    systems=(),
) -> None:
    """An OP2 of real modes: shapes (N, 3, M) (rotations written as zeros) as the table
    holds them (in each grid's system ``cd`` (N,) for OUGV1, default 0), freq_hz (M,),
    nodes (N, 3) in the basic system, generalized_mass (M,) (default 1), gamma (M, 3) as
    MPFACS (Nastran's phi^T M R / generalized mass; rotations 0) or None; ``lama`` False
    writes no LAMA (the eigenvalues only in the eigenvector headers, as some NX/MSC
    PARAM,POST,-1 runs do); ``systems`` CORD2R/CORD2C records (cid, "R" or "C", A, B, C in
    the basic system)."""
    out = _Op2Writer(word)
    n_modes = len(freq_hz)
    mass = np.ones(n_modes) if generalized_mass is None else np.asarray(generalized_mass)
    out.marker(3)
    out.block(struct.pack("<3i", 11, 26, 26))
    out.marker(7)
    out.block(b"NASTRAN FORT TAPE ID CODE - ".ljust(7 * out.word))
    out.record(out.text("XXXXXXXX"))
    out.marker(-1, 0)
    cd = np.zeros(len(node_ids), dtype=int) if cd is None else np.asarray(cd)
    grids = b"".join(
        out.words([int(n), 0, *map(float, p), int(c), 0, 0], "iifffiii")
        for n, p, c in zip(node_ids, nodes, cd, strict=True)
    )
    geometry = [[out.words([4501, 45, 1], "iii") + grids]]
    for kind, key in (("R", (2101, 21, 8, 1)), ("C", (2001, 20, 9, 2))):
        cards = [sys for sys in systems if sys[1] == kind]
        if cards:
            body = b"".join(
                out.words([cid, key[3], 2, 0, *np.concatenate(points)], "iiii" + "f" * 9)
                for cid, _, *points in cards
            )
            geometry.append([out.words(key[:3], "iii") + body])
    out.table("GEOM1", (101, 0, 0, 8, 0, 0, 0), geometry)
    omega = 2 * np.pi * np.asarray(freq_hz)
    lama_rows = b"".join(
        out.words([i + 1, i + 1, w**2, w, f, m, m * w**2], "iifffff")
        for i, (w, f, m) in enumerate(zip(omega, freq_hz, mass, strict=True))
    )
    header = [0] * 146
    if lama:
        records = [[out.words(header, "i" * 146)], [lama_rows]]
        out.table("LAMA", (101, 10, 0, 0, 0, 0, 0), records)
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


def uff_2414_modes(freq_hz, node_ids, values, analysis_type: int = 2) -> str:
    """Datasets 2414 (I-DEAS analysis data at nodes, as Simcenter/NX write modes) of real
    3-DOF displacement vectors ``values`` (N, 3, M), one per mode, with the frequency and a
    unit modal mass in record 13, as the format defines them (E13.5 reals)."""

    def reals(numbers) -> str:
        return "".join(f"{v:13.5E}" for v in numbers)

    blocks = []
    for j, f in enumerate(freq_hz):
        lines = ["    -1", "  2414", f"{j + 1:10d}", f"mode {j + 1}", f"{1:10d}"]
        lines += ["NONE"] * 5
        lines.append("".join(f"{v:10d}" for v in (1, analysis_type, 2, 8, 2, 3)))
        lines.append("".join(f"{v:10d}" for v in (0, 0, 1, 0, 0, j + 1, 0, 0)))
        lines.append("".join(f"{v:10d}" for v in (0, 0)))
        lines.append(reals([0.0, f, 0.0, 1.0, 0.0, 0.0]))
        lines.append(reals([0.0] * 6))
        for n, row in zip(node_ids, values[:, :, j], strict=True):
            lines += [f"{int(n):10d}", reals(row)]
        blocks.append("\n".join([*lines, "    -1"]))
    return "\n".join(blocks) + "\n"


def uff55_mode() -> dict:
    """pyuff's dataset 55 of one real mode (12.5 Hz, unit modal mass) at nodes 1, 2, 3."""
    import pyuff

    return pyuff.prepare_55(
        id1="mode", model_type=1, analysis_type=2, data_ch=2, spec_data_type=8, data_type=2,
        n_data_per_node=3, load_case=1, mode_n=1, freq=12.5, modal_m=1.0, modal_damp_vis=0.0,
        modal_damp_his=0.0, node_nums=np.array([1, 2, 3]), r1=np.array([0.0, 1, 0]),
        r2=np.zeros(3), r3=np.array([1.0, 0, 1]),
    )  # fmt: skip
