"""Scale run of a sweep: thousands of small cases on a dask LocalCluster, to show that
throughput, the memory of the client and of each worker, and the record store's cost per
case do not grow with the number of finished cases. JSON on stdout (and ``-o FILE``).

    python -m optim.sweep.bench.sweep_scale -o sweep_scale.json  # 2 000 cases, 2 workers

The spec (:func:`scale_spec`): a 0.6 x 0.4 m aluminium plate with 100 mm elements, 4 modes,
6 monitored points; 200 rectangular layouts (2 or 3 cups per side, 5 x 5 insets, 2 radii)
x 10 moves (``--layouts 40``: one inset along y, the last, 0.32, where 3 cups of 40 mm
overlap, so that the FE step still rejects 10 layouts; each layout is one FE analysis,
whatever its number of moves). Every ``SAMPLE_EVERY`` records the run notes the time, the
client's memory (its process also runs the LocalCluster's scheduler) and its number of
Python container objects (after a garbage collection), and each worker's memory (the
workers are found from the records' ``worker`` field, ``host:pid``); the store's cost is
timed per record, and after the run, interleaved, into the full results directory and into
an empty one.
Memory figures are resident set sizes (MB): current (the client's after returning freed
heap memory to the system, ``malloc_trim``, where the C library has it), and the process's
peak so far (``VmHWM``, Linux). What holding the records would cost is measured in the same
run: the Python allocations (tracemalloc) of ``HOLD_CASES`` stored records loaded into a
list, the yardstick of ``tests/test_sweep_scale.py``'s memory bound.
"""

from __future__ import annotations

import argparse
import ctypes
import ctypes.util
import gc
import os
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
import psutil

from fem.bench.emit import emit_json
from jaxflex.errors import InputError
from optim.sweep.run import Executor, run_sweep
from optim.sweep.spec import SweepSpec, parse_spec
from optim.sweep.store import ResultStore

SAMPLE_EVERY = 100  # records between two samples
MB = 2**20
HOLD_CASES = 1000  # records whose holding cost is measured (cases 500 ... 1 500)
LAYOUT_CHOICES = (40, 80, 120, 160, 200)  # 2 x 2 cup counts x 5 insets x 2 radii x 1..5 insets


def _trim() -> None:
    """Return the freed heap memory of this process to the system (glibc's malloc_trim),
    so that its resident size follows what it holds; nothing where there is no such call."""
    name = ctypes.util.find_library("c")
    trim = getattr(ctypes.CDLL(name), "malloc_trim", None) if name else None
    if trim is not None:
        trim(0)


def scale_spec(n_moves: int = 10, n_layouts: int = 200) -> SweepSpec:
    """``n_layouts`` (40, 80, ... 200) layouts x ``n_moves`` moves of a small plate (see the
    module docstring)."""
    fractions = [0.12, 0.17, 0.22, 0.27, 0.32]
    if n_layouts not in LAYOUT_CHOICES:
        raise InputError(f"n_layouts: one of {LAYOUT_CHOICES}, got {n_layouts}")
    return parse_spec(
        {
            "name": "scale",
            "part": {"width_m": 0.6, "height_m": 0.4, "mesh_size_m": 0.1},
            "model": {"n_modes": 4, "monitor_grid": [3, 2]},
            "optimization": {"threshold_m": 1e-4},
            "moves": [
                {"name": f"move{i}", "distance_m": [0.05 * i, 0.0, 0.3]} for i in range(n_moves)
            ],
            "grids": [
                {
                    "name": "rect",
                    "nx": [2, 3],
                    "ny": [2, 3],
                    "inset_x": fractions,
                    "inset_y": fractions[len(fractions) - n_layouts // 40 :],
                    "radius_m": [0.03, 0.04],
                }
            ],
        }
    )


def _peak_mb(process: psutil.Process) -> float | None:
    """The process's peak resident set size so far (MB), None where /proc has no VmHWM."""
    try:
        status = Path(f"/proc/{process.pid}/status").read_text()
    except OSError:
        return None
    for line in status.splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024 / MB
    return None


class Sampler:
    """``on_record`` hook of run_sweep: per-record store cost, and every ``every`` records
    the elapsed time and the memory of the client and of each worker seen so far."""

    def __init__(self, directory: str | Path, every: int = SAMPLE_EVERY):
        self.cases_dir = Path(directory) / "cases"
        self.every = every
        self.start = time.perf_counter()
        self.client = psutil.Process()
        self.workers: dict[int, psutil.Process] = {}
        self.store_s: list[float] = []
        self.record_bytes: list[int] = []
        self.samples: list[dict] = []

    def __call__(self, record: dict, store_s: float) -> None:
        self.store_s.append(store_s)
        self.record_bytes.append((self.cases_dir / f"{record['case_id']}.json").stat().st_size)
        if record.get("worker"):
            pid = int(record["worker"].rsplit(":", 1)[1])
            if pid not in self.workers:
                self.workers[pid] = psutil.Process(pid)
        if len(self.store_s) % self.every == 0:
            self.samples.append(self._sample())

    def _sample(self) -> dict:
        workers = {}
        for pid, process in self.workers.items():
            try:
                rss = process.memory_info().rss / MB
            except psutil.NoSuchProcess:
                continue
            workers[str(pid)] = {
                "rss_mb": round(rss, 1),
                "peak_mb": _round(_peak_mb(process)),
                "cpu_s": round(_cpu_s(process), 2),
            }
        gc.collect()
        _trim()
        return {
            "cases": len(self.store_s),
            "elapsed_s": round(time.perf_counter() - self.start, 2),
            "client_rss_mb": round(self.client.memory_info().rss / MB, 1),
            "client_peak_mb": _round(_peak_mb(self.client)),
            "client_cpu_s": round(_cpu_s(self.client), 2),
            "client_objects": len(gc.get_objects()),
            "workers": workers,
        }


def _cpu_s(process: psutil.Process) -> float:
    """User + system CPU seconds of the process itself (not its children)."""
    times = process.cpu_times()
    return times.user + times.system


def _round(value: float | None, digits: int = 1) -> float | None:
    return None if value is None else round(value, digits)


def _block(values: list[float], start: int, stop: int) -> float:
    return float(np.mean(values[start:stop]))


def store_cost_ms(full: ResultStore, record: dict, repeats: int = 300) -> dict:
    """Median ms to store ``record`` into ``full`` (a run's store) and into an empty store,
    the two writes interleaved so that the disk's load meets both alike (each copy is
    removed again, so the directory's size stays)."""
    times: dict[str, list[float]] = {"empty_dir": [], "full_dir": []}
    with tempfile.TemporaryDirectory() as tmp:
        stores = {"empty_dir": ResultStore(tmp), "full_dir": full}
        for i in range(repeats):
            copy = {**record, "case_id": f"store-cost-{i}"}
            for name, store in stores.items():
                tick = time.perf_counter()
                store.save_record(copy)
                times[name].append(time.perf_counter() - tick)
                store.record_path(copy["case_id"]).unlink()
    return {name: round(1e3 * float(np.median(t)), 3) for name, t in times.items()}


def _rate(samples: list[dict], i: int, j: int) -> float:
    """Cases per minute between samples ``i`` and ``j``."""
    cases = samples[j]["cases"] - samples[i]["cases"]
    return round(60 * cases / (samples[j]["elapsed_s"] - samples[i]["elapsed_s"]), 1)


def _baseline_rises(samples: list[dict], n: int) -> dict:
    """MB each process's baseline (the least RSS in a window) rose from the second quarter
    of a run of ``n`` cases to the last: a flat process rises by less than half of what
    holding the records between the windows would take (hold_mb scaled to them)."""
    early = [x for x in samples if n / 4 <= x["cases"] <= n / 2]
    late = [x for x in samples if x["cases"] >= 3 * n / 4]

    def rise(rss) -> float:
        return round(min(map(rss, late)) - min(map(rss, early)), 2)

    rises = {"client": rise(lambda x: x["client_rss_mb"])}
    for pid in samples[-1]["workers"]:
        rises[pid] = rise(lambda x, pid=pid: x["workers"].get(pid, {"rss_mb": np.inf})["rss_mb"])
    return rises


def _cpu_ms_per_case(samples: list[dict], n: int) -> dict:
    """CPU ms per case of the client and of the workers together after the first sample."""
    first, last = samples[0], samples[-1]
    workers_s = sum(w["cpu_s"] - first["workers"][p]["cpu_s"] for p, w in last["workers"].items())
    computed = n - first["cases"]
    return {
        "client_cpu_ms_per_case": round(
            1e3 * (last["client_cpu_s"] - first["client_cpu_s"]) / computed, 2
        ),
        "workers_cpu_ms_per_case": round(1e3 * workers_s / computed, 1),
    }


def measure(
    directory: str | Path, *, n_workers: int = 2, n_moves: int = 10, n_layouts: int = 200
) -> dict:
    """Run the scale spec on a LocalCluster of ``n_workers`` into ``directory`` (empty, or a
    previous run's: then only the missing cases), then rerun it (nothing left to compute:
    the cost of reading the stored records). The figures as a dict (see :func:`main`)."""
    spec = scale_spec(n_moves, n_layouts)
    sampler = Sampler(directory)
    run = run_sweep(
        spec,
        directory,
        executor=Executor(n_workers=n_workers, notify=lambda message: None),
        progress=False,
        plots=False,
        on_record=sampler,
    )
    store = ResultStore(directory)
    stored_ms = store_cost_ms(store, store.load_record(run.cases[-1].case_id))
    held = run.cases[len(run.cases) // 4 :][:HOLD_CASES]
    tracemalloc.start()
    records = [store.load_record(case.case_id) for case in held]
    hold_mb = tracemalloc.get_traced_memory()[0] / MB
    tracemalloc.stop()
    del records
    tick = time.perf_counter()
    rerun = run_sweep(spec, directory, executor="serial", progress=False, plots=False)
    rerun_s = time.perf_counter() - tick
    samples, store_ms = sampler.samples, 1e3 * np.asarray(sampler.store_s)
    n, first = run.computed, samples[0]
    block = min(200, n // 4)
    k = block // sampler.every
    rises = _baseline_rises(samples, n)
    bound_mb = round(0.5 * hold_mb * (n / 2) / max(len(held), 1), 2)
    return {
        "spec": spec.name,
        "cases": len(run.cases),
        "computed": n,
        "ok": run.records.count("ok"),
        "errors": run.n_errors,
        "workers": n_workers,
        "peak_in_flight": run.peak_in_flight,
        "wall_s": round(run.wall_s, 1),
        "cases_per_min": round(60 * n / run.wall_s, 1),
        "cases_per_min_early": _rate(samples, 0, k),  # after the first SAMPLE_EVERY (compiling)
        "cases_per_min_late": _rate(samples, len(samples) - 1 - k, len(samples) - 1),
        "store_ms_per_case_first": round(_block(store_ms, 0, block), 3),
        "store_ms_per_case_last": round(_block(store_ms, n - block, n), 3),
        "store_block_cases": block,
        "store_ms_median_empty_dir": stored_ms["empty_dir"],
        "store_ms_median_full_dir": stored_ms["full_dir"],
        "record_bytes_mean": round(float(np.mean(sampler.record_bytes))),
        "hold_cases": len(held),
        "hold_mb": round(hold_mb, 2),
        "baseline_rise_mb": rises,
        "baseline_rise_bound_mb": bound_mb,
        "memory_flat": all(r < bound_mb for r in rises.values()),
        "rerun_s": round(rerun_s, 2),
        "rerun_ms_per_stored_case": round(1e3 * rerun_s / max(rerun.skipped, 1), 3),
        **_cpu_ms_per_case(samples, n),
        "client_objects_first": first["client_objects"],
        "client_objects_last": samples[-1]["client_objects"],
        "client_rss_mb_first": first["client_rss_mb"],
        "client_rss_mb_last": samples[-1]["client_rss_mb"],
        "client_peak_mb": samples[-1]["client_peak_mb"],
        "workers_rss_mb_first": {p: w["rss_mb"] for p, w in first["workers"].items()},
        "workers_rss_mb_last": {p: w["rss_mb"] for p, w in samples[-1]["workers"].items()},
        "workers_peak_mb": {p: w["peak_mb"] for p, w in samples[-1]["workers"].items()},
        "samples": samples,
        "cpu_count": os.cpu_count(),
        "load_average_end": [round(x, 2) for x in os.getloadavg()],
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2, help="LocalCluster workers (default 2)")
    parser.add_argument(
        "--moves", type=int, default=10, help="moves per layout (default 10: 2 000 cases)"
    )
    parser.add_argument(
        "--layouts",
        type=int,
        default=200,
        choices=LAYOUT_CHOICES,
        help="layouts (default 200; each is one FE analysis, shared by its moves)",
    )
    parser.add_argument("-o", "--output", help="also write the JSON here")
    parser.add_argument(
        "--keep", metavar="DIR", help="run into DIR (a new directory) and keep its results"
    )
    args = parser.parse_args(argv)
    options = {"n_workers": args.workers, "n_moves": args.moves, "n_layouts": args.layouts}
    if args.keep:
        report = measure(args.keep, **options)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            report = measure(tmp, **options)
    return emit_json(report, args.output)


if __name__ == "__main__":
    sys.exit(main())
