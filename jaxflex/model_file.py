"""The modal model file: a versioned ``.npz`` (numpy zip archive, no pickled objects).

Schema version 1 holds:
    format          "jaxflex.modal_model"
    schema_version  1
    freq_hz (M,) Hz, zeta (M,), gamma (M, 3) kg^0.5, shapes (K, 3, M) m/kg^0.5, points (K, 3) m,
    labels (K,) unicode (empty strings: unlabelled; absent array: no labels),
    meta_json       JSON text (source, material, gripper, mesh statistics; SI units).

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
SCHEMA_VERSION = 1
ARRAY_FIELDS = ("freq_hz", "zeta", "gamma", "shapes", "points")


def write_model_file(
    path: str | os.PathLike,
    arrays: dict[str, Any],
    labels: tuple[str, ...] | None,
    meta: dict[str, Any],
) -> None:
    """Write the model ``arrays`` (ARRAY_FIELDS), ``labels`` and ``meta`` to ``path`` (.npz)
    atomically: the file is complete or absent."""
    stored = {name: np.asarray(arrays[name], dtype=np.float64) for name in ARRAY_FIELDS}
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
    if version != SCHEMA_VERSION:
        raise ModelFileError(
            f"{str(path)!r}: schema version {version} is not supported by this jaxflex "
            f"(reads version {SCHEMA_VERSION}); regenerate the model with this version"
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
    }
