"""Real normal modes from a Nastran OP2 file (SOL 103, PARAM,POST,-1 or -2).

Read from the tables of fem.op2:

* **LAMA** (record 4, 7 words per mode): mode number, extraction order, eigenvalue, radians,
  cycles (Hz), generalized mass, generalized stiffness;
* **OUGV1** or **BOUGV1** (eigenvectors in the grids' displacement systems, or in the basic
  system): per mode a record 3 of 146 words (approach code = 10 x analysis code + device
  code, table code 7, mode, eigenvalue, format code, number of words per grid) and a
  record 4 with, per grid, (10 x grid id + device code, grid type, T1, T2, T3, R1, R2, R3);
  only real, SORT1 eigenvectors of structural grids (type G) are read;
* coordinates: **BGPDT** (basic coordinates per internal grid, with **EQEXIN** for the
  external ids) or, without it, the **GEOM1** GRID records (id, CP, x1, x2, x3, CD, PS,
  SEID) of grids defined in the basic system;
* participation factors: the **MPFACS** matrix (MEFFMASS output: 6 rows T1 ... R3 per mode
  column, phi^T M D / generalized mass).

Eigenvectors in OUGV1 are in each grid's displacement system (CD): grids with CD != 0 are
refused there (PARAM,OUGCORD,BASIC writes BOUGV1 in the basic system, which is read).
Complex (CLAMA) and buckling (BLAMA) eigenvalues are no normal modes and are named as such.
"""

from __future__ import annotations

import os

import numpy as np

from fem.op2 import Op2Contents, Op2Table, read_op2
from fem.solver_modes import SolverModes
from jaxflex.errors import InputError

GRID_KEY = (4501, 45, 1)
EIGENVECTOR_TABLES = ("BOUGV1", "OUGV1")  # preferred first: basic system
STRUCTURAL_GRID = 1


def _tables(contents: Op2Contents, *names: str) -> list[Op2Table]:
    return [t for t in contents.tables if t.name in names]


def _lama(contents: Op2Contents, path: str) -> dict[int, tuple[float, float]]:
    """mode number -> (cycles Hz, generalized mass) from LAMA."""
    tables = _tables(contents, "LAMA")
    if not tables:
        others = sorted({t.name for t in _tables(contents, "CLAMA", "BLAMA")})
        kind = {"CLAMA": "complex eigenvalues", "BLAMA": "buckling eigenvalues"}
        found = "; it holds " + ", ".join(f"{n} ({kind[n]})" for n in others) if others else ""
        raise InputError(
            f"op2: {path!r} holds no real eigenvalue table (LAMA) of a normal modes analysis "
            f"(SOL 103){found}"
        )
    out: dict[int, tuple[float, float]] = {}
    for table in tables:
        data = table.record(1)
        words = 7 * contents.word
        if len(data) % words:
            raise InputError(f"op2: {path!r}: LAMA record of {len(data)} bytes is not 7 words/mode")
        for row in range(len(data) // words):
            chunk = data[row * words : (row + 1) * words]
            mode = int(contents.ints(chunk)[0])
            floats = contents.floats(chunk)
            out.setdefault(mode, (float(floats[4]), float(floats[5])))
    return out


def _eigenvectors(contents: Op2Contents, path: str):
    """(table name, {mode: (node ids, grid types, (n, 6) values)}) of the first eigenvector
    table with real modes."""
    skipped = []
    for name in EIGENVECTOR_TABLES:
        modes = {}
        for table in _tables(contents, name):
            for k in range(0, len(table.records) - 1, 2):
                head_bytes, data = table.record(k), table.record(k + 1)
                ints = contents.ints(head_bytes)
                analysis, table_code = int(ints[0]) // 10, int(ints[1]) % 1000
                if analysis != 2 or table_code != 7:
                    skipped.append(f"{name} analysis code {analysis}, table code {table_code}")
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
                modes[int(ints[4])] = (
                    codes[:, 0] // 10,
                    codes[:, 1],
                    values.reshape(rows, 8)[:, 2:].astype(float),
                )
        if modes:
            return name, modes, skipped
    raise InputError(
        f"op2: {path!r} holds no real eigenvectors (OUGV1 or BOUGV1 of a SOL 103 run); "
        "request them with DISPLACEMENT(PLOT) = ALL and PARAM,POST,-1"
        + (f" (found only: {'; '.join(sorted(set(skipped)))})" if skipped else "")
    )


def _grid_records(contents: Op2Contents) -> np.ndarray | None:
    """(G, 8) GRID entries of GEOM1 as float rows (id, cp, x, y, z, cd, ps, seid; the ints
    converted), or None."""
    rows = []
    for table in _tables(contents, "GEOM1", "GEOM1S"):
        for record in table.records:
            data = b"".join(record)
            ints = contents.ints(data)
            if len(ints) < 3 or tuple(int(i) for i in ints[:3]) != GRID_KEY:
                continue
            body = data[3 * contents.word :]
            count = len(body) // (8 * contents.word)
            i = contents.ints(body)[: 8 * count].reshape(count, 8)
            f = contents.floats(body)[: 8 * count].reshape(count, 8)
            rows.append(np.column_stack([i[:, :2], f[:, 2:5], i[:, 5:]]).astype(float))
    return np.concatenate(rows) if rows else None


def _basic_coordinates(contents: Op2Contents) -> tuple[dict[int, np.ndarray], dict[int, int]]:
    """{external id: basic coordinates (3,)} and {external id: CD} from BGPDT + EQEXIN."""
    bgpdt = _tables(contents, "BGPDT", "BGPDTS")
    eqexin = _tables(contents, "EQEXIN", "EQEXINS")
    if not bgpdt or not eqexin or not bgpdt[0].records:
        return {}, {}
    data = bgpdt[0].record(0)
    ints, floats = contents.ints(data), contents.floats(data)
    if len(ints) % 4:
        return {}, {}
    pairs = contents.ints(eqexin[0].record(0)).reshape(-1, 2)
    rows = len(ints) // 4
    out, cd = {}, {}
    for external, internal in pairs:
        if 1 <= internal <= rows:
            out[int(external)] = floats[4 * (internal - 1) + 1 : 4 * internal].astype(float)
            cd[int(external)] = int(ints[4 * (internal - 1)])
    return out, cd


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
    out = np.zeros((mode_count, n_rows))
    for column, strings in enumerate(table.records):
        for string in strings:
            first = int(contents.ints(string[: contents.word])[0])
            values = np.frombuffer(string[contents.word :], dtype=f"{contents.endian}{dtype}")
            out[column, first - 1 : first - 1 + values.size] = values
    return out


def read_op2_modes(path: str | os.PathLike) -> SolverModes:
    """The real normal modes of an OP2 file (see the module), in file units."""
    path = str(path)
    contents = read_op2(path)
    lama = _lama(contents, path)
    table, vectors, skipped = _eigenvectors(contents, path)
    if skipped:
        notes_skipped = [f"other {table} subtables left out: {'; '.join(sorted(set(skipped)))}"]
    else:
        notes_skipped = []
    mode_ids = np.array(sorted(vectors))
    missing = [int(m) for m in mode_ids if int(m) not in lama]
    if missing:
        raise InputError(f"op2: {path!r}: modes {missing[:5]} have eigenvectors but no LAMA entry")
    first = vectors[int(mode_ids[0])]
    keep = first[1] == STRUCTURAL_GRID
    node_ids = first[0][keep]
    shapes = np.zeros((node_ids.size, 3, mode_ids.size))
    for j, mode in enumerate(mode_ids):
        ids, types, values = vectors[int(mode)]
        if not np.array_equal(ids[types == STRUCTURAL_GRID], node_ids):
            raise InputError(
                f"op2: {path!r}: mode {mode} lists other grids than mode {mode_ids[0]}"
            )
        shapes[:, :, j] = values[types == STRUCTURAL_GRID, :3]
    notes = [f"eigenvectors from {table}", *notes_skipped]
    if contents.stopped:
        notes.append(f"reading stopped early: {contents.stopped}")
    if (~keep).any():
        notes.append(f"{int((~keep).sum())} scalar or extra points left out")
    nodes, nodes_missing = _coordinates(contents, node_ids, table, path, notes)
    modes = SolverModes(
        kind=f"Nastran OP2 ({contents.version or 'no version stated'}; LAMA, {table})",
        path=path,
        mode_ids=mode_ids,
        freq_hz=np.array([lama[int(m)][0] for m in mode_ids]),
        node_ids=node_ids,
        shapes=shapes,
        nodes=nodes,
        nodes_missing=nodes_missing,
        generalized_mass=np.array([lama[int(m)][1] for m in mode_ids]),
        notes=notes,
    )
    factors = _mpfacs(contents, len(lama))
    if factors is not None:
        order = {m: i for i, m in enumerate(sorted(lama))}
        modes.gamma = factors[[order[int(m)] for m in mode_ids], :3]
        modes.gamma_source = "the MPFACS matrix (Nastran MEFFMASS participation factors)"
    else:
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
    return modes


def _coordinates(contents, node_ids, table: str, path: str, notes: list[str]):
    basic, cd = _basic_coordinates(contents)
    grids = _grid_records(contents)
    if not basic and grids is not None:
        plain = grids[:, 1] == 0
        basic = {int(g[0]): g[2:5] for g in grids[plain]}
        cd = {int(g[0]): int(g[5]) for g in grids}
        if (~plain).any():
            notes.append(
                f"{int((~plain).sum())} GRID(s) defined in a local system (CP != 0) and no BGPDT"
            )
    if table == "OUGV1" and cd:
        local = [int(n) for n in node_ids if cd.get(int(n), 0) != 0]
        if local:
            raise InputError(
                f"op2: {path!r}: grids {local[:5]} ({len(local)} in all) have a displacement "
                "system CD != 0, in which OUGV1 gives their eigenvectors; write them in the "
                "basic system (PARAM,OUGCORD,BASIC: BOUGV1)"
            )
    missing = [int(n) for n in node_ids if int(n) not in basic]
    if not basic:
        return None, (
            f"{path!r} holds no grid geometry (GEOM1 or BGPDT: PARAM,POST,-1 writes it unless "
            "PARAM,OGEOM,NO); pass nodes= (--nodes) with a CSV node,x,y,z in the basic system"
        )
    if missing:
        return None, (
            f"{path!r} gives no basic coordinates for {len(missing)} grid(s), e.g. "
            f"{missing[:5]}; pass nodes= (--nodes) with a CSV node,x,y,z in the basic system"
        )
    notes.append(
        "coordinates from " + ("BGPDT" if _tables(contents, "BGPDT", "BGPDTS") else "GEOM1")
    )
    return np.array([basic[int(n)] for n in node_ids]), ""
