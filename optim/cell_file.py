"""The cell file: a robot cell (jaxflex.geometry.Cell) read from TOML or JSON, its mesh obstacles
from mesh files (fem.mesh.meshfile, read in a child process). Every field is checked; an error
names the field and what is allowed.

A cell file is TOML or JSON (:func:`load_cell`)::

    gravity_m_s2 = [0, 0, -9.81]
    [part]
    start_m = [0.0, 0.0, 0.3]          # part frame origin at A, cell coordinates
    rotation_deg = [0, 0, 0]           # part frame axes: rotations about x, y, z (in turn)
    thickness_m = 0.001                # optional: the sheet's thickness (default: the model's)
    [path]
    end_m = [2.0, 0.0, 0.6]            # at B
    via = [{position_m = [1.0, 0.0, 0.8], mode = "blend", tolerance_m = 0.05}]
    # a via point may fix the part's orientation there (with --rotate, optim.turn_via):
    # {position_m = [...], tolerance_m = 0.05, rotation_deg = [0, 20, 0]}, the part frame's
    # axes at the via point in the form of [part] rotation_deg
    [[obstacles]]
    type = "box"                       # or "half_space" (normal, offset_m), "mesh" (path, scale)
    name = "lower die"
    centre_m = [2.3, 0.0, 0.3]
    size_m = [1.2, 1.2, 0.5]
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from jaxflex.errors import InputError
from jaxflex.files import check_input_file, check_positive, named, read_settings_file
from jaxflex.geometry import (
    DEFAULT_GRAVITY_M_S2,
    Box,
    Cell,
    HalfSpace,
    Obstacle,
    TriangleMesh,
    Via,
    rotation_from_degrees,
)


def _table(where: str, value) -> dict:
    """``value`` as a dict, or InputError naming ``where``: a table was expected."""
    if not isinstance(value, Mapping):
        raise InputError(f"{where}: expected a table, got {type(value).__name__} {value!r:.40}")
    return dict(value)


def _number(where: str, value) -> float:
    """``value`` as a float, or InputError naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.number):
        raise InputError(f"{where}: expected a number, got {value!r:.40}")
    try:
        return float(value)
    except OverflowError:
        raise InputError(f"{where}: {value!r:.40} is too large") from None


def _obstacle(spec: Mapping, index: int, folder: Path) -> Obstacle:
    spec = _table(f"obstacles[{index}]", spec)
    kind = spec.get("type")
    name = str(spec.get("name", f"obstacles[{index}]"))
    where = f"obstacles[{index}] ({name})"
    known = {
        "box": {"type", "name", "centre_m", "size_m", "rotation_deg"},
        "half_space": {"type", "name", "normal", "offset_m"},
        "mesh": {"type", "name", "path", "scale"},
    }
    if not isinstance(kind, str) or kind not in known:
        raise InputError(f"{where}.type: must be one of {sorted(known)}, got {kind!r:.40}")
    unknown = set(spec) - known[kind]
    if unknown:
        raise InputError(f"{where}: unknown field(s) {sorted(unknown)} for a {kind}")
    try:
        if kind == "box":
            rotation = rotation_from_degrees(spec.get("rotation_deg", (0, 0, 0)))
            return Box(spec["centre_m"], spec["size_m"], rotation, name)
        if kind == "half_space":
            return HalfSpace(spec["normal"], _number(f"{where}.offset_m", spec["offset_m"]), name)
        path = folder / str(spec["path"])
    except KeyError as exc:
        raise InputError(f"{where}: missing field {exc.args[0]!r}") from exc
    scale = check_positive(f"{where}.scale", spec.get("scale", 1.0))
    check_input_file(f"{where}.path", path)
    try:
        from fem.mesh.meshfile import read_cells  # fem's package (scikit-fem): only for a mesh

        points, blocks = read_cells(path)
    except InputError as exc:  # naming the file the path really is (a path through ..)
        raise InputError(f"{where}.path {named(path)}: {exc}") from None
    triangles = [np.asarray(c, dtype=np.int64) for kind, c in blocks if kind == "triangle"]
    for kind, q in blocks:
        if kind == "quad":
            q = np.asarray(q, dtype=np.int64)
            triangles.append(np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]))
    if not sum(len(t) for t in triangles):
        raise InputError(f"{where}.path: {str(path)!r} holds no triangles or quads")
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise InputError(f"{where}.path: {str(path)!r}: nodes of shape {points.shape}")
    points = np.column_stack([points, np.zeros((len(points), 3 - points.shape[1]))]) * scale
    return TriangleMesh(points, np.concatenate(triangles), name)


# other forms a via point's orientation might come in (refused, naming rotation_deg)
ORIENTATION_FIELDS = {
    "orientation", "orientation_deg", "rotation", "rotation_rad", "rotation_vector",
    "quaternion", "axis", "angle_deg", "rpy_deg", "euler_deg",
}  # fmt: skip
VIA_ORIENTATION = (
    "rotation_deg = [rx, ry, rz], the part frame's axes at the via point as [part] "
    "rotation_deg: rotations in degrees about the cell's x, then y, then z"
)


def _via_rotation(where: str, value) -> np.ndarray:
    """The part's axes (3, 3) at a via point from its ``rotation_deg``; InputError naming
    ``where`` (the field) otherwise."""
    values = value if isinstance(value, list | tuple) else [value]
    if len(values) != 3:
        raise InputError(f"{where}: three numbers, got {value!r:.60}; {VIA_ORIENTATION}")
    try:
        angles = [_number(where, v) for v in values]
    except InputError as exc:
        raise InputError(f"{exc}; {VIA_ORIENTATION}") from None
    if not np.isfinite(angles).all():
        raise InputError(f"{where}: finite numbers, got {value!r:.60}; {VIA_ORIENTATION}")
    return rotation_from_degrees(angles)


def _via(i: int, v) -> Via:
    """The via point ``cell.path.via[i]`` of the cell file (module docstring)."""
    where = f"cell.path.via[{i}]"
    if not isinstance(v, Mapping) or "position_m" not in v:
        raise InputError(f"{where}: needs position_m (and mode, tolerance_m, rotation_deg)")
    extra = set(v) - {"position_m", "mode", "tolerance_m", "rotation_deg"}
    if extra & ORIENTATION_FIELDS:
        raise InputError(
            f"{where}: {sorted(extra & ORIENTATION_FIELDS)} is not read; a via point's "
            f"orientation is {VIA_ORIENTATION}"
        )
    if extra:
        raise InputError(
            f"{where}: unknown field(s) {sorted(extra)}; a via point has position_m, mode, "
            "tolerance_m and optionally rotation_deg"
        )
    tolerance = _number(f"{where}.tolerance_m", v.get("tolerance_m", 0.0))
    rotation = None
    if "rotation_deg" in v:
        rotation = _via_rotation(f"{where}.rotation_deg", v["rotation_deg"])
    return Via(v["position_m"], v.get("mode", "blend"), tolerance, rotation)


def cell_from_dict(data: Mapping, folder: str | Path = ".") -> Cell:
    """A Cell from the mapping of a cell file (module docstring); paths relative to
    ``folder``. Raises InputError naming the field."""
    data = _table("cell", data)
    unknown = set(data) - {"part", "path", "obstacles", "gravity_m_s2"}
    if unknown:
        raise InputError(f"cell: unknown section(s) {sorted(unknown)}")
    part, path = (
        _table("cell.part", data.get("part", {})),
        _table("cell.path", data.get("path", {})),
    )
    for section, allowed, value in (
        ("part", {"start_m", "rotation_deg", "thickness_m"}, part),
        ("path", {"end_m", "via"}, path),
    ):
        extra = set(value) - allowed
        if extra:
            raise InputError(f"cell.{section}: unknown field(s) {sorted(extra)}")
    if "end_m" not in path:
        raise InputError("cell.path.end_m: required (the part frame's origin at B, m)")
    vias = path.get("via", [])
    if not isinstance(vias, list | tuple):
        raise InputError(f"cell.path.via: expected a list of via points, got {vias!r:.40}")
    via = [_via(i, v) for i, v in enumerate(vias)]
    obstacles = data.get("obstacles", [])
    if not isinstance(obstacles, list | tuple):
        raise InputError("cell.obstacles: expected a list of obstacles")
    return Cell(
        obstacles=tuple(_obstacle(o, i, Path(folder)) for i, o in enumerate(obstacles)),
        start_m=part.get("start_m", (0.0, 0.0, 0.0)),
        end_m=path["end_m"],
        rotation=rotation_from_degrees(part.get("rotation_deg", (0, 0, 0))),
        via=tuple(via),
        gravity_m_s2=data.get("gravity_m_s2", DEFAULT_GRAVITY_M_S2),
        thickness_m=part.get("thickness_m"),
    )


def load_cell(path: str | Path) -> Cell:
    """Read a cell file (``.toml`` or ``.json``; module docstring)."""
    path = Path(path)
    data = read_settings_file("cell", path)
    return cell_from_dict(data, path.parent)
