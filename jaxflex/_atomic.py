"""Atomic file writes: write to a temporary file beside the target, then rename over it.

Every file a command writes goes through this module: :func:`atomic_open` (a file object),
:func:`atomic_path` (a new file's name, for writers that open files themselves: meshio,
ffmpeg) or :func:`write_text_atomic`; a command checks its output options first with
jaxflex._validation's ``check_output_file`` / ``check_output_dir`` (which also declares them
outputs of the command: jaxflex._undo). Then:

* A reader never sees a half-written file, and an interrupted write leaves the old file
  intact.
* The file is created fresh in the target's directory (a new name, ``O_EXCL``) and renamed
  over the target only when the target is a regular file or absent. A symbolic link, a
  device, a FIFO, a socket or a directory in its place is refused (OutputError naming the
  path) and left as it is: nothing is ever written through a link or into another file. A
  target with other hard links gets a new file under its name; its other names keep the
  old content (the rename replaces one name, nothing is written in place).
* What a command writes is whole or absent: a failure after some of its outputs are
  written undoes them (jaxflex._undo, for the outputs it declared).

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

from jaxflex import _undo as undo
from jaxflex._inputs import file_kind
from jaxflex.errors import OutputError

STALE_AFTER_S = 3600.0


def make_output_dir(path: str | os.PathLike) -> Path:
    """The output directory ``path``, created if absent (one level: its parent must exist);
    OutputError if it cannot be, or if ``path`` is a symbolic link (jaxflex does not write
    through links) or another file."""
    target = Path(path)
    mode = _lstat_mode(target)
    if mode is not None and stat.S_ISLNK(mode):
        raise OutputError(f"cannot write {str(target)!r}: it is {link_refusal(target)}")
    if mode is None:
        try:
            target.mkdir()
        except FileNotFoundError:
            raise OutputError(
                f"cannot create the directory {str(target)!r}: {str(target.parent)!r} does not "
                "exist (jaxflex writes only into existing directories)"
            ) from None
        except FileExistsError:  # created meanwhile: checked below
            pass
        except OSError as exc:
            raise OutputError(f"cannot create the directory {str(target)!r}: {exc}") from None
        else:
            undo.created_directory(target)
        mode = _lstat_mode(target)
    if mode is None or not stat.S_ISDIR(mode):
        kind = "a symbolic link" if mode is not None and stat.S_ISLNK(mode) else "not a directory"
        raise OutputError(f"{str(target)!r} exists and is {kind}")
    return target


def _lstat_mode(target: Path) -> int | None:
    """The mode of what ``target`` names (a link itself, not followed), None if nothing;
    OutputError if the system cannot tell."""
    try:
        return os.lstat(target).st_mode
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise OutputError(f"cannot write {str(target)!r}: {exc.strerror or exc}") from None


def link_refusal(target: Path) -> str:
    """What the symbolic link ``target`` is (where it points) and why it is not written."""
    try:
        to = os.readlink(target)
    except OSError as exc:
        to = f"unreadable ({exc.strerror})"
    ends = "" if target.exists() else ", which does not exist"
    return (
        f"a symbolic link (to {to!r}{ends}); jaxflex never writes through a link (it is left "
        "as it is): give the path of the file itself, or remove the link"
    )


def check_target(target: Path) -> Path:
    """``target`` if a rename may put a new file there: its directory exists and it is
    absent or a regular file; OutputError naming it otherwise (a symbolic link, device, FIFO,
    socket or directory: it is left as it is)."""
    target = Path(target)
    if not target.parent.is_dir():
        raise OutputError(
            f"cannot write {str(target)!r}: the directory {str(target.parent)!r} does not exist "
            "(jaxflex writes only into existing directories)"
        )
    mode = _lstat_mode(target)
    if mode is None:
        return target
    if stat.S_ISLNK(mode):
        raise OutputError(f"cannot write {str(target)!r}: it is {link_refusal(target)}")
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
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL
    flags |= getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_BINARY", 0)
    try:
        return os.open(name, flags, 0o666), name
    except OSError as exc:
        raise OutputError(f"cannot write {str(target)!r}: {exc.strerror or exc}") from None


def _replace(tmp_name: str, target: Path) -> None:
    """Rename the finished temporary file onto ``target`` (checked again: it may have
    changed meanwhile; a link put there after the check is replaced itself, never
    followed: a rename does not follow the target)."""
    target = check_target(target)
    try:
        undo.replace(tmp_name, target)
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


def remove_output(path: str | os.PathLike) -> None:
    """Remove the earlier output ``path`` if there is one (a regular file; a link itself,
    never its target): undone with the command's other writes if the command fails."""
    target = Path(path)
    mode = _lstat_mode(target)
    if mode is not None and stat.S_ISDIR(mode):
        raise OutputError(f"cannot remove {str(target)!r}: it is a directory (left as it is)")
    try:
        undo.remove(target)
    except OSError as exc:
        raise OutputError(f"cannot remove {str(target)!r}: {exc.strerror or exc}") from None


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
