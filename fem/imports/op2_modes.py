"""Real normal modes from a Nastran OP2 file (SOL 103, PARAM,POST,-1 or -2).

Read from the tables of fem.imports.op2:

* **LAMA** (record 4, 7 words per mode): mode number, extraction order, eigenvalue, radians,
  cycles (Hz), generalized mass, generalized stiffness;
* eigenvectors: **BOUGV1**, **BOPHIG**, **OPHIG** (in the basic system) or **OUGV1**,
  **OUG1** (in the grids' displacement systems): per mode a record 3 of 146 words (approach
  code = 10 x analysis code + device code, table code 7, mode, eigenvalue, format code,
  number of words per grid) and a record 4 with, per grid, (10 x grid id + device code, grid
  type, T1, T2, T3, R1, R2, R3); only real, SORT1 eigenvectors of structural grids (type G)
  are read. Without LAMA (NX and MSC write none with some PARAM,POST,-1 runs) the
  eigenvalues are those of the record-3 headers, and the generalized masses are not stated;
* coordinates and displacement systems (fem.imports.op2_coords): **BGPDT** with **EQEXIN**, or the
  **GEOM1** GRID records placed with the file's coordinate systems (CORD1x, CORD2x);
  eigenvectors of grids with a displacement system CD != 0 are turned to the basic system;
* participation factors: the **MPFACS** matrix (MEFFMASS output: 6 rows T1 ... R3 per mode
  column, phi^T M D / generalized mass).

Complex (CLAMA) and buckling (BLAMA) eigenvalues are no normal modes and are named as such,
as are the results of other analyses (statics, frequency response, transient: the approach
code of their tables).
"""

from __future__ import annotations

import os

import numpy as np

from fem.imports.op2 import Op2Contents, Op2Table, read_op2
from fem.imports.op2_coords import op2_geometry, vectors_to_basic
from fem.imports.solver_modes import SolverModes
from jaxflex.errors import InputError

BASIC_TABLES = ("BOUGV1", "BOPHIG", "OPHIG")  # eigenvectors in the basic system
EIGENVECTOR_TABLES = (*BASIC_TABLES, "OUGV1", "OUG1")  # preferred first: basic system
STRUCTURAL_GRID = 1
RIGID_ROUNDOFF_HZ = 0.01  # |negative eigenvalue| below (2 pi x this)^2: a rigid mode's round-off
ANALYSIS_CODES = {
    1: "statics",
    2: "real eigenvalues",
    3: "differential stiffness",
    5: "frequency response",
    6: "transient",
    7: "pre-buckling",
    8: "buckling",
    9: "complex eigenvalues",
    10: "nonlinear statics",
    11: "geometric nonlinear statics",
}


def _tables(contents: Op2Contents, *names: str) -> list[Op2Table]:
    return [t for t in contents.tables if t.name in names]


def _lama(contents: Op2Contents, path: str) -> dict[int, tuple[float, float, float]]:
    """mode number -> (cycles Hz, generalized mass, eigenvalue (rad/s)^2) from LAMA ({}
    without one)."""
    out: dict[int, tuple[float, float, float]] = {}
    for table in _tables(contents, "LAMA"):
        data = table.record(1)
        words = 7 * contents.word
        if len(data) % words:
            raise InputError(f"op2: {path!r}: LAMA record of {len(data)} bytes is not 7 words/mode")
        for row in range(len(data) // words):
            chunk = data[row * words : (row + 1) * words]
            mode = int(contents.ints(chunk)[0])
            floats = contents.floats(chunk)
            out.setdefault(mode, (float(floats[4]), float(floats[5]), float(floats[2])))
    return out


def _no_modes(contents: Op2Contents, path: str, skipped: list[str]) -> InputError:
    """The refusal of a file without real eigenvectors, naming what it holds instead."""
    others = sorted({t.name for t in _tables(contents, "CLAMA", "BLAMA")})
    kind = {"CLAMA": "complex eigenvalues", "BLAMA": "buckling eigenvalues"}
    held = [f"{n} ({kind[n]})" for n in others] + sorted(set(skipped))
    return InputError(
        f"op2: {path!r} holds no real normal modes (the eigenvectors of a SOL 103 run in "
        f"{', '.join(EIGENVECTOR_TABLES)}, with LAMA or their headers' eigenvalues)"
        + (f"; it holds {'; '.join(held)}" if held else "")
        + "; request them with DISPLACEMENT(PLOT) = ALL and PARAM,POST,-1"
    )


def _eigenvectors(contents: Op2Contents, path: str):
    """(table name, {mode: (node ids, grid types, (n, 6) values, eigenvalue)}, what other
    results were found) of the first eigenvector table with real modes."""
    skipped = []
    for name in EIGENVECTOR_TABLES:
        modes = {}
        for table in _tables(contents, name):
            for k in range(0, len(table.records) - 1, 2):
                head_bytes, data = table.record(k), table.record(k + 1)
                ints = contents.ints(head_bytes)
                if len(ints) < 10:
                    raise InputError(
                        f"op2: {path!r}: {name} holds a record 3 of {len(ints)} words where "
                        "the format has 146 (the file is damaged)"
                    )
                analysis, table_code = int(ints[0]) // 10, int(ints[1]) % 1000
                if analysis != 2 or table_code != 7:
                    what = ANALYSIS_CODES.get(analysis, f"analysis code {analysis}")
                    skipped.append(f"{name} of {what} (table code {table_code})")
                    continue
                sort_code, format_code, width = int(ints[1]) // 1000, int(ints[8]), int(ints[9])
                if sort_code != 0 or format_code != 1 or width != 8:
                    raise InputError(
                        f"op2: {path!r}: {name} holds eigenvectors as sort code {sort_code}, "
                        f"format code {format_code}, {width} words per grid; real SORT1 "
                        "eigenvectors (8 words per grid) are read"
                    )
                values = np.frombuffer(data, dtype=f"{contents.endian}f{contents.word}")
                codes = np.frombuffer(data, dtype=f"{contents.endian}i{contents.word}")
                rows = len(values) // 8
                codes, values = codes[: 8 * rows].reshape(rows, 8), values[: 8 * rows]
                eigenvalue = float(contents.floats(head_bytes)[5])
                modes[int(ints[4])] = (
                    codes[:, 0] // 10,
                    codes[:, 1],
                    values.reshape(rows, 8)[:, 2:].astype(float),
                    eigenvalue,
                )
        if modes:
            return name, modes, skipped
    raise _no_modes(contents, path, skipped)


def _mpfacs(contents: Op2Contents, mode_count: int) -> np.ndarray | None:
    """(M, 6) participation factors from the MPFACS matrix (one column per mode)."""
    tables = _tables(contents, "MPFACS")
    if not tables:
        return None
    table = tables[0]
    n_rows, kind = table.trailer[2], table.trailer[4]
    dtype = {1: "f4", 2: "f8"}.get(kind)
    if dtype is None or len(table.records) != mode_count:
        return None
    damaged = InputError(
        f"op2: {contents.path!r}: its MPFACS matrix (participation factors, 6 rows T1 ... R3) "
        f"is damaged: {n_rows} rows or columns beyond them"
    )
    if not 3 <= n_rows <= 6:
        raise damaged
    out = np.zeros((mode_count, n_rows))
    for column, strings in enumerate(table.records):
        for string in strings:
            first = int(contents.ints(string[: contents.word])[0])
            values = np.frombuffer(string[contents.word :], dtype=f"{contents.endian}{dtype}")
            if not 1 <= first <= n_rows - values.size + 1:
                raise damaged
            out[column, first - 1 : first - 1 + values.size] = values
    return out


def read_op2_modes(path: str | os.PathLike) -> SolverModes:
    """The real normal modes of an OP2 file (see the module), in file units."""
    path = str(path)
    contents = read_op2(path)
    lama = _lama(contents, path)
    table, vectors, skipped = _eigenvectors(contents, path)
    notes = [f"eigenvectors from {table}"]
    if skipped:
        notes.append(f"other results left out: {'; '.join(sorted(set(skipped)))}")
    mode_ids = np.array(sorted(vectors))
    if lama:
        missing = [int(m) for m in mode_ids if int(m) not in lama]
        if missing:
            raise InputError(
                f"op2: {path!r}: modes {missing[:5]} have eigenvectors but no LAMA entry"
            )
        freq_hz = np.array([lama[int(m)][0] for m in mode_ids])
        mass = np.array([lama[int(m)][1] for m in mode_ids])
        omega2 = np.array([lama[int(m)][2] for m in mode_ids])
        eigenvalues = "LAMA"
    else:  # the eigenvalues (rad/s)^2 of the eigenvector tables' headers
        omega2 = np.array([vectors[int(m)][3] for m in mode_ids])
        if not np.any(omega2):
            raise InputError(
                f"op2: {path!r}: its {table} eigenvectors state no eigenvalues (all 0 in their "
                "headers) and the file has no LAMA table: not the result of a normal modes "
                "analysis (SOL 103)"
            )
        freq_hz, mass = np.sqrt(np.maximum(omega2, 0.0)) / (2 * np.pi), None
        eigenvalues = f"{table} headers"
        notes.append(
            f"no LAMA table: eigenvalues from the {table} record headers, generalized masses "
            "not stated"
        )
    _refuse_negative(omega2, mode_ids, path)
    freq_hz = np.where(omega2 < 0, 0.0, freq_hz)  # a rigid mode's round-off below zero
    node_ids, shapes, extra = _shapes(vectors, mode_ids, path)
    if contents.stopped:
        notes.append(f"reading stopped early: {contents.stopped}")
    if extra:
        notes.append(f"{extra} scalar or extra points left out")
    nodes, nodes_missing, shapes = _geometry(contents, node_ids, shapes, table, path, notes)
    modes = SolverModes(
        kind=f"Nastran OP2 ({contents.version or 'no version stated'}; {eigenvalues}, {table})",
        path=path,
        mode_ids=mode_ids,
        freq_hz=freq_hz,
        node_ids=node_ids,
        shapes=shapes,
        nodes=nodes,
        nodes_missing=nodes_missing,
        generalized_mass=mass,
        notes=notes,
    )
    _participation(modes, contents, sorted(lama) if lama else mode_ids.tolist())
    return modes


def _refuse_negative(omega2: np.ndarray, mode_ids: np.ndarray, path: str) -> None:
    """Negative eigenvalues are a rigid mode's round-off only when they are small: below
    (2 pi 0.01 Hz)^2 or 1e-8 of the largest; larger ones mean a stiffness that is not
    positive (a mechanism with negative springs, a prestress, a wrong model)."""
    limit = max((2 * np.pi * RIGID_ROUNDOFF_HZ) ** 2, 1e-8 * float(np.max(np.abs(omega2))))
    bad = np.flatnonzero(omega2 < -limit)
    if bad.size:
        k = int(bad[0])
        raise InputError(
            f"op2: {path!r}: mode {int(mode_ids[k])} has the eigenvalue {omega2[k]:.6g} "
            f"(rad/s)^2 ({bad.size} negative beyond round-off): the solver's stiffness is not "
            "positive (an unstable or prestressed model); its modes are no normal modes"
        )


def _shapes(vectors: dict, mode_ids: np.ndarray, path: str):
    """(node ids (N,), translations (N, 3, M), count of non-structural points left out)."""
    first = vectors[int(mode_ids[0])]
    keep = first[1] == STRUCTURAL_GRID
    node_ids = first[0][keep]
    shapes = np.zeros((node_ids.size, 3, mode_ids.size))
    for j, mode in enumerate(mode_ids):
        ids, types, values, _ = vectors[int(mode)]
        if not np.array_equal(ids[types == STRUCTURAL_GRID], node_ids):
            raise InputError(
                f"op2: {path!r}: mode {mode} lists other grids than mode {mode_ids[0]}"
            )
        shapes[:, :, j] = values[types == STRUCTURAL_GRID, :3]
    return node_ids, shapes, int((~keep).sum())


def _participation(modes: SolverModes, contents: Op2Contents, all_modes: list[int]) -> None:
    """The MPFACS participation factors of ``modes``, or why there are none."""
    factors = _mpfacs(contents, len(all_modes))
    path = modes.path
    if factors is not None:
        order = {m: i for i, m in enumerate(all_modes)}
        modes.gamma = factors[[order[int(m)] for m in modes.mode_ids], :3]
        modes.gamma_source = "the MPFACS matrix (Nastran MEFFMASS participation factors)"
        return
    effective = sorted({t.name for t in _tables(contents, "MEFF", "MEFMASS", "EFMFACS")})
    modes.gamma_missing = (
        f"{path!r} holds no participation factors (the MPFACS matrix that MEFFMASS writes"
        + (
            f"; its {', '.join(effective)} hold effective masses, which have no sign"
            if effective
            else ""
        )
        + ")"
    )


def _geometry(contents, node_ids, shapes, table: str, path: str, notes: list[str]):
    """(coordinates (N, 3) or None, why not, shapes in the basic system) from the file's
    geometry (fem.imports.op2_coords)."""
    geometry = op2_geometry(contents)
    notes.extend(geometry.notes)
    if table not in BASIC_TABLES:
        if not geometry.cd:
            notes.append(
                f"the file holds no grid geometry: the {table} eigenvectors are taken as given "
                "in the basic system (grids with a displacement system CD != 0 need "
                "PARAM,OUGCORD,BASIC)"
            )
        shapes, turned = vectors_to_basic(geometry, node_ids, shapes, path, table)
        if turned:
            notes.append(
                f"{turned} grid(s) with a displacement system CD != 0: eigenvectors turned to "
                "the basic system with the file's coordinate systems"
            )
    basic = geometry.positions
    if not basic:
        return (
            None,
            (
                f"{path!r} holds no grid geometry (GEOM1 or BGPDT: PARAM,POST,-1 writes it unless "
                "PARAM,OGEOM,NO); pass nodes= (--nodes) with a CSV node,x,y,z in the basic system"
            ),
            shapes,
        )
    missing = [int(n) for n in node_ids if int(n) not in basic]
    if missing:
        return (
            None,
            (
                f"{path!r} gives no basic coordinates for {len(missing)} grid(s), e.g. "
                f"{missing[:5]}; pass nodes= (--nodes) with a CSV node,x,y,z in the basic system"
            ),
            shapes,
        )
    notes.append(f"coordinates from {geometry.source}")
    return np.array([basic[int(n)] for n in node_ids]), "", shapes
