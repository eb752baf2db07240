"""The dask.distributed cluster of a sweep: connecting, admitting workers by their jaxflex
version, and telling the user what happens to the workers while the sweep runs.

* :func:`connect` gives a :class:`Cluster` on an embedded ``LocalCluster`` (its scheduler,
  workers and dashboard bound to 127.0.0.1 unless asked otherwise) or on the scheduler at an
  address, and prints the dashboard link.
* **Version gate.** Every worker advertises its own jaxflex version as a dask resource
  (``jaxflex-0.1.0``: as many units as it has threads) through a worker plugin that dask also
  runs on workers joining later; every task of the sweep asks for one unit of the client's
  version. A worker with another version (or none) never gets a task of this sweep: it is
  refused by name when the sweep connects or when it joins, and other sweeps on a shared
  scheduler keep using it under their own version. No worker of the client's version at
  connect is an error.
* **Lost workers.** The scheduler's events tell which worker left or died; the tasks of this
  sweep it was running or held results of are rescheduled by dask on the other workers
  (up to ``distributed.scheduler.allowed-failures`` deaths per task), and the user is told
  so, or that the sweep waits for a worker if none is left.

Events arrive on the client's event-loop thread; the counters are guarded by a lock.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import uuid
from collections.abc import Callable, Iterator

import dask
from distributed import Client, LocalCluster
from distributed.diagnostics.plugin import WorkerPlugin

import jaxflex
from jaxflex.errors import InputError, JaxflexError
from jaxflex.runtime import note

# One thread per worker process for every numeric library (the workers are the parallelism).
WORKER_ENV = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
}
DASHBOARD_ADDRESS = "127.0.0.1:0"  # this machine only, a free port
# dask settings of the client and the embedded LocalCluster, so that no process grows while
# a sweep runs (measured, docs/sweep.md): dask's statistical profiler samples every thread
# each 10 ms and keeps a call tree per second for the last 1000 s, for the dashboard's
# profile page only (workers grew by ~0.17 MB/s for 17 minutes); its developers' logs keep
# the last 1000 messages of every connection, task specifications included (the client
# with the LocalCluster's scheduler grew by ~1 kB per case for the first ~1500 cases).
# Other clusters: DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False where workers start.
SWEEP_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.low-level-log-length": 100,
}
CONNECT_TIMEOUT_S = 15.0  # connecting, waiting for a first worker, reconnecting
TASKS_PER_THREAD = 4  # case tasks submitted per worker thread: the bounded batch
PLUGIN_NAME = "jaxflex-version"
TOPIC = "jaxflex-worker"  # the plugin's event: a worker's address, name, version, threads
SCHEMES = ("tcp://", "tls://", "inproc://", "ucx://", "ws://", "wss://")


class ClusterError(JaxflexError):
    """The dask cluster cannot run the sweep: no admissible worker, or the scheduler is lost."""


def resource_name(version: str) -> str:
    """The dask resource that workers running jaxflex ``version`` offer."""
    return f"jaxflex-{version}"


def worker_version() -> str:
    """The jaxflex version importable where this runs (called on each worker)."""
    return jaxflex.__version__


class VersionResource(WorkerPlugin):
    """Worker plugin: offer the resource of the worker's own jaxflex version (one unit per
    thread) and announce the worker on :data:`TOPIC`."""

    async def setup(self, worker) -> None:
        version = worker_version()
        nthreads = worker.state.nthreads
        await worker.set_resources(**{resource_name(version): nthreads})
        worker.log_event(
            TOPIC,
            {
                "worker": worker.contact_address,
                "name": str(worker.name),
                "jaxflex": version,
                "nthreads": nthreads,
            },
        )


def _notify_stderr(message: str) -> None:
    note(f"jaxflex sweep: {message}")  # above the progress bar, also when quiet


class Cluster:
    """A connected client, the admitted workers, and what happened to them.

    ``resource`` is what every task asks for; ``token`` makes this run's task keys unique on
    a shared scheduler; ``window`` is the number of case tasks to keep submitted."""

    def __init__(self, client, notify: Callable[[str], None]):
        self.client = client
        self.notify = notify
        self.version = jaxflex.__version__
        self.resource = resource_name(self.version)
        self.token = uuid.uuid4().hex[:8]
        self.lost_workers = 0
        self.retried_tasks = 0
        self._lock = threading.Lock()
        self._threads: dict[str, int] = {}  # admitted worker address -> threads
        self._refused: set[str] = set()

    @property
    def task_options(self) -> dict:
        return {"resources": {self.resource: 1}}

    @property
    def window(self) -> int:
        with self._lock:
            return TASKS_PER_THREAD * max(1, sum(self._threads.values()))

    def dashboard_link(self) -> str | None:
        try:
            return self.client.dashboard_link
        except KeyError:  # the scheduler runs without a dashboard
            return None

    def admit_workers(self) -> None:
        """Check every connected worker's jaxflex version, refuse the others by name, and
        install the version gate (see the module docstring)."""
        client = self.client
        client.subscribe_topic(TOPIC, self._on_worker_ready)
        client.subscribe_topic("all", self._on_scheduler_event)
        try:
            client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
        except TimeoutError as exc:
            raise ClusterError(
                f"the scheduler at {client.scheduler.address} has no worker after "
                f"{CONNECT_TIMEOUT_S:g} s: start workers with jaxflex {self.version} "
                f"(dask worker {client.scheduler.address})"
            ) from exc
        names = {a: w.get("name", a) for a, w in client.scheduler_info()["workers"].items()}
        versions = client.run(worker_version, on_error="return")
        for address, found in versions.items():
            if found == self.version:
                continue
            what = f"jaxflex {found}" if isinstance(found, str) else f"no usable jaxflex ({found})"
            self._refuse(address, names.get(address, address), what)
        if len(self._refused) == len(versions):
            raise ClusterError(
                f"no worker of {client.scheduler.address} runs jaxflex {self.version}: "
                "install this version on the workers and restart them"
            )
        try:
            client.register_plugin(VersionResource(), name=PLUGIN_NAME)
        except Exception:  # a refused worker may not even load the plugin
            if not self._refused:
                raise
        nthreads = client.nthreads()  # not under the lock: the event handlers need the loop
        with self._lock:
            for address, found in versions.items():
                if found == self.version and address in nthreads:
                    self._threads.setdefault(address, nthreads[address])

    def _refuse(self, address: str, name: str, what: str) -> None:
        with self._lock:
            if address in self._refused:
                return
            self._refused.add(address)
        label = address if name == address else f"{address} ({name})"
        self.notify(
            f"refused worker {label}: it has {what}, this client jaxflex {self.version}; "
            "it gets no case of this sweep"
        )

    def _on_worker_ready(self, event) -> None:
        _, msg = event
        if msg["jaxflex"] == self.version:
            with self._lock:
                self._threads[msg["worker"]] = msg["nthreads"]
        else:
            self._refuse(msg["worker"], msg["name"], f"jaxflex {msg['jaxflex']}")

    def _on_scheduler_event(self, event) -> None:
        _, msg = event
        if not isinstance(msg, dict) or msg.get("action") != "remove-worker":
            return
        address = msg["worker"]
        with self._lock:
            if self._threads.pop(address, None) is None:
                return  # a refused or unknown worker: none of our tasks
            left = len(self._threads)
            running = sum(self.token in str(k) for k in msg["processing-tasks"])
            results = sum(self.token in str(k) for k in msg["lost-computed-tasks"])
            self.lost_workers += 1
            self.retried_tasks += running + results
        where = "on the other workers" if left else "when a worker joins (none is left)"
        self.notify(
            f"worker {address} {'left' if msg['expected'] else 'lost'}: {running} tasks of "
            f"this sweep it ran or had queued are retried and {results} results it held are "
            f"recomputed, {where}"
        )


def check_dashboard(address: str | None) -> str | None:
    """``address`` ("HOST:PORT", HOST a name or address, may be empty: every interface;
    PORT 0 .. 65535, 0 a free one) if it is one, None for None; InputError naming
    dashboard_address (--dashboard) otherwise."""
    if address is None:
        return None
    host, colon, port = str(address).strip().rpartition(":")
    if not colon or not port.isdigit() or int(port) > 65535 or any(c.isspace() for c in host):
        raise InputError(
            "dashboard_address (--dashboard): HOST:PORT, e.g. 127.0.0.1:8787, 0.0.0.0:8787 "
            f"(every interface) or 127.0.0.1:0 (a free port); got {address!r}"
        )
    return f"{host}:{int(port)}"


def _local_cluster(n_workers: int | None, dashboard_address: str | None):
    """The embedded LocalCluster; InputError naming the dashboard's address or the workers
    if it does not start (an address of another machine, a name that does not resolve)."""
    try:
        return LocalCluster(
            n_workers=n_workers or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=dashboard_address or DASHBOARD_ADDRESS,
            silence_logs=logging.ERROR,  # not the workers' warnings about cancelled tasks
            env=WORKER_ENV,
        )
    except (RuntimeError, OSError, ValueError) as exc:
        cause = exc.__cause__ or exc.__context__ or exc
        raise InputError(
            f"cannot start the local dask cluster (n_workers (--workers) "
            f"{n_workers or os.cpu_count()}, dashboard_address (--dashboard) "
            f"{dashboard_address or DASHBOARD_ADDRESS!r}): {type(cause).__name__}: {cause}"
        ) from None


@contextlib.contextmanager
def connect(
    scheduler: str | None = None,
    *,
    n_workers: int | None = None,
    dashboard_address: str | None = None,
    notify: Callable[[str], None] | None = None,
) -> Iterator[Cluster]:
    """A :class:`Cluster` on the scheduler at ``scheduler`` ("tcp://host:8786") or, if None,
    on an embedded LocalCluster of ``n_workers`` single-threaded processes (default one per
    core) with its dashboard at ``dashboard_address`` ("host:port", default 127.0.0.1 and a
    free port). ``notify`` gets the messages for the user (default: stderr); the dashboard
    link is the first. Everything started is closed on exit."""
    with dask.config.set(SWEEP_CONFIG):  # read as the objects start; nannies pass it on
        client, local = _start(scheduler, n_workers, dashboard_address)
    try:
        cluster = Cluster(client, notify or _notify_stderr)
        link = cluster.dashboard_link()
        cluster.notify(
            f"dashboard: {link}" if link else "dashboard: none (the scheduler serves none)"
        )
        cluster.admit_workers()
        yield cluster
    finally:
        if client.status == "running":
            for topic in (TOPIC, "all"):  # else the scheduler's last events meet a closed comm
                client.unsubscribe_topic(topic)
            client.close()
        else:  # the scheduler is lost: closing cancels dask's reconnection, which it logs
            with _silenced("distributed.client"):
                client.close()
        if local is not None:
            local.close()


def _start(scheduler: str | None, n_workers: int | None, dashboard_address: str | None):
    """(client, LocalCluster or None)."""
    if scheduler is not None:
        if not scheduler.startswith(SCHEMES):
            raise InputError(
                f"scheduler: expected an address like tcp://host:8786, got {scheduler!r}"
            )
        if dashboard_address is not None:
            raise InputError(
                "dashboard_address: only for the embedded LocalCluster; a scheduler serves "
                "its own (dask scheduler --dashboard-address)"
            )
        try:
            client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s")
        except (OSError, TimeoutError) as exc:
            raise InputError(f"scheduler: cannot connect to {scheduler} ({exc})") from exc
        return client, None
    local = _local_cluster(n_workers, check_dashboard(dashboard_address))
    return Client(local), local


@contextlib.contextmanager
def _silenced(name: str) -> Iterator[None]:
    logger = logging.getLogger(name)
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)
