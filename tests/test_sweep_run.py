"""Running sweeps: serial reference, dask LocalCluster with 2 workers, a killed and restarted
run, a bad layout recorded as an error, and the batched evaluation against independent paths.

Tiny meshes (50 mm elements on a 0.6 x 0.4 m plate, 6 modes, 48 monitored points) and
nominal optimisation keep the module at ~1 min on 2 cores.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from optim.sweep import RUN_COLUMNS, expand, parse_spec, read_table, run_sweep
from optim.sweep.evaluate import deviation_traces
from optim.sweep.store import ResultStore

SPEC = {
    "name": "tiny",
    "part": {"width_m": 0.6, "height_m": 0.4, "mesh_size_m": 0.05},
    "model": {"n_modes": 6, "monitor_grid": [8, 6]},
    "optimization": {"threshold_m": 1e-4},
    "moves": [
        {"name": "up", "distance_m": [0, 0, 0.5]},
        {"name": "side", "distance_m": [0.4, 0, 0.1], "vmax": 1.5},
    ],
    # the third cup lies off the 0.6 m wide part: a layout the FE step must reject
    "layouts": [
        {"name": "off part", "cups": [[0.1, 0.1, 0.03], [0.5, 0.1, 0.03], [0.7, 0.3, 0.03]]}
    ],
    "grids": [
        {
            "name": "rect",
            "nx": [2],
            "ny": [2],
            "inset_x": [0.15, 0.25],
            "inset_y": [0.25],
            "radius_m": [0.03, 0.04],
        }
    ],
}
N_CASES = 10  # 5 layouts x 2 moves


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    directory = tmp_path_factory.mktemp("serial")
    run = run_sweep(parse_spec(SPEC), directory, executor="serial", progress=False)
    return run, read_table(directory / "results.csv")


def _comparable(rows):
    """Table rows without the columns that differ between runs (wall times, worker)."""
    return [{k: v for k, v in r.items() if k not in RUN_COLUMNS} for r in rows]


def _assert_same_table(rows, reference):
    """Equal strings and integers; floats equal to 1e-9 relative. ARPACK starts from a
    random vector, so eigenvalues (and what follows from them) differ between processes in
    the last bits (measured: ~1e-15 relative); every time on the dt grid is identical."""
    assert len(rows) == len(reference)
    for row, ref in zip(_comparable(rows), _comparable(reference), strict=True):
        assert row.keys() == ref.keys()
        for key, value in ref.items():
            try:
                expected = float(value)
            except ValueError:
                assert row[key] == value, (ref["index"], key)
                continue
            assert float(row[key]) == pytest.approx(expected, rel=1e-9, abs=0), (ref["index"], key)


def test_serial_run_records_the_bad_layout_and_goes_on(serial):
    run, rows = serial
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


def test_local_cluster_gives_the_serial_table(serial, tmp_path):
    _, reference = serial
    run = run_sweep(
        parse_spec(SPEC), tmp_path, executor="dask", n_workers=2, progress=False, plots=False
    )
    assert run.computed == N_CASES
    workers = {r["worker"] for r in run.records.values() if r["status"] == "ok"}
    assert len(workers) == 2, "both worker processes should have taken cases"
    _assert_same_table(read_table(tmp_path / "results.csv"), reference)


def _start(spec_path, out):
    cmd = [sys.executable, "-m", "jaxflex", "sweep", str(spec_path), "-o", str(out)]
    return subprocess.Popen(
        [*cmd, "--serial", "--quiet", "--no-plots"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )


def _wait_for_records(proc, cases_dir, count: int) -> None:
    deadline = time.monotonic() + 120
    while len(list(cases_dir.glob("*.json"))) < count:
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() < deadline, "the sweep made no progress"
        time.sleep(0.01)


def test_interrupted_and_killed_runs_restart_with_the_missing_cases_only(serial, tmp_path):
    _, reference = serial
    spec_path = tmp_path / "spec.json"
    spec_path.write_text(json.dumps(SPEC))
    out = tmp_path / "out"
    cases_dir = out / "cases"

    # Ctrl-C: the CLI stops, says so, exits 130 and writes the table of what is done
    proc = _start(spec_path, out)
    try:
        _wait_for_records(proc, cases_dir, 2)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130 and "jaxflex sweep: interrupted" in err.decode()
    statuses = [r["status"] for r in read_table(out / "results.csv")]
    assert statuses.count("pending") == N_CASES - len(list(cases_dir.glob("*.json"))) > 0

    # SIGKILL of the next run midway (no chance to clean up)
    proc = _start(spec_path, out)
    try:
        _wait_for_records(proc, cases_dir, 5)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    before = {p.name: p.read_bytes() for p in cases_dir.glob("*.json")}
    assert 5 <= len(before) < N_CASES, "the kill should land midway"

    run = run_sweep(parse_spec(SPEC), out, executor="serial", progress=False, plots=False)
    assert (run.skipped, run.computed) == (len(before), N_CASES - len(before))
    # the records of the killed run are untouched, nothing half-written is left
    assert {p.name: p.read_bytes() for p in cases_dir.glob("*.json") if p.name in before} == before
    assert not list(cases_dir.glob(".*"))
    _assert_same_table(read_table(out / "results.csv"), reference)


def test_batched_evaluation_matches_loop_and_optimiser(serial):
    """The batched deviation traces equal jaxflex.simulate case by case (round-off) and,
    over the move, optim's own peak deviation (numpy, exact samples every dt / 8)."""
    run, _ = serial
    store = ResultStore(run.directory)
    cases = [c for c in expand(run.spec) if run.records[c.case_id]["status"] == "ok"]
    models = [store.load_model(c.layout_id)[0] for c in cases]
    records = [run.records[c.case_id] for c in cases]
    accs = [np.asarray(r["acc_m_s2"]) for r in records]
    horizon = 0.8
    t, batched = deviation_traces(models, accs, 0.01, horizon)
    _, loop = deviation_traces(models, accs, 0.01, horizon, method="loop")
    assert t[-1] >= horizon and t[1] == pytest.approx(0.01 / 8)
    assert batched.shape == loop.shape == (len(cases), t.size)
    np.testing.assert_allclose(batched, loop, rtol=1e-10, atol=1e-12 * loop.max())
    for d, acc, record in zip(batched, accs, records, strict=True):
        during = d[: (acc.shape[0] - 1) * 8 + 1]
        assert during.max() == pytest.approx(record["opt"]["peak_deviation_m"], rel=1e-9)
