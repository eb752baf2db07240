"""A sweep of 400 small cases on a LocalCluster of 2 workers (optim.sweep.bench.sweep_scale with
40 layouts of 10 moves: each layout is one FE analysis, so few layouts and many moves give
the cases at a fifth of the FE work of 200 layouts of 2 moves; 10 of the layouts are still
rejected by the FE step): every case stored once, tasks in bounded batches, and the client
holding no record once the run is under way. The figures (throughput, memory of every process, store
cost; 2 000 cases) are in docs/sweep.md, measured with ``python -m optim.sweep.bench.sweep_scale``;
this test asserts no time and no resident size.
The run is the benchmark's command in a fresh interpreter: the client's memory is then its
own, not that of a pytest worker that ran other tests before (a 3.5 GB process whose heap
moves by megabytes on its own).
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from optim.sweep import read_table
from optim.sweep.bench.sweep_scale import SAMPLE_EVERY
from optim.sweep.cluster import TASKS_PER_THREAD
from optim.sweep.store import FINAL_STAGES

N_CASES = 400
WARM = 200  # cases after which every worker has compiled every move length it meets


@pytest.mark.slow
def test_four_hundred_cases_in_bounded_batches_and_no_record_held(tmp_path):
    out = tmp_path / "report.json"
    subprocess.run(
        [sys.executable, "-m", "optim.sweep.bench.sweep_scale", "--keep", str(tmp_path / "run"),
         "--moves", "10", "--layouts", "40", "-o", str(out)],
        check=True,
        capture_output=True,
    )  # fmt: skip
    report = json.loads(out.read_text(encoding="utf-8"))
    tmp_path = tmp_path / "run"
    assert report["cases"] == report["computed"] == N_CASES
    rows = read_table(tmp_path / "results.csv")
    assert len({r["case_id"] for r in rows}) == len(rows) == N_CASES
    assert len(list((tmp_path / "cases").glob("*.json"))) == N_CASES
    assert report["ok"] + report["errors"] == N_CASES and report["ok"] > N_CASES // 2
    errors = {r["stage"] for r in rows if r["status"] == "error"}
    assert errors and errors <= set(FINAL_STAGES)  # the overlapping cups' layouts at least
    assert report["rerun_ms_per_stored_case"] > 0  # the rerun read them all, computed none

    # bounded batches: never more than TASKS_PER_THREAD case tasks per worker thread out
    assert 0 < report["peak_in_flight"] <= 2 * TASKS_PER_THREAD

    # Memory, sampled every SAMPLE_EVERY records. Holding the records would add to the
    # client at least one Python container per case (a record is a dict of dicts and of one
    # list per time step): the client's containers (counted after a garbage collection, a
    # count that does not move with the machine's load) may not grow by as much as one per
    # case after WARM. Resident set sizes move with the allocator and the load: the
    # benchmark judges them (memory_flat, docs/sweep.md), this test does not.
    samples = report["samples"]
    assert [s["cases"] for s in samples] == list(range(SAMPLE_EVERY, N_CASES + 1, SAMPLE_EVERY))
    by_cases = {s["cases"]: s for s in samples}
    grown = by_cases[N_CASES]["client_objects"] - by_cases[WARM]["client_objects"]
    assert grown < N_CASES - WARM, grown
    assert set(report["baseline_rise_mb"]) == {"client", *samples[-1]["workers"]}
