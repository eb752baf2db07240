"""A directory of files that belong together, written and read as one set.

Each file is written atomically (jaxflex._atomic), but a run killed between two files would
leave a new file beside an old one. So a set carries ``manifest.json``: the kind of set, an
id of the run that wrote it and the SHA-256 and size of every member. Writing a set

1. takes a lock on the directory (two writers never interleave),
2. checks that every name a member may have is free or a regular file (a symbolic link,
   FIFO, device or directory in the way is refused before anything changes),
3. removes the old manifest (from now on the directory holds no complete set),
4. removes members of an earlier set that this one does not write, and temporary files a
   killed writer left,
5. writes the members, then the manifest last.

Removals and writes are those of the command's outputs (jaxflex._undo): a run that fails
halfway puts the earlier set back.

A reader (:func:`read_set`) accepts the members only if the manifest is there, of the
expected kind, and every member it needs is listed with the size and hash it has on disk;
otherwise it refuses, naming the file. So a set is whole, or readers see none.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

from jaxflex._atomic import (
    check_target,
    make_output_dir,
    remove_output,
    remove_stale_temporaries,
    write_text_atomic,
)
from jaxflex._validation import check_output_dir, check_output_file
from jaxflex.errors import InputError

MANIFEST = "manifest.json"
FORMAT = "jaxflex.file_set"

try:  # POSIX: an advisory lock on the directory itself
    import fcntl
except ImportError:  # Windows: sets are written without a lock
    fcntl = None


def file_digest(path: str | os.PathLike) -> str:
    """SHA-256 of a file's content (hex), read in blocks of 1 MiB."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


@contextlib.contextmanager
def directory_lock(directory: str | os.PathLike, *, option: str | None = None) -> Iterator[None]:
    """Hold an exclusive advisory lock on ``directory`` (an existing directory) while the
    block runs: POSIX ``flock`` on the directory itself, released when the block ends or the
    process dies (also by SIGKILL), so a killed writer never leaves it locked. Without
    ``option`` another holder is waited for; with it, InputError naming ``option`` is raised
    at once. Where there is no ``flock`` (Windows) the block runs unlocked."""
    if fcntl is None:
        yield
        return
    fd = os.open(directory, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (0 if option is None else fcntl.LOCK_NB))
        except BlockingIOError:
            raise InputError(
                f"{option}: {str(directory)!r} is being written by another jaxflex run; wait "
                "for it to end or choose another directory"
            ) from None
        yield
    finally:
        os.close(fd)  # releases the lock


def check_set_dir(option: str, directory: str | os.PathLike, possible: tuple[str, ...]) -> Path:
    """``directory`` if a set with the members ``possible`` may be written there, checked
    before any work (jaxflex._validation.check_output_dir, and every member's name and the
    manifest's free or a regular file: never a link, FIFO, device or directory); InputError
    naming ``option`` and the path otherwise. Nothing is created."""
    root = check_output_dir(option, directory)
    if root.is_dir():
        for name in (*possible, MANIFEST):
            check_output_file(option, root / name)
    return root


class SetWriter:
    """Collects the members of a set being written (see :func:`writing`)."""

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self.members: dict[str, dict] = {}

    def add(self, name: str, write: Callable[[Path], object]) -> Path:
        """Member ``name``: ``write(path)`` writes it (atomically); it is then hashed."""
        path = self.directory / name
        write(path)
        self.members[name] = {"sha256": file_digest(path), "bytes": path.stat().st_size}
        return path

    def add_text(self, name: str, text: str) -> Path:
        return self.add(name, lambda path: write_text_atomic(path, text))


@contextlib.contextmanager
def writing(
    directory: str | os.PathLike, kind: str, possible: tuple[str, ...]
) -> Iterator[SetWriter]:
    """Write a set of ``kind`` into ``directory`` (module docstring). ``possible`` names
    every member a set of this kind may have: those this run does not write are removed.
    The manifest is written when the block ends without an exception."""
    root = make_output_dir(directory)
    with directory_lock(root):
        for name in (*possible, MANIFEST):
            check_target(root / name)
        remove_output(root / MANIFEST)
        for name in (*possible, MANIFEST):
            remove_stale_temporaries(root / name)
        writer = SetWriter(root)
        yield writer
        for name in possible:
            if name not in writer.members:
                remove_output(root / name)
        manifest = {
            "format": FORMAT,
            "kind": kind,
            "set_id": uuid.uuid4().hex,
            "files": dict(sorted(writer.members.items())),
        }
        write_text_atomic(root / MANIFEST, json.dumps(manifest, indent=2) + "\n")


def read_set(
    directory: str | os.PathLike, kind: str, needed: tuple[str, ...], *, option: str
) -> dict[str, Path]:
    """The members of the complete set of ``kind`` in ``directory`` (name -> path), after
    checking that each of ``needed`` is listed in its manifest with the size and hash it has
    on disk. Raises InputError naming ``option`` and the file that does not belong."""
    root = Path(directory)
    manifest_path = root / MANIFEST
    rerun = "write it again (the run that wrote it was interrupted, or is older than this check)"
    if not manifest_path.is_file():
        raise InputError(
            f"{option}: {str(root)!r} holds no complete result set ({MANIFEST} is missing); "
            + rerun
        )
    try:
        manifest = json.loads(manifest_path.read_text(encoding="utf-8"))
        files = manifest["files"]
        ok = manifest["format"] == FORMAT and isinstance(files, dict)
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError) as exc:
        raise InputError(
            f"{option}: {str(manifest_path)!r} is unreadable ({exc}); " + rerun
        ) from exc
    if not ok or manifest.get("kind") != kind:
        raise InputError(
            f"{option}: {str(root)!r} holds a set of kind {manifest.get('kind')!r}, expected "
            f"{kind!r}"
        )
    for name in needed:
        path = root / name
        entry = files.get(name)
        if not isinstance(entry, dict):
            raise InputError(f"{option}: {str(path)!r} is not part of the set in {MANIFEST}")
        if not path.is_file():
            raise InputError(f"{option}: {str(path)!r} is missing from the set; " + rerun)
        if path.stat().st_size != entry.get("bytes") or file_digest(path) != entry.get("sha256"):
            raise InputError(
                f"{option}: {str(path)!r} does not belong to the set: its content differs from "
                f"what {MANIFEST} records (edited, or written by another run); " + rerun
            )
    return {name: root / name for name in files if (root / name).is_file()}
