"""JAX's persistent compilation cache of the commands (jaxflex._compile_cache): a second
process loads what the first compiled, a damaged entry is recompiled and replaced, an
unwritable or disabled cache leaves the results as they are, concurrent writers never leave
a half-written entry."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from test_cache_stores import FILE_DAMAGES
from test_optim_optimize import few_mode_model

from jaxflex import _compile_cache as compile_cache
from jaxflex._compile_cache import ENV_VAR, SUFFIX, FileStore, _evict, _writable, decode_entry

# runs the command in a fresh interpreter and prints JAX's own count of its compilation-cache
# events (jax.monitoring) as the last line: what was asked of the cache, found, written
WITH_EVENTS = """
import json, sys
import jax.monitoring
events = {}
def count(name, **_):
    if name.startswith("/jax/compilation_cache/"):
        key = name.rsplit("/", 1)[1]
        events[key] = events.get(key, 0) + 1
jax.monitoring.register_event_listener(count)
from jaxflex.cli import main
status = main(sys.argv[1:])
print("EVENTS " + json.dumps(events))
sys.exit(status)
"""


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "part.npz"
    few_mode_model().save(path)
    return path


def optimize(model_file: Path, out: Path, cache: str, *extra: str):
    """``jaxflex optimize`` of the test part with the cache at ``cache``: (process, events)."""
    args = [str(model_file), "--distance", "0", "0", "0.8", "--threshold", "1e-3"]
    args += ["--max-memory", "4", "--no-plots", "-o", str(out), *extra]
    proc = subprocess.run(
        [sys.executable, "-c", WITH_EVENTS, "optimize", *args],
        capture_output=True,
        text=True,
        env={**os.environ, ENV_VAR: cache},
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    line = proc.stdout.strip().splitlines()[-1]
    assert line.startswith("EVENTS "), proc.stdout
    return proc, json.loads(line.removeprefix("EVENTS "))


def entries(directory: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in directory.iterdir() if p.name.endswith(SUFFIX)}


def programs(directory: Path) -> dict[str, bytes]:
    """The compiled programs of the entries in ``directory``, by file name: JAX's entry is
    its compile time in ms (4 bytes) and the serialized executable, compressed; a program
    compiled again carries another compile time, so entries are compared by their programs."""
    from jax._src.compilation_cache import decompress_executable, extract_executable_and_time

    found = {}
    for name, data in entries(directory).items():
        value = decode_entry(name.removesuffix(SUFFIX), data)
        assert value is not None, f"{name} is not a whole entry"
        found[name] = extract_executable_and_time(decompress_executable(value))[0]
    return found


# a program no command compiles, compiled with the commands' cache settings
OTHER_PROGRAM = (
    "import jax; from jaxflex._compile_cache import enable; enable(); "
    "jax.jit(lambda x: x * 2.0 + 1.0)(1.0).block_until_ready()"
)


def other_program_entries(cache: Path) -> dict[str, bytes]:
    """The entries a fresh interpreter writes into ``cache`` for :data:`OTHER_PROGRAM`."""
    env = {**os.environ, ENV_VAR: str(cache)}
    proc = subprocess.run([sys.executable, "-c", OTHER_PROGRAM], env=env, capture_output=True)
    assert proc.returncode == 0, proc.stderr
    found = entries(cache)
    assert found
    return found


def test_a_second_process_loads_what_the_first_compiled(model_file, tmp_path):
    cache = tmp_path / "cache"
    first, events = optimize(model_file, tmp_path / "a", str(cache), "-q")
    written = entries(cache)
    compiled = programs(cache)
    # every program went through the cache and was written (however quick to compile)
    assert events.get("compile_requests_use_cache", 0) > 0
    assert events.get("cache_hits", 0) == 0
    assert events.get("cache_misses", 0) == len(written) > 0
    assert all(not p.name.startswith(".") for p in cache.iterdir())  # no temporaries left
    assert oct(cache.stat().st_mode & 0o777) == oct(0o700)

    second, events = optimize(model_file, tmp_path / "b", str(cache), "-q")
    assert events.get("cache_hits", 0) == events["compile_requests_use_cache"] > 0
    assert events.get("cache_misses", 0) == 0  # nothing compiled, nothing written
    assert entries(cache) == written
    assert (tmp_path / "a" / "trajectory.csv").read_bytes() == (
        tmp_path / "b" / "trajectory.csv"
    ).read_bytes()
    assert first.stdout.splitlines()[0] == second.stdout.splitlines()[0]

    # damaged entries, every damage of issue 34 on some of them (a disk error, a killed
    # writer, entries swapped among their keys, a foreign file, a FIFO or a link to /dev/zero
    # in an entry's place; as many rounds as the programs take): each a miss, recompiled and
    # replaced, without a warning, with the same answer; the others are hits
    damages = list(FILE_DAMAGES.values())
    # the entries an entry can be swapped with: the run's own and another program's (the
    # run may compile a single program)
    genuine = {**written, **other_program_entries(tmp_path / "other")}
    for round_ in range(0, len(damages), len(written)):
        chunk = damages[round_ : round_ + len(written)]
        damaged = dict(zip(sorted(written)[: len(chunk)], chunk, strict=True))
        for name, damage in damaged.items():
            damage(cache / name, genuine)
        out = tmp_path / f"c{round_}"
        third, events = optimize(model_file, out, str(cache))
        assert "compilation cache" not in third.stderr, third.stderr
        assert events.get("cache_hits", 0) == len(written) - len(damaged)
        assert events.get("cache_misses", 0) == len(damaged)
        # every entry whole again; the hits untouched, byte for byte. A recompiled program is
        # not compared by its bytes: XLA need not emit the same executable twice (one did not
        # in a full run of the suite); its answer is compared below
        now = programs(cache)
        assert now.keys() == compiled.keys()
        assert {k: v for k, v in now.items() if k not in damaged} == {
            k: v for k, v in compiled.items() if k not in damaged
        }
        assert (out / "trajectory.csv").read_bytes() == (
            tmp_path / "a" / "trajectory.csv"
        ).read_bytes()
    _, events = optimize(model_file, tmp_path / "d", str(cache), "-q")
    assert events.get("cache_hits", 0) == events["compile_requests_use_cache"] > 0

    # the keys do not depend on where the cache is: a copy of it is used as it is
    shutil.copytree(cache, tmp_path / "copied")
    _, events = optimize(model_file, tmp_path / "e", str(tmp_path / "copied"), "-q")
    assert events.get("cache_hits", 0) == events["compile_requests_use_cache"] > 0
    assert events.get("cache_misses", 0) == 0


@pytest.mark.parametrize("kind", ["unwritable", "off"])
def test_a_run_without_a_usable_cache_gives_the_same_answer(model_file, tmp_path, kind):
    reference, _ = optimize(model_file, tmp_path / "ref", str(tmp_path / "cache"), "-q")
    blocker = tmp_path / "a file"
    blocker.write_text("not a directory")
    cache = str(blocker / "cache") if kind == "unwritable" else "off"
    proc, events = optimize(model_file, tmp_path / "out", cache)
    assert events.get("cache_hits", 0) == events.get("cache_misses", 0) == 0
    if kind == "unwritable":
        # one step line says so (stderr, not with -q); nothing else complains
        assert "compilation cache off: " in proc.stderr and "not writable" in proc.stderr
        assert "Traceback" not in proc.stderr and "Error" not in proc.stderr
    else:
        assert "compilation cache" not in proc.stderr
    assert proc.stdout.splitlines()[0] == reference.stdout.splitlines()[0]
    assert (tmp_path / "out" / "trajectory.csv").read_bytes() == (
        tmp_path / "ref" / "trajectory.csv"
    ).read_bytes()


def test_the_directory_comes_from_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "mine"))
    assert compile_cache.chosen_dir() == tmp_path / "mine"
    monkeypatch.setenv(ENV_VAR, "OFF")
    assert compile_cache.chosen_dir() is None
    monkeypatch.delenv(ENV_VAR)
    if sys.platform.startswith("linux"):  # platformdirs follows XDG there
        monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
        assert compile_cache.chosen_dir() == tmp_path / "xdg" / "jaxflex" / "jax"
    assert _writable(tmp_path / "new" / "jax") is None  # created, parents too
    blocker = tmp_path / "file"
    blocker.write_bytes(b"")
    assert "not writable" in _writable(blocker / "jax")


def test_concurrent_writers_and_readers_see_whole_entries(tmp_path):
    # writers replace one entry with values of different lengths while readers read it; a
    # write in place (JAX's own file store) lets a reader see a mixture or a truncated file
    store = FileStore(tmp_path)
    values = [bytes([i]) * (2_000_000 + 100_000 * i) for i in range(1, 5)]
    store.put("key", values[0])  # the readers always find an entry, however the threads run
    seen, failures = [], []
    writing = threading.Event()
    writing.set()

    def write(value: bytes) -> None:
        for _ in range(15):
            store.put("key", value)

    def read() -> None:
        # reads for as long as anyone writes (and at least 20 times): no count that a loaded
        # machine's scheduling can make miss the writes
        count = 0
        while writing.is_set() or count < 20:
            data = (tmp_path / f"key{SUFFIX}").read_bytes()
            seen.append(len(data))
            if decode_entry("key", data) not in values:
                failures.append(len(data))
            count += 1

    writers = [threading.Thread(target=write, args=(v,)) for v in values]
    readers = [threading.Thread(target=read) for _ in range(2)]
    for thread in readers + writers:
        thread.start()
    for thread in writers:
        thread.join()
    writing.clear()
    for thread in readers:
        thread.join()
    assert seen and not failures
    assert store.get("key") in values
    assert [p.name for p in tmp_path.iterdir()] == [f"key{SUFFIX}"]


def test_least_recently_used_entries_go_first(tmp_path):
    for i, name in enumerate(("old", "middle", "new")):
        path = tmp_path / f"{name}{SUFFIX}"
        path.write_bytes(b"x" * 1000)
        os.utime(path, (1_000_000 + i, 1_000_000 + i))
    stale = tmp_path / ".new-cache.123-0123456789abcdef.tmp"
    stale.write_bytes(b"partial")
    os.utime(stale, (1_000_000, 1_000_000))
    _evict(tmp_path, 2500)
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"middle{SUFFIX}", f"new{SUFFIX}"]
