"""A sweep of 2 000 small cases on a LocalCluster of 2 workers (optim.sweep.scale): every
case stored once, tasks in bounded batches, and the memory of the client and of the workers
flat once the run is under way. The figures (throughput, memory, store cost) are in
docs/sweep.md, measured with ``python -m optim.sweep.scale``; this test asserts no time.
"""

from __future__ import annotations

import pytest

from optim.sweep import read_table
from optim.sweep.cluster import TASKS_PER_THREAD
from optim.sweep.scale import SAMPLE_EVERY, measure
from optim.sweep.store import FINAL_STAGES

N_CASES = 2000
WARM = 500  # cases after which every worker has compiled every move length it meets


@pytest.mark.slow
def test_two_thousand_cases_in_bounded_batches_and_flat_memory(tmp_path):
    report = measure(tmp_path, n_workers=2)
    assert report["cases"] == report["computed"] == N_CASES
    rows = read_table(tmp_path / "results.csv")
    assert len({r["case_id"] for r in rows}) == len(rows) == N_CASES
    assert len(list((tmp_path / "cases").glob("*.json"))) == N_CASES
    assert report["ok"] + report["errors"] == N_CASES and report["ok"] > N_CASES // 2
    assert {r["stage"] for r in rows if r["status"] == "error"} <= set(FINAL_STAGES)
    assert report["rerun_ms_per_stored_case"] > 0  # the rerun read them all, computed none

    # bounded batches: never more than TASKS_PER_THREAD case tasks per worker thread out
    assert 0 < report["peak_in_flight"] <= 2 * TASKS_PER_THREAD

    # Memory, resident set sizes (MB) sampled every SAMPLE_EVERY records. Holding the
    # records would cost the client at least their JSON size (Python objects are larger)
    # for each case after WARM; the measured growth must stay below a third of that. A
    # worker holds nothing between tasks: below the same bound.
    samples = {s["cases"]: s for s in report["samples"]}
    assert sorted(samples) == list(range(SAMPLE_EVERY, N_CASES + 1, SAMPLE_EVERY))
    held_mb = (N_CASES - WARM) * report["record_bytes_mean"] / 2**20
    start, end = samples[WARM], samples[N_CASES]
    assert end["client_rss_mb"] - start["client_rss_mb"] < held_mb / 3, report["samples"]
    assert start["workers"].keys() == end["workers"].keys() and len(end["workers"]) == 2
    for pid, worker in end["workers"].items():
        assert worker["rss_mb"] - start["workers"][pid]["rss_mb"] < held_mb / 3, pid
