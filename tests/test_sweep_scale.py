"""A sweep of 2 000 small cases on a LocalCluster of 2 workers (benchmarks.sweep_scale): every
case stored once, tasks in bounded batches, and the memory of the client and of the workers
flat once the run is under way. The figures (throughput, memory, store cost) are in
docs/sweep.md, measured with ``python -m benchmarks.sweep_scale``; this test asserts no time.
"""

from __future__ import annotations

import pytest

from benchmarks.sweep_scale import SAMPLE_EVERY, measure
from optim.sweep import read_table
from optim.sweep.cluster import TASKS_PER_THREAD
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

    # Memory, sampled every SAMPLE_EVERY records. Holding the records would add to the
    # client at least one container per case (a record is a dict of dicts and of one list per
    # time step): the client's Python containers may not grow by as much as one per case
    # after WARM. Resident set sizes (MB) move with transient allocations (an FE analysis
    # takes ~10 MB for a moment, measured), so each process's baseline is the least of its
    # samples in a window: it may not rise by 5 MB from cases WARM..1000 to 1500..2000, a
    # fraction of what dask's profiler, left on, adds over the run (~0.17 MB/s per worker,
    # measured: tens of MB) and of what the records held in the client would take (their
    # JSON alone: 1500 x ~2.8 kB; as Python objects several times more).
    samples = report["samples"]
    assert [s["cases"] for s in samples] == list(range(SAMPLE_EVERY, N_CASES + 1, SAMPLE_EVERY))
    by_cases = {s["cases"]: s for s in samples}
    grown = by_cases[N_CASES]["client_objects"] - by_cases[WARM]["client_objects"]
    assert grown < N_CASES - WARM, grown
    early = [s for s in samples if WARM <= s["cases"] <= 1000]
    late = [s for s in samples if s["cases"] >= 1500]

    def rise(rss) -> float:
        return min(map(rss, late)) - min(map(rss, early))

    assert rise(lambda s: s["client_rss_mb"]) < 5.0, samples
    pids = samples[-1]["workers"].keys()
    assert len(pids) == 2 and all(s["workers"].keys() == pids for s in early + late)
    for pid in pids:
        assert rise(lambda s, pid=pid: s["workers"][pid]["rss_mb"]) < 5.0, (pid, samples)
