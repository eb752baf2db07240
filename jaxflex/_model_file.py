"""The modal model file: a versioned ``.npz`` (numpy zip archive, no pickled objects).

Schema version 3 holds the members of :data:`FIELDS`:
    format          "jaxflex.modal_model"
    schema_version  3
    meta_json       JSON object (source, material, gripper, mesh statistics; SI units)
    freq_hz (M,) Hz, zeta (M,), gamma (M, 3) kg^0.5, shapes (K, 3, M) m/kg^0.5, points (K, 3) m,
    labels (K,) unicode (optional; empty strings: unlabelled points),
and, optionally, the groups of fields marked with a ``group`` (all fields of a group or none;
see jaxflex._outputs and jaxflex.model for their meaning): the exact static displacement of
the points per unit base acceleration, the cups and their reactions, the surface stresses,
the inertia data of turning moves (jaxflex._rotation; files without it cannot turn the part)
and their static response to the rotational loads (points, cups, stresses: three groups;
files without them turn the part without the quasi-static share of the modes left out), and
the modes' gyroscopic and spin couplings (one group; files without them get the looser
energy bound of the neglected terms), and the surface the points span (``surface_triangles``
(T, 3) point indices, integers: the FE mesh's own connectivity, for pictures and animations;
files without it, imports of modal results and R1, are drawn from their points alone).
An optional group of schema 3 added later (the surface) is ignored by the readers that came
before it, which read only the members they know: the files stay readable both ways.
Version 2 files are read as well (they hold no static displacement, and the outputs' modal
A instead of their static response S: jaxflex._outputs.legacy_static_map derives S), and
version 1 files (the same without any group).

Reading trusts nothing in the file. Only the members of :data:`FIELDS` are read (anything
else in the archive is never decompressed), each one's npy header is checked against the
table (kind of data, number of dimensions, the sizes M, K, C and S the other members
declare) *before* its data are read, the declared size must be exactly what the member
holds, and a compressed member may not expand beyond :data:`MAX_EXPANSION` times its stored
size (real modal data hardly compress; a zip bomb does). Every failure is a ModelFileError
naming the file and the member. The values themselves (finite, physical ranges
:data:`VALUE_RANGES`) are checked where the model is built (jaxflex.model).

This module knows the file, not the model class: it writes and reads plain arrays, and
jaxflex.model turns them into a validated ModalModel.
"""

from __future__ import annotations

import json
import math
import os
import struct
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from jaxflex._atomic import atomic_open
from jaxflex.errors import ModelFileError

FORMAT_NAME = "jaxflex.modal_model"
SCHEMA_VERSION = 3
SUPPORTED_VERSIONS = (1, 2, 3)
ARRAY_FIELDS = ("freq_hz", "zeta", "gamma", "shapes", "points")
# A member stored compressed may hold at most this many times its compressed size: modal
# data are float64 noise (a ratio near 1; a flat part's zero in-plane shapes give about 3).
MAX_EXPANSION = 100
# The scalar text members (format, meta_json) are small; a larger one is not a model file.
MAX_TEXT_BYTES = 64 << 20
_NPY_MAGIC = b"\x93NUMPY"


@dataclass(frozen=True)
class Field:
    """One member of the archive: its name, the data it holds ("real": numbers, "integer",
    "text": unicode), its shape in the model's sizes (M modes, K points, C cups, S stress
    points, T surface triangles; integers are fixed lengths), its unit, whether a file must
    have it, the first and last schema version with it and the optional group it belongs to
    (all of a group's fields of the file's version or none)."""

    name: str
    kind: str
    dims: tuple[str | int, ...]
    unit: str = ""
    required: bool = True
    since: int = 1
    group: str | None = None
    until: int = SCHEMA_VERSION

    def in_version(self, version: int) -> bool:
        return self.since <= version <= self.until


def _group(name: str, *fields: tuple) -> tuple[Field, ...]:
    """Fields (name, dims, unit[, since[, until]]) of an optional group (since 2 by default)."""
    out = []
    for field, dims, unit, *versions in fields:
        since, until = (*versions, SCHEMA_VERSION)[:2] if versions else (2, SCHEMA_VERSION)
        out.append(Field(field, "real", dims, unit, False, since, name, until))
    return tuple(out)


# The optional groups. Reactions: force (N) and moment about the cup centre (N m) that cup c
# exerts on the part, rows (F_x, F_y, F_z, M_x, M_y, M_z); stresses: Voigt (xx, yy, zz, yz,
# xz, xy) in Pa. "_q": per unit modal coordinate (kg^0.5 m), "_v": per unit modal velocity
# (kg^0.5 m/s), "_s": the exact static output per unit base acceleration (m/s^2; schema 3),
# "_a": schema 2's modal share per unit base acceleration (A = S + Q Omega^-2 Gamma).
CUP_FIELDS = _group(
    "cups",
    ("cup_centre_m", ("C", 3), "m"),
    ("cup_normal", ("C", 3), "unit normal from the part into the cup"),
    ("cup_radius_m", ("C",), "m (effective suction radius)"),
    ("cup_holding_force_n", ("C",), "N (vacuum x effective area)"),
    ("cup_friction", ("C",), "friction coefficient between cup and part"),
    ("cup_reaction_q", ("C", 6, "M"), "N or N m per unit modal coordinate"),
    ("cup_reaction_v", ("C", 6, "M"), "N or N m per unit modal velocity"),
    ("cup_reaction_a", ("C", 6, 3), "N or N m per unit base acceleration (modal)", 2, 2),
    ("cup_reaction_s", ("C", 6, 3), "N or N m at rest per unit base acceleration", 3),
)
STRESS_FIELDS = _group(
    "stress",
    ("stress_points_m", ("S", 3), "m (surface points where the stress is known)"),
    ("stress_q", ("S", 6, "M"), "Pa per unit modal coordinate"),
    ("stress_v", ("S", 6, "M"), "Pa per unit modal velocity"),
    ("stress_a", ("S", 6, 3), "Pa per unit base acceleration (modal)", 2, 2),
    ("stress_s", ("S", 6, 3), "Pa at rest per unit base acceleration", 3),
)
STATIC_FIELDS = _group(
    "static",
    ("static_shapes", ("K", 3, 3), "m per unit base acceleration (m/s^2), at rest", 3),
)
# The inertia shape integrals and the rigid inertia for turning moves (jaxflex._rotation).
ROTATION_GROUP = _group(
    "rotation",
    ("rotation_shape_integrals", ("M", 3, 3), "kg^0.5 m: phi^T M (e_j r_i)", 3),
    ("rotation_mass_kg", (1,), "kg", 3),
    ("rotation_centre_m", (3,), "m (centre of mass)", 3),
    ("rotation_inertia_kg_m2", (3, 3), "kg m^2 about the model frame's origin", 3),
)
# Their optional static response to the nine unit inertia loads f_ij = M (e_j r_i), at rest
# per unit B_ji (1/s^2) of the rigid-motion field B r (jaxflex._rotation): the points', the cup
# reactions', the stresses' (each its own group: a model without cups has no cup part).
ROTATION_STATIC_GROUP = _group(
    "rotation_static",
    ("rotation_static_shapes", ("K", 3, 3, 3), "m per unit B_ji (1/s^2), at rest", 3),
)
ROTATION_CUP_GROUP = _group(
    "rotation_cups",
    ("rotation_cup_static", ("C", 6, 3, 3), "N or N m per unit B_ji (1/s^2), at rest", 3),
)
ROTATION_STRESS_GROUP = _group(
    "rotation_stress",
    ("rotation_stress_static", ("S", 6, 3, 3), "Pa per unit B_ji (1/s^2), at rest", 3),
)
# The optional couplings of the deformation (jaxflex._rotation): G_k = phi^T M X_k phi and
# P_kl = phi^T M X_k X_l phi, X_k the DOF operator of u -> e_k x u (the neglected terms'
# a-posteriori bound, jaxflex._turning).
ROTATION_COUPLING_GROUP = _group(
    "rotation_coupling",
    ("rotation_gyroscopic", (3, "M", "M"), "1: phi^T M (e_k x phi)", 3),
    ("rotation_spin", (3, 3, "M", "M"), "1: phi^T M (e_k x (e_l x phi))", 3),
)
# The surface of the points (jaxflex.model.ModalModel.surface): triangles of point indices,
# the FE mesh's cells (quadratic ones split into triangles) as the mesh orders them; an integer
# field (the indices are checked where the model is built).
SURFACE_GROUP = (
    Field("surface_triangles", "integer", ("T", 3), "point indices", False, 3, "surface"),
)
FIELDS = (
    Field("format", "text", ()),
    Field("schema_version", "integer", ()),
    Field("meta_json", "text", ()),
    Field("freq_hz", "real", ("M",), "Hz"),
    Field("zeta", "real", ("M",)),
    Field("gamma", "real", ("M", 3), "kg^0.5"),
    Field("shapes", "real", ("K", 3, "M"), "m/kg^0.5"),
    Field("points", "real", ("K", 3), "m"),
    Field("labels", "text", ("K",), required=False),
    *STATIC_FIELDS,
    *CUP_FIELDS,
    *STRESS_FIELDS,
    *ROTATION_GROUP,
    *ROTATION_STATIC_GROUP,
    *ROTATION_CUP_GROUP,
    *ROTATION_STRESS_GROUP,
    *ROTATION_COUPLING_GROUP,
    *SURFACE_GROUP,
)
FIELD_BY_NAME = {f.name: f for f in FIELDS}
HEADER_FIELDS = ("format", "schema_version", "meta_json")  # read first, by name
_GROUPS = (
    ("static", STATIC_FIELDS),
    ("cups", CUP_FIELDS),
    ("stress", STRESS_FIELDS),
    ("rotation", ROTATION_GROUP),
    ("rotation_static", ROTATION_STATIC_GROUP),
    ("rotation_cups", ROTATION_CUP_GROUP),
    ("rotation_stress", ROTATION_STRESS_GROUP),
    ("rotation_coupling", ROTATION_COUPLING_GROUP),
    ("surface", SURFACE_GROUP),
)
OPTIONAL_FIELDS: dict[str, tuple[str, ...]] = {
    group: tuple(f.name for f in fields if f.in_version(SCHEMA_VERSION))
    for group, fields in _GROUPS
}

# Physical ranges of the model's values (closed intervals; jaxflex.model checks them). They are
# far outside any part this tool is for (sheet-metal parts: modes from about 1 Hz to a few
# kHz, participation factors about the square root of the part's mass in kg, mass-normalised
# shapes about its inverse, coordinates of metres), yet far inside float64, so that omega^2,
# the envelope's exponentials and the LP's coefficients never overflow or underflow: a value
# outside is a unit slip or a damaged file, not a part.
VALUE_RANGES: dict[str, tuple[float, float]] = {
    "freq_hz": (1e-3, 1e6),
    "gamma": (-1e6, 1e6),
    "shapes": (-1e6, 1e6),
    "points": (-1e6, 1e6),
    "static_shapes": (-1e6, 1e6),
}


def write_model_file(
    path: str | os.PathLike,
    arrays: dict[str, Any],
    labels: tuple[str, ...] | None,
    meta: dict[str, Any],
) -> None:
    """Write the model ``arrays`` (ARRAY_FIELDS and any complete group of OPTIONAL_FIELDS),
    ``labels`` and ``meta`` to ``path`` (.npz) atomically: the file is complete or absent."""
    stored = {name: np.asarray(arrays[name], dtype=np.float64) for name in ARRAY_FIELDS}
    for group in OPTIONAL_FIELDS.values():
        if any(name in arrays for name in group):
            stored.update({name: _stored(name, arrays[name]) for name in group})
    if labels is not None:
        stored["labels"] = np.asarray(labels, dtype=np.str_)
    with atomic_open(path, "wb") as handle:
        np.savez(
            handle,
            format=np.asarray(FORMAT_NAME),
            schema_version=np.asarray(SCHEMA_VERSION),
            meta_json=np.asarray(json.dumps(dict(meta), sort_keys=True)),
            **stored,
        )


def _stored(name: str, value: Any) -> np.ndarray:
    """``value`` as the array the file stores for field ``name`` (float64, or int64 for an
    integer field)."""
    kind = FIELD_BY_NAME[name].kind
    return np.asarray(value, dtype=np.int64 if kind == "integer" else np.float64)


class _Archive:
    """The members of one open model archive, read one at a time under the checks of the
    module docstring. ``sizes`` collects M and K as the members declare them."""

    def __init__(self, path: Path, archive: zipfile.ZipFile) -> None:
        self.path, self.archive = path, archive
        self.members = {info.filename: info for info in archive.infolist()}
        self.sizes: dict[str, int] = {}

    def fail(self, name: str, problem: str) -> ModelFileError:
        return ModelFileError(f"{str(self.path)!r}: field {name!r}: {problem}")

    def has(self, name: str) -> bool:
        return f"{name}.npy" in self.members

    def read(self, name: str) -> np.ndarray:
        field = FIELD_BY_NAME[name]
        info = self.members.get(f"{name}.npy")
        if info is None:
            raise ModelFileError(f"{str(self.path)!r}: missing field {name!r}")
        if (
            info.compress_type != zipfile.ZIP_STORED
            and info.file_size > MAX_EXPANSION * max(info.compress_size, 1) + 4096
        ):
            raise self.fail(
                name,
                f"expands from {info.compress_size} to {info.file_size} bytes, more than "
                f"{MAX_EXPANSION} times (a zip bomb, not modal data); refused",
            )
        with self.archive.open(info) as stream:
            version = np.lib.format.read_magic(stream)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(stream)
            elif version == (2, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(stream)
            else:
                raise self.fail(name, f"npy format version {version} is not supported")
            self._check_header(field, shape, dtype)
            n_bytes = math.prod(shape) * dtype.itemsize
            header_bytes = stream.tell()
            if header_bytes + n_bytes != info.file_size:
                raise self.fail(
                    name,
                    f"declares shape {shape} of {dtype} ({n_bytes} bytes) but holds "
                    f"{info.file_size - header_bytes} bytes",
                )
            if field.kind == "text" and not field.dims and n_bytes > MAX_TEXT_BYTES:
                raise self.fail(name, f"{n_bytes} bytes of text, more than {MAX_TEXT_BYTES}")
            data = stream.read(n_bytes)
        if len(data) != n_bytes:
            raise self.fail(name, f"truncated: {len(data)} of {n_bytes} bytes")
        return np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C")

    def _check_header(self, field: Field, shape: tuple, dtype: np.dtype) -> None:
        allowed = {"real": "fiu", "integer": "iu", "text": "U"}[field.kind]
        if dtype.hasobject or dtype.kind not in allowed:
            what = {"real": "real numbers", "integer": "an integer", "text": "text"}[field.kind]
            found = "complex numbers" if dtype.kind == "c" else f"data of type {dtype}"
            raise self.fail(field.name, f"holds {found}; expected {what}")
        if len(shape) != len(field.dims):
            raise self.fail(
                field.name,
                f"has shape {shape}; expected {len(field.dims)} dimension(s) {field.dims}",
            )
        if any(size < 0 for size in shape):
            raise self.fail(field.name, f"declares shape {shape}: a size below 0")
        for axis, (dim, size) in enumerate(zip(field.dims, shape, strict=True)):
            if isinstance(dim, int) and size != dim:
                raise self.fail(field.name, f"has shape {shape}; axis {axis} must be {dim}")
            expected = dim if isinstance(dim, int) else self.sizes.setdefault(dim, size)
            if size != expected:
                raise self.fail(
                    field.name,
                    f"has shape {shape}; axis {axis} must be {dim} = {expected} "
                    "(as the other fields declare)",
                )


def _scalar_text(archive: _Archive, name: str) -> str:
    return str(archive.read(name)[()])


def _schema_version(archive: _Archive) -> int:
    version = int(archive.read("schema_version")[()])
    if version not in SUPPORTED_VERSIONS:
        raise ModelFileError(
            f"{str(archive.path)!r}: schema version {version} is not supported by this jaxflex "
            f"(it reads version {', '.join(map(str, SUPPORTED_VERSIONS))}); regenerate the "
            "model with this version"
        )
    return version


def _meta(archive: _Archive) -> dict[str, Any]:
    try:
        meta = json.loads(_scalar_text(archive, "meta_json"))
    except (json.JSONDecodeError, RecursionError) as exc:
        raise archive.fail("meta_json", f"is not valid JSON ({type(exc).__name__}: {exc})") from exc
    if not isinstance(meta, dict):
        raise archive.fail("meta_json", f"must be a JSON object, got {type(meta).__name__}")
    return meta


def _read_fields(archive: _Archive) -> dict[str, Any]:
    fmt = _scalar_text(archive, "format") if archive.has("format") else ""
    if fmt != FORMAT_NAME:
        raise ModelFileError(
            f"{str(archive.path)!r} is not a jaxflex modal model (format field {fmt[:80]!r}, "
            f"expected {FORMAT_NAME!r})"
        )
    version = _schema_version(archive)
    meta = _meta(archive)
    values = {
        field.name: archive.read(field.name)
        for field in FIELDS
        if field.name not in HEADER_FIELDS and field.in_version(version)
        if field.required or archive.has(field.name)
    }
    labels = values.get("labels")
    return {
        **{name: values[name] for name in ARRAY_FIELDS},
        "labels": None if labels is None else tuple(str(s) for s in labels),
        "meta": meta,
        "optional": _optional_groups(archive, values, version),
        "schema_version": version,
    }


def _optional_groups(
    archive: _Archive, values: dict[str, np.ndarray], version: int
) -> dict[str, dict]:
    """The groups of optional fields that ``values`` hold, {group: {field: array}}; a group
    is complete (in the file's schema ``version``) or absent."""
    groups = {}
    for group in OPTIONAL_FIELDS:
        names = [f.name for f in FIELDS if f.group == group and f.in_version(version)]
        present = [name for name in names if name in values]
        if not present:
            continue
        missing = [name for name in names if name not in values]
        if missing:
            raise archive.fail(
                missing[0],
                f"missing: the {group} fields come as a group (found {present}, missing {missing})",
            )
        groups[group] = {name: values[name] for name in names}
    return groups


# what a damaged archive raises inside zipfile, zlib and numpy's header parser
_DAMAGED = (
    zipfile.BadZipFile,
    zlib.error,
    EOFError,
    OSError,
    ValueError,
    KeyError,
    struct.error,
    NotImplementedError,
    RuntimeError,
)


def read_model_file(path: str | os.PathLike) -> dict[str, Any]:
    """The fields of a model file: ARRAY_FIELDS as arrays, ``labels`` (tuple or None) and
    ``meta`` (dict). Raises ModelFileError for a missing, truncated or corrupt file, a file of
    another format, an unknown schema version, a missing field or one whose header does not
    fit the schema (module docstring)."""
    path = Path(path)
    if not path.exists():
        raise ModelFileError(f"model file {str(path)!r} does not exist")
    if not path.is_file():
        raise ModelFileError(f"model file {str(path)!r} is not a file (a directory?)")
    try:
        with path.open("rb") as handle:
            if handle.read(len(_NPY_MAGIC)) == _NPY_MAGIC:
                raise ModelFileError(
                    f"{str(path)!r} is a single numpy array (.npy), not a jaxflex model file "
                    "(.npz archive); write models with `jaxflex model ... -o FILE.npz` or "
                    "ModalModel.save"
                )
            handle.seek(0)
            with zipfile.ZipFile(handle) as archive:
                return _read_fields(_Archive(path, archive))
    except ModelFileError:
        raise
    except _DAMAGED as exc:
        raise ModelFileError(
            f"model file {str(path)!r} is truncated or corrupt ({type(exc).__name__}: {exc}); "
            "regenerate it with `jaxflex model ... -o FILE`"
        ) from exc
