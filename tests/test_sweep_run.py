"""Running sweeps: serial reference, dask LocalCluster with 2 workers, a killed and restarted
run, a bad layout recorded as an error, and the batched evaluation against independent paths
(the tiny sweep of tests/sweep_cases.py; ~1 min on 2 cores).
"""

from __future__ import annotations

import json
import os
import re
import signal
from types import SimpleNamespace

import numpy as np
import psutil
import pytest
from conftest import random_model, smooth_move
from distributed.client import FutureCancelledError
from sweep_cases import N_CASES, SPEC, assert_same_table, start_sweep, wait_for_records

import jaxflex
from jaxflex.errors import InputError
from optim.sweep import Executor, load_spec, read_table, run_sweep
from optim.sweep.cases import expand
from optim.sweep.cluster import TASKS_PER_THREAD, ClusterError
from optim.sweep.evaluate import deviation_traces
from optim.sweep.run import _settled
from optim.sweep.store import ResultStore


def test_serial_run_records_the_bad_layout_and_goes_on(serial_sweep):
    run, rows = serial_sweep
    assert run.computed == N_CASES and run.skipped == 0
    assert [r["status"] for r in rows] == ["error"] * 2 + ["ok"] * 8
    for r in rows[:2]:
        assert r["stage"] == "fe" and "supports[2]" in r["error"] and "off the part" in r["error"]
    for r in rows[2:]:
        cycle, floor = float(r["cycle_time_s"]), float(r["kinematic_floor_s"])
        # an exact cycle time on the 10 ms grid, never below the time-optimal move
        assert cycle >= floor - 1e-12
        assert cycle / 0.01 == pytest.approx(round(cycle / 0.01), abs=1e-9)
        assert int(r["n_points"]) == 48 and int(r["n_modes"]) == 6
        assert float(r["peak_deviation_m"]) > 0
    # every layout shares its FE model across both moves
    for a, b in zip(rows[2::2], rows[3::2], strict=True):
        assert a["layout"] == b["layout"] and a["first_freq_hz"] == b["first_freq_hz"]
    names = {p.rsplit("/", 1)[-1] for p in run.outputs}
    assert names == {"results.csv", "sweep.png", "deviation.png"}
    # a rerun skips every finished case, errors included
    again = run_sweep(run.spec, run.directory, executor="serial", progress=False, plots=False)
    assert (again.computed, again.skipped) == (0, N_CASES)


def _listening(processes) -> set[tuple[str, int]]:
    """(ip, port) of every TCP socket the processes listen on."""
    return {
        (c.laddr.ip, c.laddr.port)
        for p in processes
        for c in p.net_connections("tcp")
        if c.status == psutil.CONN_LISTEN
    }


def test_local_cluster_gives_the_serial_table_on_this_machine_only(serial_sweep, tmp_path):
    """Same table as the serial run, in bounded batches; the dashboard link is printed, and
    every port the sweep opens (scheduler, dashboard, nannies, workers) is on 127.0.0.1."""
    _, reference = serial_sweep
    this = psutil.Process()
    before = _listening([this])
    messages, opened = [], set()

    def look(record, store_s):
        opened.update(_listening([this, *this.children(recursive=True)]) - before)

    run = run_sweep(
        load_spec(SPEC),
        tmp_path,
        executor=Executor("dask", n_workers=2, notify=messages.append),
        progress=False,
        plots=False,
        on_record=look,
    )
    assert run.computed == N_CASES
    workers = {r["worker"] for r in run.records.values() if r["status"] == "ok"}
    assert len(workers) == 2, "both worker processes should have taken cases"
    assert_same_table(read_table(tmp_path / "results.csv"), reference)
    # at most TASKS_PER_THREAD case tasks per worker thread out at once, fewer than all
    assert 0 < run.peak_in_flight <= TASKS_PER_THREAD * 2 < N_CASES
    link = re.fullmatch(r"dashboard: http://127\.0\.0\.1:(\d+)/status", messages[0])
    assert link, messages
    assert ("127.0.0.1", int(link[1])) in opened
    assert len(opened) >= 6, opened  # scheduler, dashboard, 2 nannies, 2 workers at least
    assert {ip for ip, _ in opened} == {"127.0.0.1"}


def test_interrupted_and_killed_runs_restart_with_the_missing_cases_only(serial_sweep, tmp_path):
    _, reference = serial_sweep
    spec_path = tmp_path / "spec.json"
    spec_path.write_text(json.dumps(SPEC))
    out = tmp_path / "out"
    cases_dir = out / "cases"

    # Ctrl-C: the CLI stops, says so, exits 130 and writes the table of what is done
    proc = start_sweep(spec_path, out, "--serial")
    try:
        wait_for_records(proc, cases_dir, 2)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130 and "jaxflex sweep: interrupted" in err
    statuses = [r["status"] for r in read_table(out / "results.csv")]
    assert statuses.count("pending") == N_CASES - len(list(cases_dir.glob("*.json"))) > 0

    # SIGKILL of the next run midway (no chance to clean up)
    proc = start_sweep(spec_path, out, "--serial")
    try:
        wait_for_records(proc, cases_dir, 5)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
    assert proc.returncode == -signal.SIGKILL
    before = {p.name: p.read_bytes() for p in cases_dir.glob("*.json")}
    assert 5 <= len(before) < N_CASES, "the kill should land midway"

    run = run_sweep(load_spec(SPEC), out, executor="serial", progress=False, plots=False)
    assert (run.skipped, run.computed) == (len(before), N_CASES - len(before))
    # the records of the killed run are untouched, nothing half-written is left
    assert {p.name: p.read_bytes() for p in cases_dir.glob("*.json") if p.name in before} == before
    assert not list(cases_dir.glob(".*"))
    assert_same_table(read_table(out / "results.csv"), reference)


def test_deviation_traces_take_moves_at_one_step():
    """A group's traces take jaxflex.Move objects (raw samples carry no step) that share one
    step (the traces share one time grid); anything else is refused naming the field."""
    model, acc = random_model(seed=1, n_points=5, n_modes=2), smooth_move(10, 0.01)
    with pytest.raises(InputError, match=r"^moves\[0\]: a jaxflex\.Move .*got ndarray"):
        deviation_traces([model], [acc], 0.5)
    moves = [jaxflex.as_move(acc, 0.01), jaxflex.as_move(acc, 0.02)]
    with pytest.raises(
        InputError, match=r"^moves: one group needs one step dt_s, got \[0.01, 0.02\]"
    ):
        deviation_traces([model, model], moves, 0.5)


def test_batched_evaluation_matches_loop_and_optimiser(serial_sweep):
    """The batched deviation traces equal jaxflex.simulate case by case (round-off) and,
    over the move, optim's own peak deviation (numpy, exact samples every dt / 8)."""
    run, _ = serial_sweep
    store = ResultStore(run.directory)
    cases = [c for c in expand(run.spec) if run.records[c.case_id]["status"] == "ok"]
    models = [store.load_model(c.layout_id)[0] for c in cases]
    records = [run.records[c.case_id] for c in cases]
    moves = [jaxflex.as_move(r["acc_m_s2"], 0.01) for r in records]
    accs = [move.acc for move in moves]
    horizon = 0.8
    t, batched = deviation_traces(models, moves, horizon)
    _, loop = deviation_traces(models, moves, horizon, method="loop")
    assert t[-1] >= horizon and t[1] == pytest.approx(0.01 / 8)
    assert batched.shape == loop.shape == (len(cases), t.size)
    np.testing.assert_allclose(batched, loop, rtol=1e-10, atol=1e-12 * loop.max())
    for d, acc, record in zip(batched, accs, records, strict=True):
        during = d[: (acc.shape[0] - 1) * 8 + 1]
        assert during.max() == pytest.approx(record["opt"]["peak_deviation_m"], rel=1e-9)


class _LostOnRead:
    """A case future found finished whose result cannot be read because the scheduler is
    gone: dask either cancels it first (``cancel``) or fails the fetch of a result that
    lives on a worker while the future is still "finished"; the race of a scheduler killed
    while the sweep reads its results (tests/test_sweep_cluster.py hit both)."""

    def __init__(self, cancel: bool) -> None:
        self.status, self.cancel = "finished", cancel

    def result(self):
        if self.cancel:
            self.status = "cancelled"
            raise FutureCancelledError("case", reason="scheduler-connection-lost")
        raise OSError("Timed out trying to connect to tcp://h:1")

    def exception(self):
        return None


CLUSTER = SimpleNamespace(client=SimpleNamespace(scheduler=SimpleNamespace(address="tcp://h:1")))


@pytest.mark.parametrize("cancel", [True, False])
def test_a_result_lost_while_read_stops_the_run_and_stores_no_record(cancel):
    """A result that cannot be read because the scheduler is lost stops the run with
    ClusterError naming the scheduler; it is not the case's error record."""
    with pytest.raises(ClusterError, match=r"^lost the connection to the scheduler at tcp://h:1$"):
        _settled(_LostOnRead(cancel), CLUSTER)


def _raise():
    raise RuntimeError("worker died")


def test_a_finished_result_is_read_and_a_failed_task_is_its_case_s_error_record():
    finished = SimpleNamespace(status="finished", result=lambda: {"case_id": "c"})
    assert _settled(finished, CLUSTER) == {"case_id": "c"}
    failed = SimpleNamespace(status="error", result=_raise)
    assert _settled(failed, CLUSTER) is None
