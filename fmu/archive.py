"""Zip archives of a staged folder (FMUs, SSP packages), written atomically."""

from __future__ import annotations

import os
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
