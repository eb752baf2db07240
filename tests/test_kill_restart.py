"""kill -9 of ``jaxflex optimize`` and ``jaxflex sweep`` at several points: the output
directory then holds a complete set (the earlier one or the new one) or nothing that export
accepts (refused naming the file); the next run leaves no temporary file behind; a sweep
rerun computes only the missing cases and ends with the table of an uninterrupted run.

Kill points are reached by watching the output directory (polled every millisecond): the
set writer removes the manifest first and writes it last, and the plots take a tenth of a
second or more, so a kill when the manifest disappears lands in the middle of the set."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import random_model
from sweep_cases import N_CASES, SPEC, assert_same_table, start_sweep

from fmu.cli import load_case
from jaxflex.errors import InputError
from optim.sweep import load_spec, read_table, run_sweep

THRESHOLDS_M = (1e-3, 5e-4)  # two runs with different answers into one directory
POLL_S = 0.001
TIMEOUT_S = 300.0


def _optimize(model_path, out, threshold_m) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "jaxflex", "optimize", str(model_path)]
    args = ["--distance", "0.3", "0", "0.8", "--threshold", repr(threshold_m), "-o", str(out)]
    return subprocess.Popen(
        [*cmd, *args, "--quiet"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def _kill_when(proc: subprocess.Popen, condition) -> bool:
    """SIGKILL ``proc`` (its process group) as soon as ``condition()`` holds; False if the
    process ended first."""
    deadline = time.monotonic() + TIMEOUT_S
    try:
        while not condition():
            if proc.poll() is not None:
                return False
            assert time.monotonic() < deadline, "the kill point was never reached"
            time.sleep(POLL_S)
        os.killpg(proc.pid, signal.SIGKILL)
        return True
    finally:
        proc.communicate()


def _finish(proc: subprocess.Popen) -> None:
    _, err = proc.communicate(timeout=TIMEOUT_S)
    assert proc.returncode == 0, err
    assert "Traceback" not in err


def _stamp(path: Path):
    try:
        stat = path.stat()
    except FileNotFoundError:
        return None
    return stat.st_ino, stat.st_mtime_ns


def _after(delay_s: float):
    start = time.monotonic()
    return lambda: time.monotonic() - start >= delay_s


def _replaced(path: Path):
    before = _stamp(path)
    return lambda: _stamp(path) not in (before, None)


def _comparable(report):
    """A report without what differs between equal runs (wall and CPU times)."""
    if isinstance(report, dict):
        return {k: _comparable(v) for k, v in report.items() if not k.endswith(("wall_s", "cpu_s"))}
    if isinstance(report, list):
        return [_comparable(v) for v in report]
    return report


def _state(out: Path, references: dict) -> str:
    """'refused' (export names the directory), or which run's complete set ``out`` holds;
    fails if export accepts files that are not one run's set."""
    try:
        move, report = load_case(out)
        acc = move.acc
    except InputError as exc:
        assert str(out) in str(exc), exc
        return "refused"
    for threshold, (ref_acc, ref_report) in references.items():
        if _comparable(report) == _comparable(ref_report):
            np.testing.assert_array_equal(acc, ref_acc)  # the trajectory of that report
            return f"complete set of threshold {threshold:g}"
    raise AssertionError(f"export accepted a set of no run: {report.get('threshold_m')}")


# kill points of optimize: a condition, built just before the run starts
OPTIMIZE_KILLS = {
    "before any file is written (1 s after the start)": lambda out: _after(1.0),
    "when the manifest is removed": lambda out: lambda: not (out / "manifest.json").exists(),
    "when trajectory.csv is replaced": lambda out: _replaced(out / "trajectory.csv"),
    "when report.json is replaced": lambda out: _replaced(out / "report.json"),
    "when profiles.png is replaced": lambda out: _replaced(out / "profiles.png"),
}


def test_optimize_killed_at_any_point_leaves_a_whole_set_or_none(tmp_path, fuzz_tally):
    model_path = tmp_path / "model.npz"
    random_model(n_points=10, n_modes=4).save(model_path)
    references = {}
    for threshold in THRESHOLDS_M:
        ref = tmp_path / f"ref-{threshold:g}"
        _finish(_optimize(model_path, ref, threshold))
        move, report = load_case(ref)
        references[threshold] = (move.acc, report)

    out = tmp_path / "out"
    _finish(_optimize(model_path, out, THRESHOLDS_M[0]))
    states, killed = {}, 0
    for i, (point, kill_point) in enumerate(OPTIMIZE_KILLS.items()):
        condition = kill_point(out)
        killed += _kill_when(_optimize(model_path, out, THRESHOLDS_M[(i + 1) % 2]), condition)
        states[point] = _state(out, references)  # fails on a set of no run
    fuzz_tally(
        "kill -9 of optimize",
        tried=len(states),
        clear_errors=sum(s == "refused" for s in states.values()),
        crashes=0,
        hangs=0,
        corrupt_accepted=0,
    )
    assert killed == len(OPTIMIZE_KILLS), states
    assert states["before any file is written (1 s after the start)"].startswith("complete set"), (
        states
    )
    assert states["when the manifest is removed"] == "refused", states
    # the next run completes the set and removes what the killed writers left
    _finish(_optimize(model_path, out, THRESHOLDS_M[0]))
    assert not [p.name for p in out.iterdir() if p.name.startswith(".")]
    assert _state(out, references) == f"complete set of threshold {THRESHOLDS_M[0]:g}"


def _first(directory: Path, pattern: str):
    return lambda: directory.is_dir() and next(directory.glob(pattern), None) is not None


def test_sweep_killed_at_any_point_restarts_with_the_missing_cases(
    serial_sweep, tmp_path, fuzz_tally
):
    """SIGKILL when the first model is stored (no record yet), then when the table's
    temporary file appears (every record stored, results.csv being written): no half file
    is ever read, the rerun computes exactly the missing cases, removes the temporaries and
    ends with the uninterrupted run's table."""
    _, reference = serial_sweep
    spec_path = tmp_path / "spec.json"
    spec_path.write_text(json.dumps(SPEC))
    out = tmp_path / "out"
    kills = {
        "when the first model is stored": _first(out / "models", "*.npz"),
        "when results.csv is being written": _first(out, ".results.csv.*"),
    }
    killed, stored = 0, {}
    for point, condition in kills.items():
        killed += _kill_when(start_sweep(spec_path, out, "--serial"), condition)
        stored[point] = len(list((out / "cases").glob("*.json")))
        assert not (out / "results.csv").exists()  # atomic: whole or absent
    run = run_sweep(load_spec(SPEC), out, executor="serial", progress=False, plots=False)
    fuzz_tally(
        "kill -9 of sweep",
        tried=len(kills),
        clear_errors=0,
        crashes=len(kills) - killed,  # ended before its kill point
        hangs=0,
        corrupt_accepted=int((out / "rejected").exists()),  # a killed run's record refused
    )
    assert killed == len(kills)
    assert stored["when the first model is stored"] < stored["when results.csv is being written"]
    assert stored["when results.csv is being written"] == N_CASES
    assert (run.skipped, run.computed) == (N_CASES, 0)
    assert not (out / "rejected").exists()
    leftovers = [p for d in (out, out / "cases", out / "models") for p in d.glob(".*")]
    assert not leftovers
    assert_same_table(read_table(out / "results.csv"), reference)


# -- children die with their command -----------------------------------------------------------
# A reader in a child process (jaxflex.isolated) that takes its time: the stand-in for a long
# CAD or ANSYS read. The "command" is a fresh interpreter that calls it.
SLOW_READER = """
import time
from jaxflex.isolated import isolated


@isolated("slow", "a test reader that takes its time")
def read_slowly(path):
    time.sleep(600)
"""
SLOW_COMMAND = """
import sys
sys.path.insert(0, sys.argv[1])
import slow_reader
from jaxflex._budget import make_budget, use_budget
seconds = float(sys.argv[3]) if len(sys.argv) > 3 else None
with use_budget(make_budget(None, seconds)):
    slow_reader.read_slowly(sys.argv[2])
"""
GONE_WITHIN_S = 60.0  # generous: the kernel kills them at once, a loaded machine reaps late


def _process_table() -> dict[int, tuple[int, str, str]]:
    """pid -> (parent pid, state, start time) of every process (Linux /proc)."""
    table = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            text = (entry / "stat").read_text()
        except OSError:
            continue
        fields = text[text.rindex(")") + 2 :].split()
        table[int(entry.name)] = (int(fields[1]), fields[0], fields[19])
    return table


def _descendants(pid: int) -> set[tuple[int, str]]:
    """(pid, start time) of every live descendant of ``pid``."""
    table = _process_table()
    found, frontier = set(), [pid]
    while frontier:
        parent = frontier.pop()
        for child, (ppid, state, start) in table.items():
            if ppid == parent and state != "Z":
                found.add((child, start))
                frontier.append(child)
    return found


def _alive(processes: set[tuple[int, str]]) -> set[tuple[int, str]]:
    """Those of ``processes`` still running (a zombie is dead: it only waits to be reaped)."""
    table = _process_table()
    return {(p, s) for p, s in processes if p in table and table[p][1:] != ("Z", s)
            and table[p][2] == s}  # fmt: skip


def _children_when_started(proc: subprocess.Popen, count: int) -> set[tuple[int, str]]:
    """The descendants of ``proc`` once there are at least ``count`` of them."""
    deadline = time.monotonic() + TIMEOUT_S
    while len(found := _descendants(proc.pid)) < count:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the children never started"
        time.sleep(0.1)
    return found


def _assert_gone(processes: set[tuple[int, str]]) -> None:
    deadline = time.monotonic() + GONE_WITHIN_S
    while _alive(processes) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not _alive(processes), f"still running after the command ended: {_alive(processes)}"


def _slow_read(tmp_path: Path, *extra: str) -> subprocess.Popen:
    (tmp_path / "slow_reader.py").write_text(SLOW_READER, encoding="utf-8")
    (tmp_path / "part.step").write_text("ISO-10303-21;\n", encoding="utf-8")
    return subprocess.Popen(
        [sys.executable, "-c", SLOW_COMMAND, str(tmp_path), str(tmp_path / "part.step"), *extra],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=_interruptible,
    )


def _interruptible() -> None:
    """The command's Ctrl-C as in a user's shell: a test run started in the background
    (``pytest ... &`` in a script) ignores SIGINT, and a child would inherit that."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize("how", ["SIGTERM", "SIGKILL", "SIGINT"])
def test_a_reader_in_a_child_ends_with_its_command(tmp_path, how):
    """The command is signalled alone (as a scheduler or `kill` does; the reader runs in a
    session of its own, so a signal to the command's process group would not reach it):
    no process of it is left running."""
    proc = _slow_read(tmp_path)
    children = _children_when_started(proc, 1)
    os.kill(proc.pid, getattr(signal, how))
    proc.communicate(timeout=TIMEOUT_S)
    _assert_gone(children)


def test_a_reader_past_the_time_budget_is_stopped_with_a_message(tmp_path):
    proc = _slow_read(tmp_path, "3")
    children = _children_when_started(proc, 1)
    _, err = proc.communicate(timeout=TIMEOUT_S)
    assert "did not finish within" in err and "part.step" in err
    _assert_gone(children)


@pytest.mark.parametrize("how", ["SIGTERM", "SIGKILL"])
def test_the_sweeps_dask_workers_end_with_the_sweep(tmp_path, how):
    spec_path = tmp_path / "spec.json"
    spec_path.write_text(json.dumps(SPEC))
    proc = start_sweep(spec_path, tmp_path / "out", "--workers", "1")
    children = _children_when_started(proc, 2)  # dask's resource tracker and a worker
    os.kill(proc.pid, getattr(signal, how))
    proc.communicate(timeout=TIMEOUT_S)
    _assert_gone(children)
