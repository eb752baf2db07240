"""``jaxflex sweep --scheduler`` against a real dask cluster: a ``dask scheduler`` and
``dask worker`` processes (the distributed package's command-line tools, from this
environment) on 127.0.0.1 with free ports. The same table as the serial run; a worker killed
midway (its tasks retried, nothing lost or duplicated, the CLI says so); the scheduler killed
midway (a clear message, and a rerun against a new scheduler computes only the missing
cases); a worker with another jaxflex version refused by name.

Every process is started in its own process group and the group is killed at the end of
each test (fixture finaliser), whatever happened.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from distributed import Client
from sweep_cases import N_CASES, SPEC, assert_same_table, start_sweep, wait_for_records

import jaxflex
from optim.sweep import read_table
from optim.sweep.cluster import TASKS_PER_THREAD, WORKER_ENV, connect, resource_name
from optim.sweep.store import ResultStore

DASK = Path(sys.executable).with_name("dask")  # distributed's command line, this venv
START_TIMEOUT_S = 120.0  # process start and imports on a loaded 2-core machine


class DaskProcesses:
    """Schedulers and workers started with ``dask scheduler`` / ``dask worker`` on
    127.0.0.1, logs and scratch space in ``directory``."""

    def __init__(self, directory: Path):
        self.directory = directory
        self.processes: list[subprocess.Popen] = []

    def _start(self, label: str, args: list[str], env: dict | None = None) -> subprocess.Popen:
        with open(self.directory / f"{label}.log", "wb") as log:
            proc = subprocess.Popen(
                [str(DASK), *args],
                stdout=log,
                stderr=subprocess.STDOUT,
                cwd=self.directory,
                env=env,
                start_new_session=True,
            )
        self.processes.append(proc)
        return proc

    def scheduler(self) -> tuple[str, int, subprocess.Popen]:
        """A new scheduler: (address, dashboard port, process). Port 0: the scheduler picks
        free ports and writes them to its scheduler file."""
        label = f"scheduler-{len(self.processes)}"
        info_path = self.directory / f"{label}.json"
        proc = self._start(
            label,
            [
                *("scheduler", "--host", "127.0.0.1", "--port", "0"),
                *("--dashboard-address", "127.0.0.1:0", "--scheduler-file", str(info_path)),
            ],
        )
        deadline = time.monotonic() + START_TIMEOUT_S
        while True:
            assert proc.poll() is None, (self.directory / f"{label}.log").read_text()
            assert time.monotonic() < deadline, "the scheduler did not start"
            try:
                info = json.loads(info_path.read_text())
                return info["address"], info["services"]["dashboard"], proc
            except (OSError, ValueError):
                time.sleep(0.1)

    def worker(self, address: str, name: str, **env: str) -> subprocess.Popen:
        """A worker with one thread (under its nanny), named ``name``; ``env`` on top of
        this environment and the sweep's one-thread settings."""
        return self._start(
            f"worker-{name}",
            [
                *("worker", address, "--host", "127.0.0.1", "--nthreads", "1", "--name", name),
                *("--no-dashboard", "--local-directory", str(self.directory / "scratch")),
            ],
            env={**os.environ, **WORKER_ENV, **env},
        )

    def close(self) -> None:
        for proc in self.processes:
            kill(proc)


def kill(proc: subprocess.Popen) -> None:
    """SIGKILL the process group (a worker's nanny and its worker process, ...)."""
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()


def workers(address: str, count: int) -> dict[str, dict]:
    """Name -> {"address", "pid"} of the workers, once ``count`` are in."""
    with Client(address, timeout=f"{START_TIMEOUT_S}s") as client:
        client.wait_for_workers(count, timeout=START_TIMEOUT_S)
        names = {a: w["name"] for a, w in client.scheduler_info()["workers"].items()}
        pids = client.run(os.getpid)
    return {name: {"address": a, "pid": pids[a]} for a, name in names.items()}


@pytest.fixture
def dask_processes(tmp_path):
    processes = DaskProcesses(tmp_path)
    yield processes
    processes.close()


@pytest.fixture
def spec_path(tmp_path) -> Path:
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(SPEC))
    return path


def computed_skipped(stdout: str) -> tuple[int, int]:
    found = re.search(r"computed (\d+) .* skipped (\d+) finished", stdout)
    assert found, stdout
    return int(found[1]), int(found[2])


def finished(proc: subprocess.Popen) -> tuple[str, str]:
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    return out, err


def test_scheduler_sweep_gives_the_serial_table_and_survives_a_killed_worker(
    serial_sweep, dask_processes, spec_path, tmp_path
):
    """Two workers; one is SIGKILLed (with its nanny) while it runs tasks of the sweep:
    dask reruns them on the other, the CLI says so, and the table is the serial one with
    every case exactly once."""
    _, reference = serial_sweep
    address, dashboard_port, _ = dask_processes.scheduler()
    procs = {name: dask_processes.worker(address, name) for name in ("w0", "w1")}
    workers(address, 2)
    out = tmp_path / "out"
    proc = start_sweep(spec_path, out, "--scheduler", address)
    try:
        wait_for_records(proc, out / "cases", 2)
        with Client(address, timeout=f"{START_TIMEOUT_S}s") as client:
            busy = client.processing()  # address -> keys it runs or holds to run
            names = {a: w["name"] for a, w in client.scheduler_info()["workers"].items()}
        victim = max(busy, key=lambda a: len(busy[a]))
        assert busy[victim], "a worker should be running tasks of the sweep"
        kill(procs[names[victim]])
        stdout, stderr = finished(proc)
    finally:
        kill(proc)
    assert f"dashboard: http://127.0.0.1:{dashboard_port}/status" in stderr
    lost = re.search(rf"worker {re.escape(victim)} lost: (\d+) tasks of this sweep", stderr)
    assert lost and int(lost[1]) >= 1, stderr
    assert re.search(r"lost workers: 1, retried tasks: [1-9]", stdout), stdout
    assert computed_skipped(stdout) == (N_CASES, 0)
    rows = read_table(out / "results.csv")
    assert sorted(r["case_id"] for r in rows) == sorted({r["case_id"] for r in rows})
    assert len(list((out / "cases").glob("*.json"))) == N_CASES
    assert_same_table(rows, reference)


def test_lost_scheduler_stops_clearly_and_a_new_one_computes_the_rest(
    serial_sweep, dask_processes, spec_path, tmp_path
):
    _, reference = serial_sweep
    address, _, scheduler = dask_processes.scheduler()
    old_workers = [dask_processes.worker(address, name) for name in ("w0", "w1")]
    workers(address, 2)
    out = tmp_path / "out"
    proc = start_sweep(spec_path, out, "--scheduler", address)
    try:
        wait_for_records(proc, out / "cases", 2)
        kill(scheduler)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        kill(proc)
    assert proc.returncode == 2, (stdout, stderr)
    stored = {p.name: p.read_bytes() for p in (out / "cases").glob("*.json")}
    message = (
        f"jaxflex sweep: error: lost the connection to the scheduler at {address}; the "
        f"{len(stored)} cases computed before are stored, {N_CASES - len(stored)} are not: "
        "rerun the same command against a running scheduler to compute only those"
    )
    assert message in stderr, stderr
    assert "Traceback" not in stderr
    assert 2 <= len(stored) < N_CASES, "the scheduler should die midway"
    # only real outcomes were stored, no error records for the cases cut off
    assert all(r.get("stage") != "worker" for r in ResultStore(out).iter_records())

    for worker in old_workers:
        kill(worker)
    address, _, _ = dask_processes.scheduler()
    dask_processes.worker(address, "w2")
    workers(address, 1)
    stdout, _ = finished(start_sweep(spec_path, out, "--scheduler", address))
    assert computed_skipped(stdout) == (N_CASES - len(stored), len(stored))
    assert {n: (out / "cases" / n).read_bytes() for n in stored} == stored
    assert_same_table(read_table(out / "results.csv"), reference)


def other_jaxflex(directory: Path, version: str) -> Path:
    """A copy of this jaxflex package that reports ``version``: what a worker finds on its
    path when another release is installed there. Returns the directory to put first on
    PYTHONPATH."""
    target = directory / "jaxflex"
    shutil.copytree(Path(jaxflex.__file__).parent, target, ignore=shutil.ignore_patterns("*.pyc"))
    init = target / "__init__.py"  # a module-level __version__ wins over the lazy lookup
    init.write_text(f'{init.read_text()}\n__version__ = "{version}"\n')
    return directory


def test_worker_with_another_jaxflex_version_is_refused_by_name(
    serial_sweep, dask_processes, spec_path, tmp_path
):
    _, reference = serial_sweep
    other = "0.0.1+other"
    path = other_jaxflex(tmp_path / "other-release", other)
    address, _, _ = dask_processes.scheduler()
    dask_processes.worker(address, "old", PYTHONPATH=str(path))
    old = workers(address, 1)["old"]["address"]
    refused = (
        f"refused worker {old} (old): it has jaxflex {other}, this client jaxflex "
        f"{jaxflex.__version__}; it gets no case of this sweep"
    )

    # the only worker is refused: the sweep stops before computing anything
    out = tmp_path / "out"
    alone = start_sweep(spec_path, out, "--scheduler", address)
    try:
        stdout, stderr = alone.communicate(timeout=300)
    finally:
        kill(alone)
    assert alone.returncode == 2, (stdout, stderr)
    assert refused in stderr
    assert f"no worker of {address} runs jaxflex {jaxflex.__version__}" in stderr
    assert not list((out / "cases").glob("*.json"))

    # with a worker of this version next to it, every case runs there
    dask_processes.worker(address, "same")
    same_pid = workers(address, 2)["same"]["pid"]
    stdout, stderr = finished(start_sweep(spec_path, out, "--scheduler", address))
    assert refused in stderr
    assert computed_skipped(stdout) == (N_CASES, 0)
    places = {r["worker"] for r in ResultStore(out).iter_records() if r["worker"]}
    assert {p.rsplit(":", 1)[1] for p in places} == {str(same_pid)}
    assert_same_table(read_table(out / "results.csv"), reference)


def test_a_worker_joining_later_with_another_version_is_refused_and_gets_no_task(
    dask_processes, tmp_path
):
    """The version gate holds for workers that join after the sweep connected: the plugin
    runs on them, they offer their own version's resource, the client names them."""
    other = "0.0.1+other"
    path = other_jaxflex(tmp_path / "other-release", other)
    address, _, _ = dask_processes.scheduler()
    dask_processes.worker(address, "same")
    same_pid = workers(address, 1)["same"]["pid"]
    messages: list[str] = []
    with connect(address, notify=messages.append) as cluster:
        assert cluster.window == TASKS_PER_THREAD  # one admitted thread
        dask_processes.worker(address, "old", PYTHONPATH=str(path))
        deadline = time.monotonic() + START_TIMEOUT_S
        while not any(m.startswith("refused worker") for m in messages):
            assert time.monotonic() < deadline, messages
            time.sleep(0.1)
        info = cluster.client.scheduler_info()["workers"].values()
        assert {w["name"]: w["resources"] for w in info} == {
            "same": {resource_name(jaxflex.__version__): 1},
            "old": {resource_name(other): 1},
        }
        assert cluster.window == TASKS_PER_THREAD
        futures = cluster.client.map(
            lambda _: os.getpid(), range(4 * TASKS_PER_THREAD), pure=False, **cluster.task_options
        )
        assert set(cluster.client.gather(futures)) == {same_pid}
    [refused] = [m for m in messages if m.startswith("refused worker")]
    assert refused.endswith(
        f"(old): it has jaxflex {other}, this client jaxflex {jaxflex.__version__}; "
        "it gets no case of this sweep"
    )
