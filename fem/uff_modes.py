"""Modes and measured responses from a Universal File (UFF/UNV; read with pyuff).

Datasets used:

* **55** (data at nodes), analysis type 2 (normal mode), real, 3 or 6 values per node of
  specific data type 8 (displacement) or 0 (unknown): one mode per dataset, with its
  frequency (Hz) and modal mass (0: not stated);
* **58** (function at a node), function type 1 (time response), even abscissa: the response
  of a node along a direction to a unit hat of base acceleration along the reference
  direction (a test rig's or a solver's R1, identified like the preprint's R1, fem.identify);
* **15** and **2411** (nodes): coordinates in the global system (coordinate system 0, or 1,
  I-DEAS's number for the global Cartesian system);
* **164** (units): length and force factors (file value / factor = SI value), so the mass
  unit is force / (length / s^2).

Other datasets (elements 2412, static results 2414, ...) are counted and left out.
"""

from __future__ import annotations

import os
import warnings
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from fem.solver_modes import SolverModes
from fem.units import Units
from jaxflex.errors import InputError

NORMAL_MODE, REAL, TIME_RESPONSE = 2, 2, 1
GLOBAL_SYSTEMS = (0, 1)
AXES = "xyz"


@dataclass(eq=False)
class UffResponses:
    """Time responses of dataset 58: ``axes`` excited (reference directions), ``dt_s``,
    ``first_time_s`` (the abscissa of the first sample), ``values`` (A, n, K, 3) response
    per unit input (length / (length / s^2): s^2, the same in any unit), ``node_ids`` (K,),
    ``nodes`` (K, 3) their coordinates in file units (None if the file lacks some), the
    file's ``units``."""

    axes: tuple[str, ...]
    dt_s: float
    first_time_s: float
    values: np.ndarray
    node_ids: np.ndarray
    nodes: np.ndarray | None = None
    units: Units | None = None
    notes: list[str] = field(default_factory=list)


def _sets(path: str) -> list[dict]:
    import pyuff

    if not os.path.isfile(path):
        raise InputError(f"uff: file {path!r} does not exist")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sets = pyuff.UFF(path).read_sets()
    except Exception as exc:  # pyuff raises many types for foreign files
        raise InputError(f"uff: {path!r} is not a Universal File pyuff can read ({exc})") from exc
    return [sets] if isinstance(sets, dict) else list(sets)


def _units(sets: list[dict]) -> Units | None:
    found = [s for s in sets if s["type"] == 164]
    if not found:
        return None
    unit = found[0]
    length_m, force_n = 1 / float(unit["length"]), 1 / float(unit["force"])
    name = str(unit.get("units_description", "")).strip() or f"units code {unit['units_code']}"
    return Units(
        f"UFF 164: {name}",
        length_m,
        force_n / length_m,
        f"length {length_m:g} m, force {force_n:g} N (dataset 164)",
    )


def _nodes(sets: list[dict], path: str) -> dict[int, np.ndarray]:
    out: dict[int, np.ndarray] = {}
    for data in sets:
        if data["type"] not in (15, 2411):
            continue
        systems = {int(c) for c in np.concatenate([data["def_cs"], data["disp_cs"]])}
        if systems - set(GLOBAL_SYSTEMS):
            raise InputError(
                f"uff: {path!r}: nodes in coordinate systems {sorted(systems)}; only the global "
                "system (0, or I-DEAS's 1) is read"
            )
        xyz = np.column_stack([data["x"], data["y"], data["z"]]).astype(float)
        for node, point in zip(np.asarray(data["node_nums"], dtype=int), xyz, strict=True):
            out[int(node)] = point
    return out


def read_uff(path: str | os.PathLike) -> tuple[SolverModes | None, UffResponses | None]:
    """The modes (datasets 55) or the time responses (58) of a Universal File, in file
    units, with the nodes and units it holds (see the module)."""
    path = str(path)
    sets = _sets(path)
    counts = Counter(int(s["type"]) for s in sets)
    units, nodes = _units(sets), _nodes(sets, path)
    modes = [s for s in sets if s["type"] == 55]
    functions = [s for s in sets if s["type"] == 58]
    left_out = {k: v for k, v in counts.items() if k not in (15, 2411, 164, 55, 58)}
    notes = [f"datasets left out: {dict(sorted(left_out.items()))}"] if left_out else []
    if modes:
        return _modes(modes, nodes, units, path, notes), None
    if functions:
        responses = _responses(functions, path, notes)
        if all(int(n) in nodes for n in responses.node_ids):
            responses.nodes = np.array([nodes[int(n)] for n in responses.node_ids])
        responses.units = units
        return None, responses
    raise InputError(
        f"uff: {path!r} holds no modes (dataset 55) or time responses (58); its datasets: "
        f"{dict(sorted(counts.items()))}"
    )


def _modes(sets, nodes, units, path, notes) -> SolverModes:
    normal = [s for s in sets if s["analysis_type"] == NORMAL_MODE]
    if not normal:
        kinds = sorted({int(s["analysis_type"]) for s in sets})
        raise InputError(
            f"uff: {path!r}: its datasets 55 are of analysis types {kinds}, not normal modes (2)"
        )
    if len(normal) < len(sets):
        notes.append(f"{len(sets) - len(normal)} dataset(s) 55 of other analysis types left out")
    for data in normal:
        if data["data_type"] != REAL or data["data_ch"] not in (2, 3):
            raise InputError(
                f"uff: {path!r}: mode {data.get('mode_n')} is complex or not a translation "
                f"vector (data type {data['data_type']}, characteristic {data['data_ch']}); "
                "real 3- or 6-DOF vectors are read"
            )
        if data["spec_data_type"] not in (0, 8):
            raise InputError(
                f"uff: {path!r}: mode {data.get('mode_n')} holds specific data type "
                f"{data['spec_data_type']}, not displacements (8)"
            )
    normal.sort(key=lambda s: float(s["freq"]))
    node_ids = np.asarray(normal[0]["node_nums"], dtype=int)
    shapes = np.zeros((node_ids.size, 3, len(normal)))
    for j, data in enumerate(normal):
        if not np.array_equal(np.asarray(data["node_nums"], dtype=int), node_ids):
            raise InputError(f"uff: {path!r}: mode {j + 1} lists other nodes than the first")
        shapes[:, :, j] = np.column_stack([data["r1"], data["r2"], data["r3"]])
    missing = [int(n) for n in node_ids if int(n) not in nodes]
    masses = np.array([float(s["modal_m"]) for s in normal])
    return SolverModes(
        kind="Universal File (datasets 55, normal modes)",
        path=path,
        mode_ids=np.array([int(s.get("mode_n") or j + 1) for j, s in enumerate(normal)]),
        freq_hz=np.array([float(s["freq"]) for s in normal]),
        node_ids=node_ids,
        shapes=shapes,
        nodes=None if missing else np.array([nodes[int(n)] for n in node_ids]),
        nodes_missing=(
            f"{path!r} has no coordinates (dataset 15 or 2411) for {len(missing)} node(s), e.g. "
            f"{missing[:5]}; pass nodes= (--nodes) with a CSV node,x,y,z or a Universal File"
        )
        if missing
        else "",
        generalized_mass=None if np.all(masses == 0) else masses,
        gamma_missing=f"{path!r} (datasets 55) holds no participation factors",
        units=units,
        notes=notes,
    )


def _responses(sets, path, notes) -> UffResponses:
    time = [s for s in sets if s["func_type"] == TIME_RESPONSE]
    if not time:
        kinds = sorted({int(s["func_type"]) for s in sets})
        raise InputError(
            f"uff: {path!r}: its datasets 58 are of function types {kinds}, not time responses (1)"
        )
    grids = {(float(s["abscissa_min"]), float(s["abscissa_inc"]), int(s["num_pts"])) for s in time}
    if len(grids) != 1 or any(s["abscissa_spacing"] != 1 for s in time):
        raise InputError(f"uff: {path!r}: the time responses have different or uneven time axes")
    first, dt, count = grids.pop()
    axes = sorted({abs(int(s["ref_dir"])) for s in time})
    if not set(axes) <= {1, 2, 3}:
        raise InputError(
            f"uff: {path!r}: reference directions {axes}; responses to base acceleration along "
            "x, y or z (1, 2, 3) are read"
        )
    node_ids = np.array(sorted({int(s["rsp_node"]) for s in time}))
    where = {int(n): i for i, n in enumerate(node_ids)}
    values = np.zeros((len(axes), count, node_ids.size, 3))
    rotations = 0
    for data in time:
        direction = int(data["rsp_dir"])
        if abs(direction) not in (1, 2, 3):
            rotations += 1
            continue
        sign = np.sign(direction) * np.sign(int(data["ref_dir"]))
        a = axes.index(abs(int(data["ref_dir"])))
        values[a, :, where[int(data["rsp_node"])], abs(direction) - 1] = sign * np.asarray(
            data["data"], dtype=float
        )
    if rotations:
        notes.append(f"{rotations} rotational response(s) left out")
    return UffResponses(tuple(AXES[a - 1] for a in axes), dt, first, values, node_ids, notes)
