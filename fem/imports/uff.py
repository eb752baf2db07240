"""Modes and measured responses from a Universal File (UFF/UNV; read with pyuff).

Datasets used:

* **55** (data at nodes), analysis type 2 (normal mode), real, 3 or 6 values per node of
  specific data type 8 (displacement) or 0 (unknown): one mode per dataset, with its
  frequency (Hz) and modal mass (0: not stated);
* **2414** (analysis data: how Simcenter/NX and I-DEAS write results), analysis type 2
  (normal mode), data at nodes, 3 or 6 values per node (real, or complex with zero
  imaginary parts: a real mode written as complex), result type displacement (8) or
  unknown (0): one mode per dataset, its mode number, frequency (Hz) and modal mass;
* **58** (function at a node), function type 1 (time response), even abscissa: the response
  of a node along a direction to a unit hat of base acceleration along the reference
  direction (a test rig's or a solver's R1, identified like the preprint's R1, fem.imports.r1);
* **15** and **2411** (nodes): coordinates in their definition system and displacement
  system: the global system (0, or 1 where the file defines no system 1, I-DEAS's number
  for the global Cartesian system) or a Cartesian system of dataset **2420** (rows 1-3 of
  its 4 x 3 transformation matrix: the local x, y, z axes in global coordinates, row 4:
  the origin; global = local @ rows 1-3 + row 4); mode shapes are turned from each node's
  displacement system to the global one;
* **164** (units): length and force factors (file value / factor = SI value), so the mass
  unit is force / (length / s^2).

Other datasets (elements 2412, results of other analyses, ...) are counted and left out; a
file whose results are not normal modes is refused naming what they are.
"""

from __future__ import annotations

import contextlib
import io
import os
import warnings
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from fem.imports.solver_modes import SolverModes
from fem.imports.units import Units
from jaxflex.errors import InputError
from jaxflex.stdout import silenced_stdout

NORMAL_MODE, REAL, TIME_RESPONSE = 2, 2, 1
GLOBAL_SYSTEMS = (0, 1)
AXES = "xyz"
MODE_DATASETS = (55, 2414)
# analysis types of datasets 55 and 2414 (I-DEAS), for what a file holds instead of modes
ANALYSIS_TYPES = {
    0: "unknown",
    1: "static",
    2: "normal mode",
    3: "complex eigenvalue, first order",
    4: "transient",
    5: "frequency response",
    6: "buckling",
    7: "complex eigenvalue, second order",
    9: "static non-linear",
    10: "Craig-Bampton constraint modes",
    11: "equivalent attachment modes",
    12: "effective mass modes",
    13: "effective mass matrix",
}
REAL_2414, COMPLEX_2414 = (2, 4), (5, 6)  # single/double real, single/double complex
IMAGINARY_RTOL = 1e-6  # imaginary parts below this share of the mode's largest: a real mode


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
    try:  # pyuff prints some datasets (groups 2467) as it reads them: kept off stdout
        with warnings.catch_warnings(), silenced_stdout():
            warnings.simplefilter("ignore")
            with contextlib.redirect_stdout(io.StringIO()):
                sets = pyuff.UFF(path).read_sets()
    except Exception as exc:  # pyuff raises many types for foreign files
        raise InputError(f"uff: {path!r} is not a Universal File pyuff can read ({exc})") from exc
    return [sets] if isinstance(sets, dict) else list(sets)


def _units(sets: list[dict]) -> Units | None:
    found = [s for s in sets if s["type"] == 164]
    if not found:
        return None
    unit = found[0]
    factors = np.array([float(unit["length"]), float(unit["force"])])
    if not (np.isfinite(factors).all() and (factors > 0).all()):
        raise InputError(
            f"uff: dataset 164 states the length and force factors {factors.tolist()}; finite "
            "factors > 0 are read"
        )
    length_m, force_n = 1 / factors
    name = str(unit.get("units_description", "")).strip() or f"units code {unit['units_code']}"
    return Units(
        f"UFF 164: {name}",
        length_m,
        force_n / length_m,
        f"length {length_m:g} m, force {force_n:g} N (dataset 164)",
    )


def _systems(sets: list[dict], path: str) -> dict[int, np.ndarray]:
    """{label: (4, 3) transformation (rows 1-3 local axes, row 4 origin; global)} of the
    Cartesian systems of datasets 2420; cylindrical and spherical ones are refused where
    they are used (see :func:`_nodes`)."""
    out: dict[int, np.ndarray] = {}
    for data in sets:
        if data["type"] != 2420:
            continue
        for label, kind, matrix in zip(
            data["CS_sys_labels"], data["CS_types"], data["CS_matrices"], strict=True
        ):
            matrix = np.asarray(matrix, dtype=float)
            if int(kind) != 0:
                out[int(label)] = None
                continue
            axes = matrix[:3]
            if matrix.shape != (4, 3) or not np.allclose(axes @ axes.T, np.eye(3), atol=1e-6):
                raise InputError(
                    f"uff: {path!r}: coordinate system {label} (dataset 2420) has no orthonormal "
                    "axes in rows 1-3 of its transformation matrix"
                )
            out[int(label)] = matrix
    return out


@dataclass
class _Nodes:
    """Nodes of datasets 15/2411 in the global system: ``xyz`` {node: (3,)}, ``turn``
    {node: (3, 3) rows: its displacement system's axes} for nodes not in the global one,
    ``unplaced`` {node: why its system is unknown}."""

    xyz: dict[int, np.ndarray] = field(default_factory=dict)
    turn: dict[int, np.ndarray] = field(default_factory=dict)
    unplaced: dict[int, str] = field(default_factory=dict)


def _system(systems: dict, label: int, path: str, node: int) -> np.ndarray | None:
    """The (4, 3) transformation of system ``label`` (None: the global system)."""
    if label in systems:
        if systems[label] is None:
            raise InputError(
                f"uff: {path!r}: node {node} is in coordinate system {label}, a cylindrical or "
                "spherical one (dataset 2420); only Cartesian systems are read"
            )
        return systems[label]
    if label in GLOBAL_SYSTEMS:
        return None
    raise InputError(
        f"uff: {path!r}: node {node} is in coordinate system {label}, which the file does not "
        "define (dataset 2420); systems 0 and 1 are taken as the global one"
    )


def _nodes(sets: list[dict], path: str) -> _Nodes:
    systems = _systems(sets, path)
    out = _Nodes()
    for data in sets:
        if data["type"] not in (15, 2411):
            continue
        xyz = np.column_stack([data["x"], data["y"], data["z"]]).astype(float)
        ids = _ids(data["node_nums"], path, f"dataset {data['type']} node numbers")
        systems_of = [
            _ids(data[k], path, "coordinate system numbers") for k in ("def_cs", "disp_cs")
        ]
        if not all(len(v) == len(ids) for v in (xyz, *systems_of)):
            raise InputError(f"uff: {path!r}: dataset {data['type']}: node records are incomplete")
        for node, point, defined, shown in zip(ids, xyz, *systems_of, strict=True):
            try:
                where = _system(systems, int(defined), path, int(node))
                turn = _system(systems, int(shown), path, int(node))
            except InputError as exc:
                out.unplaced[int(node)] = str(exc)
                continue
            out.xyz[int(node)] = point if where is None else point @ where[:3] + where[3]
            if turn is not None:
                out.turn[int(node)] = turn[:3]
    return out


def read_uff(path: str | os.PathLike) -> tuple[SolverModes | None, UffResponses | None]:
    """The modes (datasets 55 or 2414) or the time responses (58) of a Universal File, in
    file units, with the nodes and units it holds (see the module)."""
    path = str(path)
    sets = _sets(path)
    try:
        return _read_sets(sets, path)
    except InputError:
        raise
    except (ValueError, OverflowError, TypeError, KeyError, IndexError, ZeroDivisionError) as exc:
        raise InputError(
            f"uff: {path!r}: a dataset holds fields the Universal File format does not allow "
            f"({type(exc).__name__}: {exc})"
        ) from exc


def _read_sets(sets: list[dict], path: str):
    counts = Counter(int(s["type"]) for s in sets)
    units, nodes = _units(sets), _nodes(sets, path)
    results = [s for s in sets if s["type"] in MODE_DATASETS]
    functions = [s for s in sets if s["type"] == 58]
    used = (15, 2411, 2420, 164, *MODE_DATASETS, 58)
    left_out = {k: v for k, v in counts.items() if k not in used}
    notes = [f"datasets left out: {dict(sorted(left_out.items()))}"] if left_out else []
    if results:
        return _modes(results, nodes, units, path, notes), None
    if functions:
        responses = _responses(functions, path, notes)
        if all(int(n) in nodes.xyz for n in responses.node_ids):
            responses.nodes = np.array([nodes.xyz[int(n)] for n in responses.node_ids])
        responses.units = units
        return None, responses
    raise InputError(
        f"uff: {path!r} holds no modes (dataset 55 or 2414) or time responses (58); its "
        f"datasets: {dict(sorted(counts.items()))}"
    )


def _analysis(data: dict) -> int:
    return int(data["analysis_type"])


def _normal(sets: list[dict], path: str, notes: list[str]) -> list[dict]:
    """The datasets of normal modes among ``sets`` (55 and 2414), others named."""
    normal = [s for s in sets if _analysis(s) == NORMAL_MODE]
    if not normal:
        kinds = Counter(ANALYSIS_TYPES.get(_analysis(s), f"type {_analysis(s)}") for s in sets)
        raise InputError(
            f"uff: {path!r} holds no normal modes: its results (datasets 55/2414) are of "
            f"analysis types {dict(kinds)}, not normal mode (2)"
        )
    if len(normal) < len(sets):
        notes.append(
            f"{len(sets) - len(normal)} result dataset(s) of other analysis types left out"
        )
    return normal


def _mode_55(data: dict, path: str) -> tuple[int, float, float, np.ndarray, np.ndarray]:
    """(mode number, Hz, modal mass, node ids, (N, 3) translations) of a dataset 55."""
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
    values = np.column_stack([data["r1"], data["r2"], data["r3"]]).astype(float)
    mode = _integer(data.get("mode_n") or 0, path, "mode number")
    ids = _ids(data["node_nums"], path, "dataset 55 node numbers")
    if values.shape[0] != ids.size:
        raise InputError(
            f"uff: {path!r}: mode {mode} (dataset 55) lists {ids.size} nodes but "
            f"{values.shape[0]} vectors"
        )
    return mode, float(data["freq"]), float(data["modal_m"]), ids, values


def _ids(values, path: str, what: str) -> np.ndarray:
    """Whole numbers (labels) of a dataset as ints; an InputError for others."""
    numbers = np.atleast_1d(np.asarray(values, dtype=float))
    if not (np.isfinite(numbers).all() and (np.abs(numbers) < 2**31).all()):
        raise InputError(f"uff: {path!r}: {what} that are not integers ({numbers[:3]} ...)")
    if (numbers != np.round(numbers)).any():
        raise InputError(f"uff: {path!r}: {what} that are not integers ({numbers[:3]} ...)")
    return numbers.astype(np.int64)


def _integer(value, path: str, what: str) -> int:
    try:
        return int(value)
    except (OverflowError, ValueError) as exc:
        raise InputError(f"uff: {path!r}: the {what} {value!r} is not an integer") from exc


def _mode_2414(data: dict, path: str) -> tuple[int, float, float, np.ndarray, np.ndarray]:
    """(mode number, Hz, modal mass, node ids, (N, 3) translations) of a dataset 2414."""
    label = f"dataset 2414 {data.get('analysis_dataset_label')}"
    kind, width = int(data["data_type"]), int(data["number_of_data_values_for_the_data_component"])
    if int(data["dataset_location"]) != 1 or int(data["data_characteristic"]) not in (2, 3):
        raise InputError(
            f"uff: {path!r}: {label} holds data at location {data['dataset_location']} with "
            f"characteristic {data['data_characteristic']}; normal modes as 3- or 6-DOF "
            "vectors at nodes (location 1, characteristic 2 or 3) are read"
        )
    if int(data["result_type"]) not in (0, 8) or kind not in REAL_2414 + COMPLEX_2414:
        raise InputError(
            f"uff: {path!r}: {label} holds result type {data['result_type']}, data type {kind}; "
            "displacements (8) as real or complex numbers are read"
        )
    per_node = width * (2 if kind in COMPLEX_2414 else 1)
    rows = [np.asarray(v, dtype=float) for v in data["data_at_node"]]
    if any(r.size != per_node for r in rows):
        raise InputError(
            f"uff: {path!r}: {label}: node records of {sorted({r.size for r in rows})} values, "
            f"expected {per_node} ({width} {'complex' if per_node > width else 'real'} values)"
        )
    values = np.array(rows).reshape(len(rows), -1)
    if kind in COMPLEX_2414:
        real, imaginary = values[:, 0::2], values[:, 1::2]
        if np.abs(imaginary).max(initial=0) > IMAGINARY_RTOL * np.abs(real).max(initial=0):
            raise InputError(
                f"uff: {path!r}: {label} is a complex mode (imaginary parts up to "
                f"{np.abs(imaginary).max():.3g}); real normal modes are read"
            )
        values = real
    mode = _integer(data.get("record10_field6") or 0, path, "mode number")
    ids = _ids(data["node_nums"], path, f"{label} node numbers")
    if ids.size != values.shape[0]:
        raise InputError(
            f"uff: {path!r}: {label} lists {ids.size} nodes, {values.shape[0]} vectors"
        )
    return mode, float(data["record12_field2"]), float(data["record12_field4"]), ids, values[:, :3]


def _modes(sets, nodes: _Nodes, units, path, notes) -> SolverModes:
    normal = _normal(sets, path, notes)
    first_ids = _ids(normal[0]["node_nums"], path, "node numbers")
    unplaced = [n for n in first_ids if int(n) in nodes.unplaced]
    if unplaced:
        raise InputError(nodes.unplaced[int(unplaced[0])] + f" ({len(unplaced)} such node(s))")
    read = [(_mode_55 if s["type"] == 55 else _mode_2414)(s, path) for s in normal]
    read.sort(key=lambda r: r[1])
    node_ids = read[0][3]
    shapes = np.zeros((node_ids.size, 3, len(read)))
    for j, (_, _, _, ids, values) in enumerate(read):
        if not np.array_equal(ids, node_ids):
            raise InputError(f"uff: {path!r}: mode {j + 1} lists other nodes than the first")
        shapes[:, :, j] = values
    turned = [k for k, n in enumerate(node_ids) if int(n) in nodes.turn]
    for k in turned:  # displacement system -> global: rows of the axes
        shapes[k] = nodes.turn[int(node_ids[k])].T @ shapes[k]
    if turned:
        notes.append(
            f"{len(turned)} node(s) with a displacement system of dataset 2420: shapes turned "
            "to the global system"
        )
    missing = [int(n) for n in node_ids if int(n) not in nodes.xyz]
    masses = np.array([r[2] for r in read])
    datasets = sorted({int(s["type"]) for s in normal})
    return SolverModes(
        kind=f"Universal File (datasets {', '.join(map(str, datasets))}, normal modes)",
        path=path,
        mode_ids=np.array([r[0] or j + 1 for j, r in enumerate(read)]),
        freq_hz=np.array([r[1] for r in read]),
        node_ids=node_ids,
        shapes=shapes,
        nodes=None if missing else np.array([nodes.xyz[int(n)] for n in node_ids]),
        nodes_missing=(
            f"{path!r} has no coordinates (dataset 15 or 2411) for {len(missing)} node(s), e.g. "
            f"{missing[:5]}; pass nodes= (--nodes) with a CSV node,x,y,z or a Universal File"
        )
        if missing
        else "",
        generalized_mass=None if np.all(masses == 0) else masses,
        gamma_missing=f"{path!r} (datasets {', '.join(map(str, datasets))}) holds no "
        "participation factors",
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
    grids = {(float(s["abscissa_min"]), float(s["abscissa_inc"]), np.size(s["data"])) for s in time}
    if len(grids) != 1 or any(s["abscissa_spacing"] != 1 for s in time):
        raise InputError(f"uff: {path!r}: the time responses have different or uneven time axes")
    first, dt, count = grids.pop()
    stated = {_integer(s["num_pts"], path, "number of samples") for s in time}
    if stated != {count} or not (np.isfinite(first) and np.isfinite(dt) and dt > 0):
        raise InputError(
            f"uff: {path!r}: the time responses hold {count} samples from {first:g} s every "
            f"{dt:g} s where their headers state {sorted(stated)[:3]} samples; a time axis of "
            "finite values with a step > 0 and as many samples as stated is read"
        )
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
    return UffResponses(tuple(AXES[a - 1] for a in axes), dt, first, values, node_ids, notes=notes)
