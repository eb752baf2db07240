"""Run a sweep: skip finished cases, compute the rest serially or on dask.distributed, store
each record the moment it arrives, then write the table and the plots.

Executors:

* ``"serial"``: in this process, layout by layout (the reference; no dask involved);
* ``"dask"``: a ``dask.distributed.Client`` on an embedded ``LocalCluster`` (``n_workers``
  worker processes, one thread each; default one per core) or on the scheduler at
  ``scheduler`` ("tcp://host:8786"). One task per layout runs the finite-element analysis;
  one task per case optimises, depending on its layout's task, so dask schedules the FE
  analyses in parallel processes and runs each case next to its model. The records come back
  to this process (``as_completed``), which alone writes the results directory, so the
  workers need no shared file system.

Interrupting (Ctrl-C) cancels what is pending and keeps every stored record; the next run
computes only the missing cases.
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from distributed import Client, LocalCluster, as_completed
from tqdm.auto import tqdm

from jaxflex.errors import InputError
from optim.sweep.cases import Case, case_job, expand, layout_job
from optim.sweep.plots import plot_sweep
from optim.sweep.spec import SweepSpec
from optim.sweep.store import ResultStore, is_final
from optim.sweep.table import table_rows, write_table
from optim.sweep.work import (
    analyse_layout,
    fe_from_model,
    optimise_case,
    payload_model,
)

EXECUTORS = ("serial", "dask")
# One thread per worker process for every numeric library (the workers are the parallelism).
WORKER_ENV = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
}


@dataclass
class SweepRun:
    """What a run did. ``records`` holds every stored record of the spec's cases."""

    spec: SweepSpec
    directory: Path
    cases: list[Case]
    records: dict[str, dict]
    computed: int = 0
    skipped: int = 0
    wall_s: float = 0.0
    executor: str = "serial"
    outputs: list[str] = field(default_factory=list)

    @property
    def n_errors(self) -> int:
        return sum(r["status"] == "error" for r in self.records.values())

    @property
    def rows(self) -> list[dict]:
        return table_rows(self.cases, self.records)

    def summary(self) -> str:
        ok = sum(r["status"] == "ok" for r in self.records.values())
        rate = 60.0 * self.computed / self.wall_s if self.wall_s > 0 else float("nan")
        return (
            f"{self.spec.name}: {len({c.case_id for c in self.cases})} cases, {ok} ok, "
            f"{self.n_errors} errors; computed {self.computed} ({self.executor}, "
            f"{self.wall_s:.1f} s, {rate:.1f} cases/min), skipped {self.skipped} finished"
        )


def run_sweep(
    spec: SweepSpec,
    directory: str | Path,
    *,
    executor: str = "dask",
    scheduler: str | None = None,
    n_workers: int | None = None,
    retry_errors: bool = False,
    progress: bool = True,
    plots: bool = True,
) -> SweepRun:
    """Compute every case of ``spec`` not yet stored in ``directory`` and write the table
    (``results.csv``) and plots. See the module docstring for the executors; ``retry_errors``
    recomputes cases whose stored record is an error."""
    if executor not in EXECUTORS:
        raise InputError(f"executor: must be one of {list(EXECUTORS)}, got {executor!r}")
    if scheduler is not None and executor != "dask":
        raise InputError("scheduler: only used with the dask executor")
    if n_workers is not None and n_workers < 1:
        raise InputError(f"n_workers: must be >= 1, got {n_workers}")
    store = ResultStore(directory)
    store.save_spec(spec.source)
    cases = expand(spec)
    stored = store.records()
    ids = {c.case_id for c in cases}
    keep = {k: r for k, r in stored.items() if k in ids and is_final(r)}
    if retry_errors:
        keep = {k: r for k, r in keep.items() if r["status"] == "ok"}
    pending: dict[str, Case] = {}
    for case in cases:
        if case.case_id not in keep:
            pending.setdefault(case.case_id, case)
    run = SweepRun(spec, store.root, cases, dict(keep), skipped=len(keep), executor=executor)
    start = time.perf_counter()
    bar = tqdm(total=len(pending), unit="case", disable=not progress, desc=spec.name)
    try:
        compute = _run_serial if executor == "serial" else _run_dask
        stream = compute(spec, store, list(pending.values()), scheduler, n_workers)
        with contextlib.closing(stream):
            for record in stream:
                store.save_record(record)
                run.records[record["case_id"]] = record
                run.computed += 1
                bar.update()
                bar.set_postfix(errors=run.n_errors, refresh=False)
    finally:
        bar.close()
        run.wall_s = time.perf_counter() - start
        write_table(store.root / "results.csv", run.rows)
    run.outputs.append(str(store.root / "results.csv"))
    if plots:
        run.outputs += plot_sweep(run, store)
    return run


def _by_layout(cases: list[Case]) -> dict[str, list[Case]]:
    groups: dict[str, list[Case]] = {}
    for case in cases:
        groups.setdefault(case.layout_id, []).append(case)
    return groups


def _stored_fe(store: ResultStore, layout_id: str) -> dict | None:
    found = store.load_model(layout_id)
    return None if found is None else fe_from_model(*found)


def _keep_model(store: ResultStore, layout_id: str, fe: dict) -> None:
    if fe["status"] == "ok" and fe["worker"] is not None:
        store.save_model(layout_id, payload_model(fe["model"]), fe["fe"])


def _run_serial(spec, store, pending, scheduler, n_workers) -> Iterator[dict]:
    for layout_id, group in _by_layout(pending).items():
        fe = _stored_fe(store, layout_id)
        if fe is None:
            fe = analyse_layout(layout_job(spec, group[0].layout))
            _keep_model(store, layout_id, fe)
        for case in group:
            yield optimise_case(fe, case_job(spec, case))


def _client(scheduler: str | None, n_workers: int | None):
    """A dask Client and a closer: the embedded LocalCluster, or the given scheduler."""
    if scheduler is not None:
        if not scheduler.startswith(("tcp://", "tls://", "inproc://", "ucx://", "ws://")):
            raise InputError(
                f"scheduler: expected an address like tcp://host:8786, got {scheduler!r}"
            )
        try:
            client = Client(scheduler, timeout="15s")
        except (OSError, TimeoutError) as exc:
            raise InputError(f"scheduler: cannot connect to {scheduler} ({exc})") from exc
        return client, client.close
    cluster = LocalCluster(
        n_workers=n_workers or os.cpu_count() or 1,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",  # a free port: never clashes with another cluster
        silence_logs=logging.ERROR,  # not the workers' warnings about cancelled tasks
        env=WORKER_ENV,
    )
    client = Client(cluster)

    def close() -> None:
        client.close()
        cluster.close()

    return client, close


def _run_dask(spec, store, pending, scheduler, n_workers) -> Iterator[dict]:
    if not pending:
        return
    client, close = _client(scheduler, n_workers)
    token = uuid.uuid4().hex[:8]  # keys unique on a shared scheduler
    futures: dict = {}  # future -> (kind, id)
    try:
        for layout_id, group in _by_layout(pending).items():
            fe = _stored_fe(store, layout_id)
            if fe is None:
                fe = client.submit(
                    analyse_layout, layout_job(spec, group[0].layout), key=f"fe-{layout_id}-{token}"
                )
                futures[fe] = ("fe", layout_id)
            else:
                [fe] = client.scatter([fe], hash=False)
            for case in group:
                job = case_job(spec, case)
                fut = client.submit(optimise_case, fe, job, key=f"case-{case.case_id}-{token}")
                futures[fut] = ("case", case.case_id)
        for fut in as_completed(list(futures)):
            kind, ident = futures.pop(fut)
            outcome = _outcome(fut)
            if kind == "fe":
                if outcome is not None:
                    _keep_model(store, ident, outcome)
            else:
                yield outcome if outcome is not None else _lost(ident, fut)
    finally:
        client.cancel(list(futures))
        close()


def _outcome(fut):
    """The future's result, or None if the task itself failed (lost worker, ...)."""
    try:
        return fut.result()
    except Exception:
        return None


def _lost(case_id: str, fut) -> dict:
    exc = fut.exception()
    return {
        "case_id": case_id,
        "status": "error",
        "stage": "worker",
        "error_type": type(exc).__name__,
        "error": f"the task failed outside the case's code: {exc}",
        "fe": None,
        "worker": None,
        "finished_unix_s": time.time(),
    }
