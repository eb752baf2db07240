"""jaxflex's cache of compiled work: JAX's persistent compilation cache (compile a program
once, load it on every later run), and beside it the stores of other work a later run can
reuse (:func:`store`: the FMU binaries gcc built, fmu.build; the FE models, fem.model_store).

The directory is ``$JAXFLEX_COMPILE_CACHE`` when set, else ``jax`` in the user's cache
directory (platformdirs: ``$XDG_CACHE_HOME/jaxflex/jax``, by default ``~/.cache/jaxflex/jax``
on Linux). ``JAXFLEX_COMPILE_CACHE=off`` disables it; so does a directory that cannot be
created or written (the run compiles as without a cache, and says why in its step lines).
JAX is pointed at it as JAX is imported (a command that needs no JAX does not load it).

Every program is cached, however small or quick to compile (a run of ``jaxflex optimize``
compiles a handful, each 0.1-1 s). Every entry of every store is checked on every read and
is a miss unless it is whole and the one asked for (:func:`decode_entry`: it carries its key
and the SHA-256 of its content; :func:`read_regular`: only a regular file within the
store's size is read, never a link, a FIFO or a device); a miss is made again and replaces
the entry. Entries are written atomically (jaxflex._atomic: a new file beside the entry, then a
rename; JAX's own file store writes in place, which another process can read half-written);
the JAX entries keep its file names. Keys do not depend on the cache's path (JAX's GPU
caches, whose directory would enter its keys, are off), so a copied cache is used. Each
directory holds at most its size limit (JAX's: MAX_BYTES): the least recently used entries
go first. The other stores are subdirectories (:func:`store`); their keys hash everything
their work reads, so a changed input is a miss, never a stale answer; :func:`fetch` makes a
run wait for an entry another run is making (a lock file) instead of making it twice. The
cache is trusted code (JAX's warning): keep it private to its user (the directories are
created with mode 0700).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
import stat
import tempfile
import threading
import time
from pathlib import Path

from jaxflex._atomic import atomic_open
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
    # no GPU caches beside the programs: their directory would enter every key, and a
    # copied or moved cache would never be used
    jax.config.update("jax_persistent_cache_enable_xla_caches", "none")
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
            jax_cache._cache = AtomicFileStore(directory)
            jax_cache._cache_initialized = True


def store(name: str, max_bytes: int) -> FileStore | None:
    """The store ``name`` (a subdirectory of :func:`chosen_dir`) holding at most
    ``max_bytes``; None when the cache is off or the directory cannot be written (the work is
    then done every time)."""
    directory = chosen_dir()
    if directory is None or _writable(directory / name) is not None:
        return None
    return FileStore(directory / name, max_bytes=max_bytes)


# An entry: MAGIC, one line of JSON {"key": KEY, "bytes": N, "sha256": HEX} (the key: for
# jaxflex's stores the SHA-256 of everything the work reads, for JAX its own hash of the
# program), then the N bytes of the content. Read back only if the key is the one asked for
# and the content has the size and hash written: a cut, flipped, swapped or foreign entry is
# a miss.
MAGIC = b"jaxflex-cache-entry 1\n"
MAX_HEADER_BYTES = 1024
LOCK_TIMEOUT_S = 900.0  # the longest a run waits for another building the same entry
LOCK_POLL_S = 0.1


def encode_entry(key: str, value: bytes) -> bytes:
    """The file content of the entry ``value`` under ``key`` (see MAGIC)."""
    header = {"key": key, "bytes": len(value), "sha256": hashlib.sha256(value).hexdigest()}
    return MAGIC + json.dumps(header, sort_keys=True).encode() + b"\n" + value


def decode_entry(key: str, data: bytes) -> bytes | None:
    """The content of the entry file ``data`` if it is a whole entry of ``key``, else None."""
    if not data.startswith(MAGIC):
        return None
    end = data.find(b"\n", len(MAGIC), len(MAGIC) + MAX_HEADER_BYTES)
    if end < 0:
        return None
    try:
        header = json.loads(data[len(MAGIC) : end])
    except (ValueError, UnicodeDecodeError):
        return None
    value = data[end + 1 :]
    if not isinstance(header, dict) or header.get("key") != key:
        return None
    if header.get("bytes") != len(value):
        return None
    if header.get("sha256") != hashlib.sha256(value).hexdigest():
        return None
    return value


def pack_text(text: str, data: bytes) -> bytes:
    """Content of an entry of two parts: ``text`` (UTF-8, length-prefixed) and ``data``."""
    encoded = text.encode()
    return len(encoded).to_bytes(8, "little") + encoded + data


def unpack_text(content: bytes) -> tuple[str, bytes]:
    """(text, data) of :func:`pack_text`'s ``content``; ValueError if it is not that."""
    length = int.from_bytes(content[:8], "little")
    if len(content) < 8 or len(content) < 8 + length:
        raise ValueError("not a text and data entry")
    try:
        return content[8 : 8 + length].decode(), content[8 + length :]
    except UnicodeDecodeError as exc:
        raise ValueError("not a text and data entry") from exc


def read_regular(path: Path, max_bytes: int) -> bytes | None:
    """The bytes of ``path`` if it is a regular file (not a link, FIFO, device or directory)
    of at most ``max_bytes``, else None; never blocks (a FIFO) nor reads without end (a
    device)."""
    flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except OSError:  # absent, a link (ELOOP), no permission
        return None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode) or info.st_size > max_bytes:
            return None
        with os.fdopen(os.dup(fd), "rb") as handle:
            data = handle.read(info.st_size + 1)
    except OSError:
        return None
    finally:
        os.close(fd)
    return data if len(data) == info.st_size else None  # changed while read: a miss


class FileStore:
    """Entries (bytes by key) in files written atomically, each checked on every read
    (:func:`read_regular`: a regular file within the store's size; :func:`decode_entry`: its
    key, size and SHA-256); a damaged entry is a miss. The get/put pair is JAX's cache
    interface; :meth:`building` makes concurrent runs wait for an entry another run is
    making."""

    def __init__(self, directory: Path, *, max_bytes: int = MAX_BYTES) -> None:
        self._path = directory
        self._max_bytes = max_bytes

    def _file(self, key: str) -> Path:
        return self._path / f"{key}{SUFFIX}"

    def get(self, key: str) -> bytes | None:
        path = self._file(key)
        data = read_regular(path, self._max_bytes + MAX_HEADER_BYTES + len(MAGIC))
        value = None if data is None else decode_entry(key, data)
        if value is not None:
            with contextlib.suppress(OSError):
                os.utime(path)  # recently used (eviction)
        return value

    def put(self, key: str, value: bytes) -> None:
        """Write the entry atomically (jaxflex._atomic: a new file beside it, then a rename)
        over whatever is in the way: an old entry, or a link or FIFO, whose name is removed
        first (never followed); not cached when the disk refuses."""
        if len(value) > self._max_bytes:
            return
        path = self._file(key)
        with contextlib.suppress(OSError):  # disk full, directory gone: not cached
            if os.path.lexists(path) and not stat.S_ISREG(os.lstat(path).st_mode):
                os.unlink(path)  # the name only (a directory stays: not cached)
            with atomic_open(path, "wb") as handle:  # OutputError (an OSError): not cached
                handle.write(encode_entry(key, value))
            _evict(self._path, self._max_bytes)

    def discard(self, key: str) -> None:
        """Remove the entry of ``key`` (its user found it wrong)."""
        with contextlib.suppress(OSError):
            os.unlink(self._file(key))

    @contextlib.contextmanager
    def building(self, key: str, what: str = "", timeout_s: float = LOCK_TIMEOUT_S):
        """While another run holds the entry of ``key`` (it is making it: a lock file with
        flock, released when that run ends however it ends), wait for it, at most
        ``timeout_s``, saying so on a step line (``what``: the work); then hold it. Yields
        nothing; look the entry up again inside."""
        path = self._path / f".{key[:32]}.lock"
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600)
        except OSError:  # no lock possible (a link or FIFO in its place): build anyway
            yield
            return
        try:
            _flock(fd, what, timeout_s)
            yield
        finally:
            os.close(fd)  # releases the lock


def _flock(fd: int, what: str, timeout_s: float) -> None:
    """Take the exclusive flock on ``fd``, waiting at most ``timeout_s`` (then go on without
    it: a stuck run does not stop this one)."""
    import fcntl

    deadline = time.monotonic() + timeout_s
    said = False
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return
        except OSError:
            if time.monotonic() > deadline:
                return
        if not said:
            from jaxflex._progress import step

            step(f"waiting for another run making the same {what or 'cache entry'}")
            said = True
        time.sleep(LOCK_POLL_S)


def fetch(store: FileStore | None, key: str, make, use, what: str = ""):
    """(value, True) from ``use(entry)`` of the store's entry of ``key``, or (value, False)
    from ``make()`` -> (value, bytes to store), stored. An entry ``use`` refuses (raises
    ValueError) is a miss and replaced. While another run makes the same entry, this one
    waits for it (:meth:`FileStore.building`). ``store`` None: always ``make()``."""
    if store is None:
        return make()[0], False
    found = _use(store, key, use)
    if found is not None:
        return found, True
    with store.building(key, what):
        found = _use(store, key, use)  # made by the run this one waited for
        if found is not None:
            return found, True
        value, data = make()
        store.put(key, data)
    return value, False


def _use(store: FileStore, key: str, use):
    """``use(entry)`` of the entry of ``key``, None if there is none or ``use`` refuses it
    (then it is removed)."""
    entry = store.get(key)
    if entry is None:
        return None
    try:
        return use(entry)
    except ValueError:
        store.discard(key)
        return None


def _evict(directory: Path, max_bytes: int) -> None:
    """Remove the least recently used entries of ``directory`` until they fit in
    ``max_bytes``, what is in an entry's place but not a regular file (a link, a FIFO), and
    temporaries and lock files older than STALE_TMP_S (writers killed mid-write)."""
    entries = []
    now = time.time()
    for path in directory.iterdir():
        with contextlib.suppress(OSError):
            info = path.lstat()
            if path.name.endswith(SUFFIX):
                if stat.S_ISREG(info.st_mode):
                    entries.append((info.st_mtime, info.st_size, path))
                elif not stat.S_ISDIR(info.st_mode):
                    path.unlink()
            elif path.name.startswith(".") and now - info.st_mtime > STALE_TMP_S:
                path.unlink()
    total = sum(size for _, size, _ in entries)
    for _, size, path in sorted(entries):
        if total <= max_bytes:
            break
        with contextlib.suppress(OSError):
            path.unlink()
        total -= size
