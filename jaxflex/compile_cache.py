"""jaxflex's cache of compiled work: JAX's persistent compilation cache (compile a program
once, load it on every later run), and beside it the stores of other work a later run can
reuse (:func:`store`: the FMU binaries gcc built, fmu.build; the built-in scenes' FE models,
fem.scenes).

The directory is ``$JAXFLEX_COMPILE_CACHE`` when set, else ``jax`` in the user's cache
directory (platformdirs: ``$XDG_CACHE_HOME/jaxflex/jax``, by default ``~/.cache/jaxflex/jax``
on Linux). ``JAXFLEX_COMPILE_CACHE=off`` disables it; so does a directory that cannot be
created or written (the run compiles as without a cache, and says why in its step lines).

Every program is cached, however small or quick to compile (a run of ``jaxflex optimize``
compiles a handful, each 0.1-1 s). Entries are written atomically (a temporary file beside
the entry, then a rename), so runs sharing the directory at the same time never read a
half-written entry; an entry that cannot be read (a disk error, a writer of another JAX
version) counts as absent and is replaced by the next compilation. JAX's own file cache
writes in place, which another process can read half-written; the entries here have its
file names and format. The directory holds at most MAX_BYTES: the least recently used
entries go first. The other stores are subdirectories of it (:func:`store`), each with its
own size limit, written the same way; their keys hash everything their work reads, so a
changed input is a miss, never a stale answer. The cache is trusted code (JAX's warning):
keep it private to its user (the directories are created with mode 0700).
"""

from __future__ import annotations

import contextlib
import functools
import os
import tempfile
import threading
import time
from pathlib import Path

from jaxflex.lazy import after_import

ENV_VAR = "JAXFLEX_COMPILE_CACHE"
OFF = "off"
MAX_BYTES = 2 * 1024**3  # the least recently used entries are removed beyond this
SUFFIX = "-cache"  # JAX's file cache names its entries KEY-cache
STALE_TMP_S = 3600.0  # temporaries of killed writers: removed after this long

_lock = threading.Lock()
_state: dict[str, object] = {}  # "directory": Path | None, "reason": str (once per process)


def default_dir() -> Path:
    """``jax`` in the user's cache directory (``$XDG_CACHE_HOME/jaxflex/jax`` on Linux)."""
    from platformdirs import user_cache_path

    return user_cache_path("jaxflex", appauthor=False) / "jax"


def chosen_dir() -> Path | None:
    """The directory :func:`enable` uses: ``$JAXFLEX_COMPILE_CACHE`` (None for ``off``), else
    :func:`default_dir`."""
    given = os.environ.get(ENV_VAR, "").strip()
    if given.lower() == OFF:
        return None
    return Path(given).expanduser() if given else default_dir()


def _writable(directory: Path) -> str | None:
    """None if entries can be written into ``directory`` (created, mode 0700, if absent),
    else why not."""
    try:
        directory.mkdir(mode=0o700, parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".probe-", dir=directory)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        return f"{directory} is not writable ({exc.strerror or exc})"
    return None


def enable(directory: str | os.PathLike | None = None) -> tuple[Path | None, str]:
    """Turn JAX's persistent compilation cache on for this process, at ``directory`` or
    :func:`chosen_dir`: now if JAX is loaded, else as it is imported (a run that needs no
    JAX does not load it). Returns (the directory or None if the cache is off, a short
    description for a step line). Only the first call of a process decides: JAX reads its
    cache settings once."""
    with _lock:
        if "reason" not in _state:
            target = Path(directory) if directory is not None else chosen_dir()
            if target is None:
                _state.update(directory=None, reason=f"off ({ENV_VAR}={OFF})")
            elif (problem := _writable(target)) is not None:
                _state.update(directory=None, reason=f"off: {problem}")
            else:
                after_import("jax", functools.partial(_install, target))  # when JAX loads
                _state.update(directory=target, reason=str(target))
        return _state["directory"], _state["reason"]


def _install(directory: Path, jax) -> None:
    """Point JAX (the module ``jax``, just imported) at ``directory`` with the atomic file
    store, caching every program."""
    jax.config.update("jax_compilation_cache_dir", str(directory))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", -1)
    try:  # JAX's cache module (private; checked with jax 0.10)
        from jax._src import compilation_cache as jax_cache
        from jax._src.compilation_cache_interface import CacheInterface

        mutex = jax_cache._cache_initialized_mutex
    except (ImportError, AttributeError):  # another layout: JAX's own file store
        return

    class AtomicFileStore(FileStore, CacheInterface):
        pass

    with mutex:
        if not jax_cache._cache_initialized:
            jax_cache._cache = AtomicFileStore(directory, jax_cache.decompress_executable)
            jax_cache._cache_initialized = True


def store(name: str, max_bytes: int, check=None) -> FileStore | None:
    """The store ``name`` (a subdirectory of :func:`chosen_dir`) holding at most
    ``max_bytes``, ``check`` as :class:`FileStore`'s; None when the cache is off or the
    directory cannot be written (the work is then done every time)."""
    directory = chosen_dir()
    if directory is None or _writable(directory / name) is not None:
        return None
    return FileStore(directory / name, check, max_bytes=max_bytes)


class FileStore:
    """Entries (bytes by key) in files written atomically; an unreadable entry is a miss.
    ``check(data)`` raises on a damaged entry (JAX's decompressor for JAX's programs). The
    get/put pair is JAX's cache interface."""

    def __init__(self, directory: Path, check=None, *, max_bytes: int = MAX_BYTES) -> None:
        self._path = directory
        self._check = check
        self._max_bytes = max_bytes

    def get(self, key: str) -> bytes | None:
        path = self._path / f"{key}{SUFFIX}"
        try:
            data = path.read_bytes()
            if self._check is not None:
                self._check(data)  # a damaged entry: a miss, replaced by put
            os.utime(path)  # recently used (eviction)
        except Exception:  # absent, or damaged (whatever the check raises): a miss
            return None
        return data

    def put(self, key: str, value: bytes) -> None:
        from jaxflex.atomic import atomic_open

        with contextlib.suppress(OSError):  # disk full, directory gone: not cached
            with atomic_open(self._path / f"{key}{SUFFIX}", "wb") as handle:
                handle.write(value)
            _evict(self._path, self._max_bytes)


def _evict(directory: Path, max_bytes: int) -> None:
    """Remove the least recently used entries of ``directory`` until they fit in
    ``max_bytes``, and temporaries older than STALE_TMP_S (writers killed mid-write)."""
    entries = []
    now = time.time()
    for path in directory.iterdir():
        with contextlib.suppress(OSError):
            info = path.stat()
            if path.name.endswith(SUFFIX):
                entries.append((info.st_mtime, info.st_size, path))
            elif path.name.startswith(".") and now - info.st_mtime > STALE_TMP_S:
                path.unlink()
    total = sum(size for _, size, _ in entries)
    for _, size, path in sorted(entries):
        if total <= max_bytes:
            break
        with contextlib.suppress(OSError):
            path.unlink()
        total -= size
