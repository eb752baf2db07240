"""The modal model file: a versioned ``.npz`` (numpy zip archive, no pickled objects).

Schema version 2 holds:
    format          "jaxflex.modal_model"
    schema_version  2
    freq_hz (M,) Hz, zeta (M,), gamma (M, 3) kg^0.5, shapes (K, 3, M) m/kg^0.5, points (K, 3) m,
    labels (K,) unicode (empty strings: unlabelled; absent array: no labels),
    meta_json       JSON text (source, material, gripper, mesh statistics; SI units),
and, optionally, the groups of OPTIONAL_FIELDS (all fields of a group or none; see
jaxflex.outputs for their meaning): the cups and their reactions, the surface stresses.
Version 1 files (the same without optional fields) are read as well.

This module knows the file, not the model class: it writes and reads plain arrays, and
jaxflex.model turns them into a validated ModalModel.
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from jaxflex.atomic import atomic_open
from jaxflex.errors import ModelFileError

FORMAT_NAME = "jaxflex.modal_model"
SCHEMA_VERSION = 2
READABLE_VERSIONS = (1, 2)
ARRAY_FIELDS = ("freq_hz", "zeta", "gamma", "shapes", "points")
# Optional fields (schema version 2), by group: name -> (number of dimensions, meaning).
# C cups, S stress points, M modes. Reactions: force (N) and moment about the cup centre
# (N m) that cup c exerts on the part, rows (F_x, F_y, F_z, M_x, M_y, M_z); stresses: Voigt
# (xx, yy, zz, yz, xz, xy) in Pa. "_q": per unit modal coordinate (kg^0.5 m), "_v": per unit
# modal velocity (kg^0.5 m/s), "_a": per unit base acceleration (m/s^2).
OPTIONAL_FIELDS: dict[str, dict[str, tuple[int, str]]] = {
    "cups": {
        "cup_centre_m": (2, "(C, 3) cup centres, m"),
        "cup_normal": (2, "(C, 3) unit surface normals, from the part into the cup"),
        "cup_radius_m": (1, "(C,) effective suction radius, m"),
        "cup_holding_force_n": (1, "(C,) holding force (vacuum x effective area), N"),
        "cup_friction": (1, "(C,) friction coefficient between cup and part"),
        "cup_reaction_q": (3, "(C, 6, M) reaction per unit modal coordinate, N or N m"),
        "cup_reaction_v": (3, "(C, 6, M) reaction per unit modal velocity"),
        "cup_reaction_a": (3, "(C, 6, 3) reaction per unit base acceleration"),
    },
    "stress": {
        "stress_points_m": (2, "(S, 3) surface points where the stress is known, m"),
        "stress_q": (3, "(S, 6, M) stress per unit modal coordinate, Pa"),
        "stress_v": (3, "(S, 6, M) stress per unit modal velocity, Pa"),
        "stress_a": (3, "(S, 6, 3) stress per unit base acceleration, Pa"),
    },
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
            stored.update({name: np.asarray(arrays[name], dtype=np.float64) for name in group})
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


def read_model_file(path: str | os.PathLike) -> dict[str, Any]:
    """The fields of a model file: ARRAY_FIELDS as arrays, ``labels`` (tuple or None) and
    ``meta`` (dict). Raises ModelFileError for a missing, truncated or corrupt file, a file of
    another format, an unknown schema version or a missing field."""
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"model file {str(path)!r} does not exist")
    try:
        with np.load(path, allow_pickle=False) as data:
            contents = {key: data[key] for key in data.files}
    except (zipfile.BadZipFile, EOFError, ValueError, OSError, KeyError) as exc:
        raise ModelFileError(
            f"model file {str(path)!r} is truncated or corrupt ({type(exc).__name__}: {exc}); "
            "regenerate it with `jaxflex model ... -o FILE`"
        ) from exc
    fmt = str(contents.get("format", ""))
    if fmt != FORMAT_NAME:
        raise ModelFileError(
            f"{str(path)!r} is not a jaxflex modal model (format field {fmt!r}, "
            f"expected {FORMAT_NAME!r})"
        )
    if "schema_version" not in contents:
        raise ModelFileError(f"{str(path)!r}: missing field 'schema_version'")
    version = int(contents["schema_version"])
    if version not in READABLE_VERSIONS:
        raise ModelFileError(
            f"{str(path)!r}: schema version {version} is not supported by this jaxflex "
            f"(reads versions {list(READABLE_VERSIONS)}); regenerate the model with this version"
        )
    for name in (*ARRAY_FIELDS, "meta_json"):
        if name not in contents:
            raise ModelFileError(f"{str(path)!r}: missing field {name!r}")
    try:
        meta = json.loads(str(contents["meta_json"]))
    except json.JSONDecodeError as exc:
        raise ModelFileError(f"{str(path)!r}: field 'meta_json' is not valid JSON ({exc})") from exc
    labels = contents.get("labels")
    return {
        **{name: contents[name] for name in ARRAY_FIELDS},
        "labels": None if labels is None else tuple(str(s) for s in labels),
        "meta": meta,
        "optional": _optional_groups(path, contents, version),
    }


def _optional_groups(path: Path, contents: dict, version: int) -> dict[str, dict]:
    """The complete groups of OPTIONAL_FIELDS in ``contents``: {group: {field: array}}."""
    groups = {}
    for group, spec in OPTIONAL_FIELDS.items():
        present = [name for name in spec if name in contents]
        if not present:
            continue
        missing = [name for name in spec if name not in contents]
        if version < 2 or missing:
            raise ModelFileError(
                f"{str(path)!r}: the {group} fields come as a group in schema version 2; "
                f"found {present}, missing {missing or 'none'} (schema version {version})"
            )
        for name, (ndim, meaning) in spec.items():
            if contents[name].ndim != ndim:
                raise ModelFileError(
                    f"{str(path)!r}: field {name!r} must be {ndim}-D ({meaning}), "
                    f"got shape {contents[name].shape}"
                )
        groups[group] = {name: contents[name] for name in spec}
    return groups
