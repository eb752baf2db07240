"""Atomic file writes: write to a temporary file beside the target, then rename over it.

A reader never sees a half-written file, and an interrupted write leaves the old file intact.
The written file gets the permissions any program's new file gets: 0666 minus the umask
(typically 0644, readable by colleagues and build servers), not the 0600 of a private
temporary file.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import stat
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from jaxflex.errors import OutputError
from jaxflex.inputs import file_kind

STALE_AFTER_S = 3600.0


def make_output_dir(path: str | os.PathLike) -> Path:
    """The output directory ``path``, created if absent (one level: its parent must exist);
    OutputError if it cannot be."""
    target = Path(path)
    try:
        target.mkdir(exist_ok=True)
    except FileNotFoundError:
        raise OutputError(
            f"cannot create the directory {str(target)!r}: {str(target.parent)!r} does not "
            "exist (jaxflex writes only into existing directories)"
        ) from None
    except OSError as exc:
        raise OutputError(f"cannot create the directory {str(target)!r}: {exc}") from None
    if not target.is_dir():
        raise OutputError(f"{str(target)!r} exists and is not a directory")
    return target


def check_target(target: Path) -> Path:
    """The path a rename writes ``target`` at (a symbolic link's target: the link stays);
    OutputError unless its directory exists and it is absent or a regular file (a device,
    FIFO, socket or directory would be replaced)."""
    if target.is_symlink():
        try:
            target = target.resolve(strict=True)
        except (OSError, RuntimeError) as exc:
            raise OutputError(f"cannot write {str(target)!r}: a link to nothing ({exc})") from None
    if not target.parent.is_dir():
        raise OutputError(
            f"cannot write {str(target)!r}: the directory {str(target.parent)!r} does not exist "
            "(jaxflex writes only into existing directories)"
        )
    try:
        mode = target.stat().st_mode
    except FileNotFoundError:
        return target
    except OSError as exc:
        raise OutputError(f"cannot write {str(target)!r}: {exc}") from None
    if not stat.S_ISREG(mode):
        raise OutputError(
            f"cannot write {str(target)!r}: it is {file_kind(mode)}; only regular files are "
            "written (it is left as it is)"
        )
    return target


def _create_beside(target: Path, suffix: str) -> tuple[int, str]:
    """A new, empty file with a random name beside ``target`` (descriptor, name), created
    with mode 0666 so that the umask decides its permissions. The name carries the writer's
    process id, so that :func:`remove_stale_temporaries` can tell a killed writer's file from
    a live one's. OutputError if ``target`` may not be written (:func:`check_target`)."""
    target = check_target(target)
    name = str(target.parent / f".{target.name}.{os.getpid()}-{secrets.token_hex(8)}{suffix}")
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    try:
        return os.open(name, flags, 0o666), name
    except OSError as exc:
        raise OutputError(f"cannot write {str(target)!r}: {exc.strerror or exc}") from None


def _replace(tmp_name: str, target: Path) -> None:
    """Rename the finished temporary file onto ``target`` (checked again: it may have
    changed meanwhile)."""
    target = check_target(target)
    try:
        os.replace(tmp_name, target)
    except OSError as exc:
        raise OutputError(f"cannot write {str(target)!r}: {exc.strerror or exc}") from None


def _writer_alive(entry: Path, pid: str | None) -> bool:
    """Whether the process ``pid`` that created the temporary file ``entry`` may still be
    writing it: it runs (POSIX); on other systems, and for names without a process id,
    whether the file changed within STALE_AFTER_S."""
    if os.name == "posix" and pid is not None:
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            return False
        except OSError:  # EPERM: alive, another user's
            return True
        return True
    try:
        return time.time() - entry.stat().st_mtime < STALE_AFTER_S
    except OSError:
        return False


def remove_stale_temporaries(path: str | os.PathLike) -> list[Path]:
    """Remove the temporary files a killed writer of ``path`` left beside it (those of live
    writers stay); returns the removed paths."""
    target = Path(path)
    pattern = re.compile(rf"\.{re.escape(target.name)}\.(?:(\d+)-)?[0-9a-f]{{16}}(?:\..*)?")
    removed = []
    if not target.parent.is_dir():
        return removed
    for entry in target.parent.iterdir():
        match = pattern.fullmatch(entry.name)
        if match and not _writer_alive(entry, match.group(1)):
            with contextlib.suppress(FileNotFoundError, IsADirectoryError, PermissionError):
                entry.unlink()
                removed.append(entry)
    return removed


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = ".tmp") -> Iterator[str]:
    """For writers that open files by name: the name of a new empty file beside ``path``
    (ending in ``suffix``), renamed onto ``path`` when the block succeeds.

    On any exception the temporary file is removed and ``path`` is left untouched.
    """
    target = Path(path)
    fd, tmp_name = _create_beside(target, suffix)
    os.close(fd)
    try:
        yield tmp_name
        _replace(tmp_name, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp_name)
        raise


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike, mode: str = "wb") -> Iterator[IO]:
    """Open a temporary file next to ``path``; on success rename it to ``path``.

    On any exception the temporary file is removed and ``path`` is left untouched.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open: mode must be 'w' or 'wb', got {mode!r}")
    target = Path(path)
    fd, tmp_name = _create_beside(target, ".tmp")
    try:
        with os.fdopen(fd, mode, **({} if "b" in mode else {"encoding": "utf-8"})) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        _replace(tmp_name, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp_name)
        raise


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_open(path, "w") as handle:
        handle.write(text)
