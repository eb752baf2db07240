"""Run a sweep: skip finished cases, compute the rest serially or on dask.distributed, store
each record the moment it arrives, then write the table and the plots.

Executors:

* ``"serial"``: in this process, layout by layout (the reference; no dask involved);
* ``"dask"``: a ``dask.distributed.Client`` on an embedded ``LocalCluster`` (``n_workers``
  worker processes, one thread each; default one per core) or on the scheduler at
  ``scheduler`` ("tcp://host:8786"), both options of :class:`Executor`; see
  optim.sweep.cluster for the connection, the version gate and the lost workers. One task
  per layout runs the finite-element analysis; one task per case optimises, depending on
  its layout's task, so dask schedules the FE analyses in
  parallel processes and runs each case next to its model. Tasks are submitted in bounded
  batches: at most ``cluster.window`` case tasks (a few per worker thread) are out at once,
  and a new one goes out as a record comes back, so neither the task graph nor the client
  grows with the sweep. The records come back to this process (``as_completed``), which
  alone writes the results directory, so the workers need no shared file system; the client
  keeps only each case's status (``SweepRun.records`` reads the store on demand).

Interrupting (Ctrl-C) cancels what is pending and keeps every stored record; the next run
computes only the missing cases. A lost scheduler stops the run with
:class:`~optim.sweep.cluster.ClusterError`; the stored records stay, and a rerun against a new
scheduler computes the missing cases.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from distributed import as_completed

from jaxflex.errors import InputError
from jaxflex.files import directory_lock, kept_writes
from jaxflex.model import ModalModel
from jaxflex.runtime import check_time, progress_bar, require
from optim.sweep.best import MoveBest, best_layouts, move_limits
from optim.sweep.cases import Case, case_job, expand, layout_job
from optim.sweep.cluster import ClusterError, check_dashboard, connect
from optim.sweep.plan import sweep_needs, workers
from optim.sweep.plots import plot_sweep
from optim.sweep.spec import SweepSpec
from optim.sweep.store import ResultStore, StoredRecords, is_final
from optim.sweep.table import table_rows, write_table
from optim.sweep.work import (
    analyse_layout,
    fe_from_model,
    optimise_case,
    payload_model,
)

EXECUTORS = ("serial", "dask")


@dataclass
class SweepRun:
    """What a run did. ``records`` maps the case id of every stored record of the spec's
    cases to its record, read from the store on access (optim.sweep.store.StoredRecords)."""

    spec: SweepSpec
    directory: Path
    cases: list[Case]
    records: StoredRecords
    computed: int = 0
    skipped: int = 0
    wall_s: float = 0.0
    executor: str = "serial"
    outputs: list[str] = field(default_factory=list)
    peak_in_flight: int = 0  # dask: the most case tasks submitted and not yet collected
    lost_workers: int = 0  # dask: workers that died or left during the run
    retried_tasks: int = 0  # dask: tasks of the run rescheduled after a lost worker

    @property
    def n_errors(self) -> int:
        return self.records.count("error")

    @property
    def rows(self) -> list[dict]:
        return list(table_rows(self.cases, self.records))

    def record(self, case: Case) -> dict:
        """The stored record of ``case`` (optim.sweep.table lists its fields)."""
        if case.case_id not in self.records:
            raise InputError(f"case {case.case_id} ({case.layout.name}): no stored record")
        return self.records[case.case_id]

    def model(self, case: Case) -> ModalModel:
        """The modal model of ``case``'s layout, as stored by the FE step."""
        found = ResultStore(self.directory).load_model(case.layout_id)
        if found is None:
            raise InputError(
                f"layout {case.layout.name!r}: no stored model (its FE step failed or has not run)"
            )
        return found[0]

    def best(self) -> list[MoveBest]:
        """Per move, the best layout and its comparison (optim.sweep.best)."""
        return best_layouts(self.spec, self._stored())

    def _stored(self):
        return ((c, self.records[c.case_id]) for c in self.cases if c.case_id in self.records)

    def warnings(self) -> list[str]:
        """Each kind of warning the cases got, once, with the number of cases."""
        kinds: dict[str, tuple[int, str]] = {}  # kind -> (cases, the first message)
        for _case, record in self._stored():
            for w in (record.get("opt") or {}).get("warnings", []):
                count, first = kinds.get(w["kind"], (0, w["message"]))
                kinds[w["kind"]] = (count + 1, first)
        return [
            f"warning ({count} case{'s' if count > 1 else ''}): {message}"
            for count, message in kinds.values()
        ]

    def summary(self) -> str:
        """The answer per move first (best layout), then the run's bookkeeping."""
        rate = 60.0 * self.computed / self.wall_s if self.wall_s > 0 else float("nan")
        lost = (
            f"; lost workers: {self.lost_workers}, retried tasks: {self.retried_tasks}"
            if self.lost_workers
            else ""
        )
        lines = [*move_limits(self.spec), *(best.line() for best in self.best())]
        lines.append(
            f"{self.spec.name}: {len({c.case_id for c in self.cases})} cases, "
            f"{self.records.count('ok')} ok, {self.n_errors} errors; computed {self.computed} "
            f"({self.executor}, {self.wall_s:.1f} s, {rate:.1f} cases/min), skipped "
            f"{self.skipped} finished{lost}"
        )
        lines += self.warnings()
        return "\n".join(lines)


@dataclass(frozen=True)
class Executor:
    """Where a sweep's cases run (module docstring), checked when made: ``kind`` "dask"
    (default) or "serial"; for dask the embedded LocalCluster's ``n_workers`` (default one
    per core) and ``dashboard_address`` ("host:port"), or the ``scheduler`` to connect to
    ("tcp://host:8786"; optim.sweep.cluster.connect), and ``notify`` for the messages about
    the cluster (default: stderr)."""

    kind: str = "dask"
    n_workers: int | None = None
    scheduler: str | None = None
    dashboard_address: str | None = None
    notify: Callable[[str], None] | None = None

    def __post_init__(self) -> None:
        if self.kind not in EXECUTORS:
            raise InputError(f"executor: must be one of {list(EXECUTORS)}, got {self.kind!r}")
        for name in ("scheduler", "dashboard_address"):
            if getattr(self, name) is not None and self.kind != "dask":
                raise InputError(f"{name}: only used with the dask executor")
        if self.n_workers is not None and self.n_workers < 1:
            raise InputError(f"n_workers: must be >= 1, got {self.n_workers}")
        check_dashboard(self.dashboard_address)

    def connect(self):
        """The dask client of this executor (optim.sweep.cluster.connect)."""
        where = {"n_workers": self.n_workers, "dashboard_address": self.dashboard_address}
        return connect(self.scheduler, notify=self.notify, **where)


def run_sweep(
    spec: SweepSpec,
    directory: str | Path,
    *,
    executor: Executor | str = "dask",
    retry_errors: bool = False,
    progress: bool | None = None,
    plots: bool = True,
    on_record: Callable[[dict, float], None] | None = None,
) -> SweepRun:
    """Compute every case of ``spec`` not yet stored in ``directory`` and write the table
    (``results.csv``) and plots, the cases run by ``executor`` (an :class:`Executor`, or
    its kind "dask" or "serial" with the defaults). ``retry_errors`` recomputes cases whose
    stored record is an error. ``on_record(record, store_s)`` is called after each record
    is stored, with the seconds the store took."""
    if isinstance(executor, str):
        executor = Executor(executor)
    elif not isinstance(executor, Executor):
        raise InputError(
            "executor: 'dask', 'serial' or an optim.sweep.Executor(...), got "
            f"{type(executor).__name__}"
        )
    store = ResultStore(directory, dt_s=spec.optimization.dt_s)
    with directory_lock(store.root, option="-o/--output"):
        options = _Options(
            executor=executor.kind,
            n_workers=workers(executor.n_workers, executor.kind),
            connect_to=executor.connect,
            retry_errors=retry_errors,
            progress=progress,
            plots=plots,
            on_record=on_record,
        )
        return _run_locked(spec, store, options)


@dataclass(frozen=True)
class _Options:
    """run_sweep's options, checked (``connect_to`` opens the dask cluster)."""

    executor: str
    n_workers: int
    connect_to: Callable
    retry_errors: bool
    progress: bool | None
    plots: bool
    on_record: Callable[[dict, float], None] | None


def _run_locked(spec: SweepSpec, store: ResultStore, options: _Options) -> SweepRun:
    """run_sweep's work, with the results directory locked against other sweeps."""
    store.remove_temporaries()
    store.save_spec(spec.source)
    cases = expand(spec)
    run = SweepRun(spec, store.root, cases, StoredRecords(store), executor=options.executor)
    pending: dict[str, Case] = {}
    for case in cases:
        if case.case_id in run.records or case.case_id in pending:
            continue
        record = store.read_record(case.case_id)  # checked; a bad one is rejected
        if (
            record is not None
            and is_final(record)
            and not (options.retry_errors and record["status"] != "ok")
        ):
            run.records.add(record)
        else:
            pending[case.case_id] = case
    run.skipped = len(run.records)
    if pending:  # before the first case: a sweep that cannot run within the budget is refused
        layouts = len({case.layout_id for case in pending.values()})
        require(*sweep_needs(spec, len(pending), layouts, options.n_workers))
    start = time.perf_counter()
    bar = progress_bar(len(pending), spec.name, options.progress, unit="case")

    def consume(stream: Iterator[dict]) -> None:
        with contextlib.closing(stream):
            for record in stream:
                store_start = time.perf_counter()
                record = store.save_record(record)
                store_s = time.perf_counter() - store_start
                run.records.add(record)
                run.computed += 1
                bar.update()
                bar.set_postfix_str(f"errors={run.n_errors}")
                if options.on_record is not None:
                    options.on_record(record, store_s)
                check_time(
                    f"the sweep ({run.computed} of {len(pending)} cases computed)",
                    "the computed cases are stored: the same command computes the rest",
                )

    try:
        if options.executor == "serial":
            consume(_run_serial(spec, store, list(pending.values())))
        elif pending:
            with options.connect_to() as cluster:
                _on_cluster(cluster, run, store, list(pending.values()), consume)
    finally:
        bar.close()
        run.wall_s = time.perf_counter() - start
        with kept_writes():  # the table of what is stored, also when the run failed
            write_table(store.root / "results.csv", table_rows(cases, run.records))
    run.outputs.append(str(store.root / "results.csv"))
    if options.plots:
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


def _run_serial(spec, store, pending) -> Iterator[dict]:
    for layout_id, group in _by_layout(pending).items():
        fe = _stored_fe(store, layout_id)
        if fe is None:
            fe = analyse_layout(layout_job(spec, group[0].layout))
            _keep_model(store, layout_id, fe)
        for case in group:
            yield optimise_case(fe, case_job(spec, case))


def _on_cluster(cluster, run, store, pending, consume) -> None:
    """Compute ``pending`` on ``cluster``, ``consume`` the records, count the lost workers."""
    try:
        consume(_run_dask(cluster, run, store, pending))
    except ClusterError as exc:
        missing = len(pending) - run.computed
        raise ClusterError(
            f"{exc}; the {run.computed} cases computed before are stored, {missing} are "
            "not: rerun the same command against a running scheduler to compute only those"
        ) from None
    finally:
        run.lost_workers = cluster.lost_workers
        run.retried_tasks = cluster.retried_tasks


def restored_fe(fe: dict) -> dict:
    """The stored FE outcome of a layout as a task's result: dask keeps the task's
    arguments, so it can recompute the result if the worker holding it is lost (scattered
    data would be lost with the worker)."""
    return fe


def _submissions(cluster, spec, store, pending) -> Iterator[tuple]:
    """(future, kind, id) of each task, submitted as the caller asks for the next: a layout's
    FE task ("fe", or its stored model, not watched), then its cases ("case")."""
    client, token, options = cluster.client, cluster.token, cluster.task_options
    for layout_id, group in _by_layout(pending).items():
        stored = _stored_fe(store, layout_id)
        if stored is None:
            job = layout_job(spec, group[0].layout)
            fe = client.submit(analyse_layout, job, key=f"fe-{layout_id}-{token}", **options)
            yield fe, "fe", layout_id
        else:
            fe = client.submit(restored_fe, stored, key=f"model-{layout_id}-{token}", **options)
        for case in group:
            job = case_job(spec, case)
            key = f"case-{case.case_id}-{token}"
            yield client.submit(optimise_case, fe, job, key=key, **options), "case", case.case_id


def _run_dask(cluster, run, store, pending) -> Iterator[dict]:
    """The records of ``pending`` as they finish, with at most ``cluster.window`` case tasks
    out at once; FE results are stored as models on the way."""
    submissions = _submissions(cluster, run.spec, store, pending)
    watched = as_completed()
    out: dict = {}  # future -> (kind, id): what the client holds
    n_cases = 0

    def top_up() -> None:
        nonlocal n_cases
        while n_cases < cluster.window:
            item = next(submissions, None)
            if item is None:
                break
            future, kind, ident = item
            out[future] = (kind, ident)
            watched.add(future)
            n_cases += kind == "case"
        run.peak_in_flight = max(run.peak_in_flight, n_cases)

    try:
        top_up()
        for future in watched:
            kind, ident = out.pop(future)
            outcome = _settled(future, cluster)
            if kind == "fe":
                if outcome is not None:
                    _keep_model(store, ident, outcome)
            else:
                n_cases -= 1
                yield outcome if outcome is not None else _lost(ident, future)
            top_up()
    finally:
        if out and cluster.client.status == "running":
            cluster.client.cancel(list(out))


def _cancelled(future, cluster) -> str:
    """Why a task of the run was cancelled from outside (the run never cancels its own)."""
    reason = "unknown"
    try:
        future.result()
    except Exception as exc:  # the FutureCancelledError, with dask's reason
        reason = getattr(exc, "reason", str(exc))
    if reason == "scheduler-connection-lost":
        return _lost_scheduler(cluster)
    address = cluster.client.scheduler.address
    return f"the scheduler at {address} cancelled the sweep's tasks ({reason})"


def _lost_scheduler(cluster) -> str:
    """What stopped a run whose scheduler is gone (the CLI adds what was stored)."""
    return f"lost the connection to the scheduler at {cluster.client.scheduler.address}"


def _settled(future, cluster):
    """The result of a finished ``future``, or None if its task failed (status "error": a
    lost worker, ...). ClusterError if the result cannot be read for another reason: the
    future was cancelled from outside (dask cancels every future the client holds when the
    scheduler is lost), or its result could not be fetched (a task finished on a worker
    whose result the client asks for after the scheduler is gone: the future is still
    "finished" when the read fails, and cancelled only after)."""
    try:
        return future.result()
    except Exception:
        if future.status == "error":
            return None
        if future.status == "cancelled":
            raise ClusterError(_cancelled(future, cluster)) from None
        raise ClusterError(_lost_scheduler(cluster)) from None


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
