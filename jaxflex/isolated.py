"""Readers that cannot take the process down: third-party code with native parts (gmsh,
ansys-mapdl-reader, meshio's readers) run in a child interpreter.

A damaged file can make native code crash (a segmentation fault, std::bad_alloc ending in
an abort), allocate without bound or loop. Decorated with :func:`isolated`, a reader runs in
a fresh interpreter (``subprocess``: allowed in dask's daemonic workers, where
multiprocessing may not start children) that imports only the reader's own module (its
packages' ``__init__`` are not run: no JAX, no scikit-fem where the reader does not need
them; nor those of the third-party packages the decorator names, ``bare``:
ansys-mapdl-reader's imports pyvista's plotting and matplotlib, 1 s of CPU, for a reader of
binary records), under the process's budget (jaxflex._budget): its address space is limited
to the memory budget on top of what its imports mapped (``RLIMIT_AS``), and it is stopped
when the time budget runs out. The result comes back pickled (numpy arrays, dataclasses of them).

What reaches the caller is the reader's result or one error naming the file:

* the reader's own JaxflexError (InputError, ...) as it raised it;
* any other exception as an InputError ``FIELD: cannot read 'PATH' (Type: message)``;
* a crash (a signal, an exit without a result) as an InputError saying that the reader
  crashed on the file and how (``SIGSEGV``), with the reader's last words on stderr;
* running out of the memory or time budget as a BudgetError.

Inside the child the decorated functions run directly (a reader that calls another one
stays in the same child).

The child ends with its parent, however the parent ends (SIGTERM, SIGKILL, Ctrl-C, its
budget): it asks for the parent-death signal first thing (jaxflex._children.GUARD, Linux),
and a thread of it exits the process when its lifeline, a pipe whose other end only the
parent holds, closes (every POSIX system). Other programs a command runs (a compiler, a
test harness, wine) go through :func:`run_child`, ``subprocess.run`` whose child dies with
the command the same way (jaxflex._children).
"""

from __future__ import annotations

import functools
import importlib.util
import os
import pickle
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from jaxflex._budget import current_budget, format_bytes, format_seconds
from jaxflex._children import GUARD
from jaxflex._children import run as run_child
from jaxflex._inputs import check_input_file
from jaxflex.errors import BudgetError, InputError, JaxflexError

__all__ = ["isolated", "run_child"]


F = TypeVar("F", bound=Callable[..., Any])
_IN_CHILD = False
STDERR_TAIL = 300  # characters of the child's stderr quoted in a crash message
_SINGLE_THREAD = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

# The child's program (``python -I -c PROGRAM PARENT_PID LIFELINE_FD``): the parent-death
# signal; the lifeline's watcher; only the standard library until the request has set
# sys.path and the packages of the reader's module (as bare namespaces, so that their
# __init__ does not run); then the module, the address-space limit, the call, the answer.
_CHILD = (
    GUARD
    + r"""
import importlib, os, pickle, resource, sys, threading, types
def watch(fd):
    while os.read(fd, 1):
        pass
    os._exit(1)  # the parent ended: its end of the lifeline closed
threading.Thread(target=watch, args=(int(sys.argv[2]),), daemon=True).start()
out = os.fdopen(os.dup(1), "wb")
os.dup2(2, 1)
request = pickle.load(sys.stdin.buffer)
sys.path[:] = request["sys_path"]
for name, folder in request["packages"].items():
    package = types.ModuleType(name)
    package.__path__ = [folder]
    sys.modules[name] = package
    if "." in name:  # a subpackage: an attribute of its parent too, as an import makes it
        parent, _, leaf = name.rpartition(".")
        setattr(importlib.import_module(parent), leaf, package)
try:
    importlib.import_module("jaxflex.isolated")._IN_CHILD = True
    target = importlib.import_module(request["module"])
    for part in request["qualname"].split("."):
        target = getattr(target, part)
    target = getattr(target, "__wrapped__", target)
    if request["memory_bytes"]:
        with open("/proc/self/statm") as statm:
            mapped = int(statm.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        limit = mapped + request["memory_bytes"]
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    answer = ("ok", target(*request["args"], **request["kwargs"]))
except MemoryError:
    answer = ("memory", None)
except BaseException as exc:
    try:
        pickle.dumps(exc)
        answer = ("raised", exc)
    except Exception:
        answer = ("error", (type(exc).__name__, str(exc)))
try:
    data = pickle.dumps(answer, protocol=pickle.HIGHEST_PROTOCOL)
except MemoryError:
    data = pickle.dumps(("memory", None))
except Exception as exc:
    data = pickle.dumps(("error", (type(exc).__name__, str(exc))))
out.write(data)
out.flush()
"""
)


def _packages(module: str, bare: tuple[str, ...] = ()) -> dict[str, str]:
    """The top-level package of ``module`` (if it is in one), the project's core and the
    (third-party) packages ``bare``, by folder: the child does not run their ``__init__``."""
    names = {module.split(".")[0], "jaxflex"}
    folders = {
        name: str(Path(sys.modules[name].__file__).parent)
        for name in names
        if hasattr(sys.modules[name], "__path__")
    }
    return folders | {name: _folder(name) for name in bare}


@functools.cache
def _folder(package: str) -> str:
    """The folder of ``package``, found without running its ``__init__`` (only its parents')."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise ImportError(f"no package {package!r}")
    return next(iter(spec.submodule_search_locations))


def _signal_name(returncode: int) -> str:
    try:
        return signal.Signals(-returncode).name
    except ValueError:
        return f"signal {-returncode}"


def run_isolated(
    func: Callable,
    args: tuple,
    kwargs: dict,
    *,
    field: str,
    reader: str,
    path: str,
    bare: tuple[str, ...] = (),
) -> Any:
    """``func(*args, **kwargs)`` in a child interpreter under the process's budget (module
    docstring); ``field`` and ``path`` name the input in messages, ``reader`` the library;
    the child does not run the ``__init__`` of the packages ``bare``."""
    budget = current_budget()
    memory = 0 if budget.memory_bytes <= 0 else int(budget.memory_bytes)
    request = pickle.dumps(
        {
            "sys_path": list(sys.path),
            "packages": _packages(func.__module__, bare),
            "module": func.__module__,
            "qualname": func.__qualname__,
            "args": args,
            "kwargs": kwargs,
            "memory_bytes": memory,
        }
    )
    env = {**os.environ, **dict.fromkeys(_SINGLE_THREAD, "1")}
    lifeline, keep = os.pipe()  # the child reads; this process holds the other end
    try:
        try:
            child = subprocess.Popen(
                [sys.executable, "-I", "-c", _CHILD, str(os.getpid()), str(lifeline)],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                env=env,
                start_new_session=True,
                pass_fds=(lifeline,),
            )
        finally:
            os.close(lifeline)
        out, err = _communicate(child, request, budget, path, reader)
    finally:
        os.close(keep)
    return _answer(out, err, child.returncode, field, reader, path, memory, budget)


def _communicate(child: subprocess.Popen, request: bytes, budget, path: str, reader: str):
    """(stdout, stderr) of ``child`` given ``request``; BudgetError when the time budget
    runs out first (the child is killed, as on any interrupt)."""
    left = budget.remaining_s()
    try:
        return child.communicate(request, timeout=None if left == float("inf") else left)
    except subprocess.TimeoutExpired:
        child.kill()
        child.communicate()
        raise BudgetError(
            f"time: reading {path!r} ({reader}) did not finish within the "
            f"{format_seconds(left)} left of the budget of {format_seconds(budget.time_s)} "
            f"({budget.time_source})"
        ) from None
    except BaseException:  # an interrupt: the child goes with us
        child.kill()
        child.communicate()
        raise


def _answer(out: bytes, err: bytes, returncode: int, field, reader, path, memory, budget):
    """The child's result, or the error it stands for (module docstring)."""
    try:
        kind, value = pickle.loads(out) if out else (None, None)
    except Exception:  # a child killed while writing its answer
        kind, value = None, None
    if kind == "ok":
        return value
    if kind == "raised" and isinstance(value, JaxflexError):
        raise value
    if kind == "raised" and isinstance(value, KeyboardInterrupt):
        raise KeyboardInterrupt
    if kind == "memory":
        raise BudgetError(
            f"memory: reading {path!r} ({reader}) needs more than the budget of "
            f"{format_bytes(memory)} ({budget.memory_source}); a file this large or damaged "
            "in its declared sizes cannot be read within it"
        )
    if kind in ("raised", "error"):
        name, message = (
            (type(value).__name__, str(value)) if kind == "raised" else (value[0], value[1])
        )
        raise InputError(f"{field}: cannot read {path!r} ({name}: {message})")
    how = _signal_name(returncode) if returncode < 0 else f"exit status {returncode}"
    words = err.decode("utf-8", "replace").strip()[-STDERR_TAIL:]
    raise InputError(
        f"{field}: {path!r} is damaged or not a file {reader} can read: the reader crashed "
        f"on it ({how}) and nothing was taken from it"
        + (f"; its last message: {words!r}" if words else "")
    )


def isolated(
    field: str,
    reader: str,
    path_arg: int = 0,
    precheck: Callable[[Path], None] | None = None,
    bare: tuple[str, ...] = (),
) -> Callable[[F], F]:
    """Decorator: the function (a module-level reader whose argument ``path_arg`` is the
    file) runs in a child interpreter (module docstring); ``field`` names the input in
    messages (``mesh``, ``cad``, ``--from-ansys``), ``reader`` the library. The file is
    checked to be a readable regular file first, and by ``precheck(path)`` (a structural
    check of the format, raising InputError) where given. The child skips the ``__init__``
    of the packages ``bare`` (the reader then imports what it uses from their submodules)."""

    def wrap(func: F) -> F:
        @functools.wraps(func)
        def call(*args, **kwargs):
            if _IN_CHILD:
                return func(*args, **kwargs)
            path = check_input_file(field, args[path_arg])
            if precheck is not None:
                precheck(path)
            return run_isolated(
                func, args, kwargs, field=field, reader=reader, path=str(path), bare=bare
            )

        return call  # type: ignore[return-value]

    return wrap
