"""Zip archives of a staged folder (FMUs, SSP packages), written atomically, and the
instantiation token of an FMU's content."""

from __future__ import annotations

import hashlib
import os
import uuid
import zipfile
from pathlib import Path

from jaxflex.files import atomic_open


def zip_folder(folder: Path, path: str | os.PathLike) -> None:
    """Write every file under ``folder`` into the zip archive ``path`` (deflated, names
    relative to ``folder`` with forward slashes, sorted), atomically."""
    files = sorted(f for f in Path(folder).rglob("*") if f.is_file())
    with (
        atomic_open(path, "wb") as handle,
        zipfile.ZipFile(handle, "w", zipfile.ZIP_DEFLATED) as zf,
    ):
        for file in files:
            zf.write(file, file.relative_to(folder).as_posix())


def content_token(*parts: bytes) -> str:
    """The instantiation token (FMI 2 guid) of an FMU whose content is ``parts``: a name-based
    UUID (version 5) of their SHA-256, in braces. The same content gives the same token (so
    a rebuilt FMU of the same model and move, under any file name, is the same binary, which
    fmu.build's store reuses); any change of content gives another."""
    digest = hashlib.sha256()
    for part in parts:
        digest.update(len(part).to_bytes(8, "little") + part)
    return "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "jaxflex:" + digest.hexdigest())) + "}"
