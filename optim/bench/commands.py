"""Wall time of whole commands as a user types them, start-up included.

Each run is ``python -m jaxflex ...`` in a fresh interpreter, timed from outside (wall clock
around the child, its CPU time from the operating system's accounting of children):

* ``cold``: with an empty JAX compilation cache (jaxflex._compile_cache): imports, every
  compilation, the work, the pictures;
* ``warm``: the same command again with the cache the cold run filled;
* ``warm_no_plots``: the same with ``--no-plots`` (the answer, trajectory and report only).

The command is the issue's: ``jaxflex optimize MODEL --distance 0 0 1 --vmax 2 --amax 10
--jmax 100 --threshold 5e-4`` of the demo plate (nominal), and in the full run also ``jaxflex
demo`` cold and warm. The load average is recorded with the figures: on a shared machine wall
time grows with it, CPU time much less.

Beside them (issue 32's start-up targets, CPU seconds):

* ``startup``: ``jaxflex --version``, an argument error (``jaxflex optimize`` without its
  arguments) and a cheap input check (a zero-length move, refused before the model file is
  read), each the median of STARTUP_RUNS runs;
* ``model_scene``: ``jaxflex model --scene plate`` cold and warm (the second run copies the
  model from the FE store, fem.model_store);
* ``cache_checks``: what reading an entry costs with its checks (a regular file, its key,
  its SHA-256: jaxflex.runtime.CacheStore.get), ms per entry and per MB, for the JAX
  programs and the FE model the runs above stored.
"""

from __future__ import annotations

import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from jaxflex.defaults import THRESHOLD_M
from jaxflex.errors import JaxflexError
from jaxflex.runtime import COMPILE_CACHE_ENV as ENV_VAR
from jaxflex.runtime import COMPILE_CACHE_SUFFIX as SUFFIX
from jaxflex.runtime import CacheStore

STARTUP_RUNS = 5
# the command line (the demo's move), quiet
OPTIMIZE_ARGS = (
    *("--distance", "0", "0", "1", "--vmax", "2", "--amax", "10", "--jmax", "100"),
    *("--threshold", f"{THRESHOLD_M:g}", "-q"),
)


def timed_run(argv: list[str], env: dict[str, str], status: int = 0) -> dict:
    """``jaxflex ARGV`` in a fresh interpreter: wall and CPU seconds (user + system of the
    child), and the first line it printed (the answer). JaxflexError if it does not end
    with ``status``."""
    import resource  # POSIX: the children's CPU time

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "jaxflex", *argv], capture_output=True, text=True, env=env
    )
    wall_s = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != status:
        raise JaxflexError(f"jaxflex {' '.join(argv)} failed: {proc.stderr.strip()[-2000:]}")
    cpu_s = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    lines = proc.stdout.splitlines()
    return {"wall_s": wall_s, "cpu_s": cpu_s, "answer": lines[0] if lines else ""}


def cold_and_warm(
    argv: list[str], cache: Path, *, variants: dict[str, list[str]] | None = None
) -> dict:
    """One cold run of ``argv`` with an empty cache at ``cache``, one warm run, and one warm
    run per ``variants`` (name -> extra arguments); the cache's entries after the cold run."""
    env = {**os.environ, ENV_VAR: str(cache)}
    shutil.rmtree(cache, ignore_errors=True)
    runs = {"cold": timed_run(argv, env)}
    runs["cache_entries"] = sum(1 for p in cache.iterdir() if p.name.endswith(SUFFIX))
    runs["warm"] = timed_run(argv, env)
    for name, extra in (variants or {}).items():
        runs[name] = timed_run([*argv, *extra], env)
    return runs


def startup(model_path: Path, folder: Path) -> dict:
    """Median wall and CPU seconds of the answers that need no work (module docstring)."""
    env = {**os.environ, ENV_VAR: str(folder / "cache")}
    zero = ["optimize", str(model_path), "--distance", "0", "0", "0", "--threshold", "1e-3"]
    cases = {
        "version": (["--version"], 0),
        "argument_error": (["optimize"], 2),
        "zero_length_move": ([*zero, "-o", str(folder / "zero")], 2),
    }
    out = {}
    for name, (argv, status) in cases.items():
        runs = [timed_run(argv, env, status) for _ in range(STARTUP_RUNS)]
        out[name] = {m: statistics.median(r[m] for r in runs) for m in ("wall_s", "cpu_s")}
    return out


def cache_checks(cache: Path) -> dict:
    """ms to read and check one entry (FileStore.get), per store under ``cache``: JAX's
    programs (the directory itself) and each store below it."""
    out = {}
    for folder in [cache, *sorted(p for p in cache.iterdir() if p.is_dir())]:
        keys = [p.name.removesuffix(SUFFIX) for p in folder.iterdir() if p.name.endswith(SUFFIX)]
        if not keys:
            continue
        store = CacheStore(folder)
        start = time.perf_counter()
        size = sum(len(store.get(key) or b"") for key in keys)
        seconds = time.perf_counter() - start
        out["jax" if folder == cache else folder.name] = {
            "entries": len(keys),
            "mb": size / 1e6,
            "ms_per_entry": 1e3 * seconds / len(keys),
            "ms_per_mb": 1e3 * seconds / (size / 1e6) if size else None,
        }
    return out


def _medians(rounds: list[dict]) -> dict:
    keys = [k for k, v in rounds[0].items() if isinstance(v, dict)]
    return {
        k: {m: statistics.median(r[k][m] for r in rounds) for m in ("wall_s", "cpu_s")}
        for k in keys
    }


def run_commands(
    model,
    *,
    repeats: int = 1,
    demo: bool = False,
    progress: Callable[[str], None] = lambda message: None,
) -> dict:
    """Cold and warm runs of ``jaxflex optimize`` of ``model`` (a ModalModel), ``repeats``
    rounds, each from an empty cache; with ``demo`` also ``jaxflex demo`` cold and warm."""
    out: dict = {"load_average_1min": os.getloadavg()[0], "cpu_count": os.cpu_count()}
    with tempfile.TemporaryDirectory(prefix="jaxflex-bench-commands-") as tmp:
        folder = Path(tmp)
        model_path = folder / "model.npz"
        model.save(model_path)
        argv = ["optimize", str(model_path), *OPTIMIZE_ARGS, "-o", str(folder / "opt")]
        out["optimize"] = {
            "command": "jaxflex optimize MODEL " + " ".join(OPTIMIZE_ARGS),
            "model": f"{model.n_modes} modes, {model.n_points} points",
            "rounds": [],
        }
        for i in range(repeats):
            progress(f"commands: jaxflex optimize cold and warm, round {i + 1}/{repeats} ...")
            rounds = out["optimize"]["rounds"]
            rounds.append(
                cold_and_warm(argv, folder / "cache", variants={"warm_no_plots": ["--no-plots"]})
            )
        out["optimize"]["median"] = _medians(out["optimize"]["rounds"])
        progress("commands: start-up (--version, an argument error, a zero-length move) ...")
        out["startup"] = startup(model_path, folder)
        if demo:  # the full run: the FE store of the built-in plate too
            progress("commands: jaxflex model --scene plate cold and warm ...")
            argv = ["model", "--scene", "plate", "-o", str(folder / "scene.npz"), "-q"]
            out["model_scene"] = cold_and_warm(argv, folder / "scene-cache")
            out["model_scene"]["command"] = "jaxflex model --scene plate"
        out["cache_checks"] = cache_checks(folder / "cache")
        if "model_scene" in out:
            out["cache_checks"].update(cache_checks(folder / "scene-cache"))
        if demo:
            progress("commands: jaxflex demo cold and warm ...")
            argv = ["demo", "-o", str(folder / "demo"), "-q"]
            if shutil.which("gcc") is None:
                argv.append("--no-fmu")  # the FMUs need gcc
            out["demo"] = {"command": "jaxflex " + " ".join(argv[:1] + argv[3:])}
            out["demo"].update(cold_and_warm(argv, folder / "cache"))
    out["load_average_1min_after"] = os.getloadavg()[0]
    return out


# sections reported as one line of named items: (section key, label, an item's text)
LISTED = (
    (
        "startup",
        "start-up",
        lambda name, m: (
            f"{name.replace('_', ' ')} {m['cpu_s']:.2f} s CPU ({m['wall_s']:.2f} s wall)"
        ),
    ),
    (
        "cache_checks",
        "cache checks (read + key + SHA-256 per entry)",
        lambda name, c: (
            f"{name} {c['ms_per_entry']:.2f} ms/entry ({c['entries']} entries, {c['mb']:.1f} MB)"
        ),
    ),
)


def format_commands(section: dict) -> list[str]:
    """Text lines of the section (the CLI prints them)."""
    lines = [
        f"commands (load average {section['load_average_1min']:.1f} -> "
        f"{section['load_average_1min_after']:.1f} on {section['cpu_count']} cores):"
    ]
    opt = section["optimize"]
    figures = ", ".join(
        f"{name} {m['wall_s']:.2f} s wall ({m['cpu_s']:.2f} s CPU)"
        for name, m in opt["median"].items()
    )
    lines.append(f"  {opt['command']} ({opt['model']}): {figures}")
    if "model_scene" in section:
        scene = section["model_scene"]
        lines.append(
            f"  {scene['command']}: cold {scene['cold']['cpu_s']:.2f} s CPU, warm (from the FE "
            f"store) {scene['warm']['cpu_s']:.2f} s CPU"
        )
    for key, label, item in LISTED:
        if section.get(key):
            items = ", ".join(item(name, m) for name, m in section[key].items())
            lines.append(f"  {label}: {items}")
    if "demo" in section:
        demo = section["demo"]
        lines.append(
            f"  {demo['command']}: cold {demo['cold']['wall_s']:.1f} s wall "
            f"({demo['cold']['cpu_s']:.1f} s CPU), warm {demo['warm']['wall_s']:.1f} s wall "
            f"({demo['warm']['cpu_s']:.1f} s CPU)"
        )
    return lines
