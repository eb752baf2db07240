"""Grid positions and displacement systems of a Nastran OP2 file, from its own geometry.

An OP2 written with PARAM,POST,-1 holds the model's geometry: the **GEOM1** table's GRID
records (id, CP, x1, x2, x3, CD, PS, SEID: the position in system CP, the displacement
system CD) and coordinate systems, **CORD2R/C/S** (cid, type 1/2/3, 2, RID, A1..A3, B1..B3,
C1..C3: three points in system RID) and **CORD1R/C/S** (cid, type, 1, G1, G2, G3: three
grids); or the **BGPDT** table (per internal grid: CD and the basic position) with
**EQEXIN** (external id, internal id). Systems are resolved as Nastran resolves them (a
CORD2 through its RID, a CORD1 through its grids, chains of any depth; fem.imports.nastran.coords
holds the geometry of the systems). Eigenvectors in OUGV1/OUG1 are given in each grid's
displacement system: :func:`vectors_to_basic` turns them to the basic system with the
directions of CD at the grid (cylindrical: radial, tangential, axial; spherical: radial,
meridional, azimuthal).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fem.imports.nastran.coords import BASIC, CoordSystem, axes_from_points
from fem.imports.op2 import Op2Contents
from jaxflex.errors import InputError

GRID_KEY = (4501, 45, 1)
CORD2_KEYS = {(2101, 21, 8): "R", (2001, 20, 9): "C", (2201, 22, 10): "S"}
CORD1_KEYS = {(1801, 18, 5): "R", (1701, 17, 6): "C", (1901, 19, 7): "S"}
CORD2_WORDS, CORD1_WORDS, GRID_WORDS = 13, 6, 8


@dataclass
class Op2Geometry:
    """What an OP2 says of its grids (file units): ``positions`` {grid: basic (3,)},
    ``cd`` {grid: displacement system}, ``systems`` {cid: CoordSystem} (resolved),
    ``unresolved`` {cid: why not}, ``source`` (the tables read), ``notes``."""

    positions: dict[int, np.ndarray] = field(default_factory=dict)
    cd: dict[int, int] = field(default_factory=dict)
    systems: dict[int, CoordSystem] = field(default_factory=lambda: {0: BASIC})
    unresolved: dict[int, str] = field(default_factory=dict)
    source: str = ""
    notes: list[str] = field(default_factory=list)


def _records(contents: Op2Contents, keys) -> dict[tuple, list[np.ndarray]]:
    """{key: [(n, width) int rows and float rows]} of the GEOM1 records whose key is in
    ``keys`` (key -> entry width in words)."""
    out: dict[tuple, list] = {}
    for table in contents.tables:
        if table.name not in ("GEOM1", "GEOM1S"):
            continue
        for strings in table.records:
            data = b"".join(strings)
            ints = contents.ints(data)
            key = tuple(int(i) for i in ints[:3]) if len(ints) >= 3 else ()
            if key not in keys:
                continue
            body = data[3 * contents.word :]
            width = keys[key]
            count = len(body) // (width * contents.word)
            i = contents.ints(body)[: width * count].reshape(count, width)
            f = contents.floats(body)[: width * count].reshape(count, width)
            out.setdefault(key, []).append((i, f))
    return out


def _bgpdt(contents: Op2Contents) -> tuple[dict, dict]:
    """({external id: basic (3,)}, {external id: CD}) from BGPDT + EQEXIN (4 words per
    grid: CD, x, y, z), or two empty dicts."""
    bgpdt = [t for t in contents.tables if t.name in ("BGPDT", "BGPDTS")]
    eqexin = [t for t in contents.tables if t.name in ("EQEXIN", "EQEXINS")]
    if not bgpdt or not eqexin or not bgpdt[0].records or not eqexin[0].records:
        return {}, {}
    data = bgpdt[0].record(0)
    ints, floats = contents.ints(data), contents.floats(data)
    pairs = contents.ints(eqexin[0].record(0))
    if len(ints) % 4 or len(pairs) % 2:
        return {}, {}
    rows = len(ints) // 4
    positions, cd = {}, {}
    for external, internal in pairs.reshape(-1, 2):
        if 1 <= internal <= rows:
            k = 4 * (int(internal) - 1)
            positions[int(external)] = floats[k + 1 : k + 4].astype(float)
            cd[int(external)] = int(ints[k])
    return positions, cd


def op2_geometry(contents: Op2Contents) -> Op2Geometry:
    """The grids' basic positions and displacement systems and the coordinate systems of an
    OP2 (module docstring); empty where the file holds no geometry."""
    keys = {GRID_KEY: GRID_WORDS} | dict.fromkeys(CORD2_KEYS, CORD2_WORDS)
    keys |= dict.fromkeys(CORD1_KEYS, CORD1_WORDS)
    records = _records(contents, keys)
    geometry = Op2Geometry()
    positions, cd = _bgpdt(contents)
    grids: dict[int, tuple[int, np.ndarray]] = {}
    for i, f in records.get(GRID_KEY, []):
        for row_i, row_f in zip(i, f, strict=True):
            gid, entry = int(row_i[0]), (int(row_i[1]), row_f[2:5].astype(float))
            if gid in grids and not (
                grids[gid][0] == entry[0] and np.array_equal(grids[gid][1], entry[1])
            ):
                raise InputError(
                    f"op2: {contents.path!r}: GRID {gid} is defined twice (GEOM1), at "
                    f"{grids[gid][1].tolist()} and {entry[1].tolist()}: which one its "
                    "eigenvectors belong to is unknown"
                )
            grids[gid] = entry
            cd.setdefault(gid, int(row_i[5]))
    geometry.cd = cd
    pending = _pending_systems(records)
    if positions:
        geometry.positions, geometry.source = positions, "BGPDT"
    waiting = {} if positions else dict(grids)
    while True:
        placed = _place(geometry, waiting)
        resolved = _resolve(geometry, pending)
        if not (placed or resolved):
            break
    for cid, (kind, _, refs) in pending.items():
        geometry.unresolved[cid] = (
            f"CORD{'2' if kind[1] == 'system' else '1'}{kind[0]} {cid} refers to "
            + ("system" if kind[1] == "system" else "grids")
            + f" {list(refs)} that the file does not define"
        )
    if waiting:
        geometry.notes.append(
            f"{len(waiting)} GRID(s) placed in coordinate systems the file does not define "
            f"(CP {sorted({cp for cp, _ in waiting.values()})[:5]})"
        )
    if not positions and grids:
        geometry.source = "GEOM1"
    if len(geometry.systems) > 1:
        geometry.notes.append(f"{len(geometry.systems) - 1} coordinate system(s) from GEOM1")
    return geometry


def _pending_systems(records) -> dict[int, tuple[tuple[str, str], np.ndarray, tuple]]:
    """{cid: ((kind, "system" | "grids"), numbers, references)} of the CORD records."""
    out = {}
    for key, kind in CORD2_KEYS.items():
        for i, f in records.get(key, []):
            for row_i, row_f in zip(i, f, strict=True):
                out[int(row_i[0])] = ((kind, "system"), row_f[4:13].astype(float), (int(row_i[3]),))
    for key, kind in CORD1_KEYS.items():
        for i, _ in records.get(key, []):
            for row in i:
                out[int(row[0])] = ((kind, "grids"), None, tuple(int(g) for g in row[3:6]))
    out.pop(0, None)
    return out


def _place(geometry: Op2Geometry, waiting: dict) -> bool:
    """Place the waiting GRIDs whose CP system is resolved; True if any was placed."""
    done = [g for g, (cp, _) in waiting.items() if cp in geometry.systems]
    for gid in done:
        cp, xyz = waiting.pop(gid)
        geometry.positions[gid] = geometry.systems[cp].to_basic(xyz)[0]
    return bool(done)


def _resolve(geometry: Op2Geometry, pending: dict) -> bool:
    """Resolve the pending systems whose references are known; True if any was."""
    progress = False
    for cid, ((kind, needs), numbers, refs) in list(pending.items()):
        if needs == "system":
            ref = geometry.systems.get(refs[0])
            if ref is None:
                continue
            points = ref.to_basic(numbers.reshape(3, 3))
        else:
            if not all(g in geometry.positions for g in refs):
                continue
            points = np.array([geometry.positions[g] for g in refs])
        del pending[cid]
        progress = True
        try:
            axes = axes_from_points(*points, "points" if needs == "system" else "grids")
        except ValueError as exc:
            geometry.unresolved[cid] = f"CORD{'2' if needs == 'system' else '1'}{kind} {cid}: {exc}"
            continue
        geometry.systems[cid] = CoordSystem(cid, kind, points[0], axes)
    return progress


def vectors_to_basic(
    geometry: Op2Geometry, node_ids: np.ndarray, vectors: np.ndarray, path: str, table: str
) -> tuple[np.ndarray, int]:
    """(N, 3, M) translations given in each grid's displacement system (``table``'s) turned
    to the basic system, and the number of grids turned; an InputError naming the grids
    whose system or position the file does not give."""
    cds = np.array([geometry.cd.get(int(n), 0) for n in node_ids])
    local = np.flatnonzero(cds > 0)
    if local.size == 0:
        return vectors, 0
    missing = sorted({int(c) for c in cds[local] if int(c) not in geometry.systems})
    if missing:
        why = "; ".join(
            geometry.unresolved.get(c, f"system {c} is not in the file") for c in missing
        )
        raise InputError(
            f"op2: {path!r}: {local.size} grid(s) give their eigenvectors in {table} in "
            f"displacement systems CD {missing[:5]} that cannot be resolved ({why}); write them "
            "in the basic system (PARAM,OUGCORD,BASIC: BOUGV1) or keep the geometry "
            "(PARAM,POST,-1 writes GEOM1 unless PARAM,OGEOM,NO)"
        )
    unplaced = [int(node_ids[k]) for k in local if int(node_ids[k]) not in geometry.positions]
    if unplaced:
        raise InputError(
            f"op2: {path!r}: grids {unplaced[:5]} ({len(unplaced)} in all) have displacement "
            "systems CD != 0 but no position in the file, so their directions are unknown"
        )
    out = vectors.copy()
    for cd in sorted({int(c) for c in cds[local]}):
        rows = local[cds[local] == cd]
        points = np.array([geometry.positions[int(node_ids[k])] for k in rows])
        frames = geometry.systems[cd].frames(points)  # (n, 3 components, 3 basic)
        out[rows] = np.einsum("nim,nib->nbm", vectors[rows], frames)
    return out, int(local.size)
