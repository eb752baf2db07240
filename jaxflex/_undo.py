"""Whole or absent: what a command writes is undone when the command fails.

A command writes several files: ``jaxflex export`` the .fmu and beside it the move's input
CSV and case JSON, ``jaxflex model`` the model, a picture and a report, ``optimize`` a
result set. Each file is written atomically (jaxflex._atomic), but a failure between two
files (a side file refused, a full disk, an interrupt) would leave the first behind. Inside
:func:`whole_or_absent` (the dispatcher, jaxflex.cli, runs every command in one) each output
written is recorded:

* the file it replaces is kept under a temporary name beside it (a second hard link: no
  copy, and the target is still replaced in one rename, never written in place);
* a file removed (an earlier set's member) is moved aside the same way;
* a directory created is remembered.

When the block ends with an exception (KeyboardInterrupt included) all of it is undone in
reverse order: the new files removed, the earlier ones put back, the new directories removed
if empty. When it ends normally, the earlier files kept aside are dropped. Blocks nest: an
inner block that ends well hands its record to the outer one.

Only **declared outputs** are recorded: paths checked by
:func:`jaxflex._validation.check_output_file` / :func:`~jaxflex._validation.check_output_dir`
inside the block (every command checks its outputs before any work), and every file and
directory under a declared directory. Stores of reusable work (the compilation cache, the
FE and FMU-binary stores) are not outputs: what a failed run added to them stays, as do
writes inside :func:`kept_writes` (a sweep's case records, which its rerun resumes from).
Writes from threads the block started are not recorded (a ContextVar: threads do not
inherit it). A killed process (SIGKILL) cannot undo; the earlier files it kept aside stay
under their temporary names, which the next write of a file set removes
(jaxflex._atomic.remove_stale_temporaries).
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import secrets
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

KEPT_SUFFIX = ".old"  # the earlier file's temporary name: .NAME.PID-HEX.old


@dataclass
class _Change:
    """One change to undo: ``path`` now holds the file of ``identity`` (st_dev, st_ino),
    or nothing (None: removed); ``earlier`` is where its earlier file was kept (a name
    beside it), None if there was none; ``directory``: a directory created."""

    path: Path
    identity: tuple[int, int] | None
    earlier: str | None
    directory: bool = False


@dataclass
class _Record:
    declared: set[Path] = field(default_factory=set)
    changes: list[_Change] = field(default_factory=list)

    def covers(self, path: Path) -> bool:
        key = _key(path)
        return key in self.declared or any(parent in self.declared for parent in key.parents)


_CURRENT: contextvars.ContextVar[_Record | None] = contextvars.ContextVar("undo", default=None)


def _key(path: Path) -> Path:
    """``path`` with its directory resolved (the last part as it is: never a link here)."""
    path = Path(path)
    return Path(os.path.realpath(path.parent)) / path.name


def _identity(path: Path) -> tuple[int, int] | None:
    try:
        info = os.lstat(path)
    except OSError:
        return None
    return info.st_dev, info.st_ino


def _recording(path: Path) -> _Record | None:
    record = _CURRENT.get()
    return record if record is not None and record.covers(path) else None


def declare(path: str | os.PathLike) -> None:
    """``path`` (a file, or a directory and everything under it) is an output of the
    current :func:`whole_or_absent` block (nothing without one)."""
    record = _CURRENT.get()
    if record is not None:
        record.declared.add(_key(Path(path)))


def _keep_aside(path: Path, *, move: bool) -> str | None:
    """The regular file at ``path`` kept under a new temporary name beside it: linked
    (``move`` False: ``path`` still holds it) or renamed there; None if there is none.
    Where hard links are not supported, a link falls back to a rename."""
    try:
        if not os.path.isfile(path) or os.path.islink(path):
            return None
    except OSError:
        return None
    name = str(path.parent / f".{path.name}.{os.getpid()}-{secrets.token_hex(8)}{KEPT_SUFFIX}")
    if not move:
        try:
            os.link(path, name, follow_symlinks=False)
            return name
        except (OSError, NotImplementedError):  # no hard links here: moved instead
            pass
    os.replace(path, name)
    return name


def replace(tmp_name: str, target: Path) -> None:
    """``os.replace(tmp_name, target)``, recorded for undo when ``target`` is a declared
    output of the current block (module docstring). OSError as os.replace raises it."""
    record = _recording(target)
    if record is None:
        os.replace(tmp_name, target)
        return
    earlier = _keep_aside(target, move=False)
    try:
        os.replace(tmp_name, target)
    except BaseException:
        if earlier is not None and not os.path.lexists(target):
            os.replace(earlier, target)
        elif earlier is not None:
            os.unlink(earlier)
        raise
    record.changes.append(_Change(target, _identity(target), earlier))


def remove(path: Path) -> None:
    """Remove the file ``path`` if there is one (not a directory), recorded for undo when it
    is a declared output of the current block."""
    record = _recording(path)
    if record is None:
        path.unlink(missing_ok=True)
        return
    earlier = _keep_aside(path, move=True)
    if earlier is None:
        path.unlink(missing_ok=True)  # a link or nothing: nothing to keep
    else:
        record.changes.append(_Change(path, None, earlier))


def created_directory(path: Path) -> None:
    """The directory ``path`` was just created (removed again on undo, if empty)."""
    record = _recording(path)
    if record is not None:
        record.changes.append(_Change(path, _identity(path), None, directory=True))


def _undo_one(change: _Change) -> None:
    """Undo ``change`` (again from where an interrupted attempt left it: each step checks
    what is there); what cannot be undone (someone changed the path meanwhile) is left."""
    with contextlib.suppress(OSError):
        if change.directory:
            if _identity(change.path) == change.identity:
                os.rmdir(change.path)  # only an empty one
            return
        if change.identity is not None and _identity(change.path) == change.identity:
            os.unlink(change.path)
        if change.earlier is not None:
            if os.path.lexists(change.path):
                os.unlink(change.earlier)
            else:
                os.replace(change.earlier, change.path)


def _undo(changes: list[_Change]) -> None:
    """Undo ``changes``, the last first. An interrupt meanwhile (Ctrl-C, repeated by the
    dispatcher until it is handled) does not stop it halfway: the step is done again and
    the interrupt raised when all is undone."""
    interrupted = None
    for change in reversed(changes):
        while True:
            try:
                _undo_one(change)
                break
            except KeyboardInterrupt as exc:
                interrupted = exc
    if interrupted is not None:
        raise interrupted


def _drop_earlier(changes: list[_Change]) -> None:
    for change in changes:
        if change.earlier is not None:
            with contextlib.suppress(OSError):
                os.unlink(change.earlier)


@contextlib.contextmanager
def whole_or_absent() -> Iterator[None]:
    """Everything written to declared outputs inside the block is undone if the block
    raises (module docstring)."""
    outer = _CURRENT.get()
    record = _Record(set() if outer is None else set(outer.declared))
    token = _CURRENT.set(record)
    try:
        yield
    except BaseException:
        _CURRENT.reset(token)
        _undo(record.changes)
        raise
    _CURRENT.reset(token)
    if outer is None:
        _drop_earlier(record.changes)
    else:
        outer.changes.extend(record.changes)
        outer.declared |= record.declared


@contextlib.contextmanager
def kept_writes() -> Iterator[None]:
    """Writes inside the block stay whatever happens after it (stores a rerun resumes
    from): they are not recorded by an enclosing :func:`whole_or_absent`."""
    token = _CURRENT.set(None)
    try:
        yield
    finally:
        _CURRENT.reset(token)
