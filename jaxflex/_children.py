"""Child processes that end with the process that started them.

A command stopped by whoever runs it (a scheduler's SIGTERM, ``kill -9``, Ctrl-C, its own
time budget) must not leave its children running: a native reader holding gigabytes, a
compiler, a worker. On Linux each child asks the kernel for the parent-death signal
(``prctl(PR_SET_PDEATHSIG, SIGKILL)`` through ctypes) as the first thing it does, so it is
killed the moment its parent ends, for any reason, SIGKILL included; having asked, it checks
that its parent is still the one that started it (the parent may have ended before) and
exits if not. The signal stays through ``exec``.

* :data:`GUARD`: that request as Python source, the first lines of a Python child's
  program (jaxflex.isolated's readers); the parent's process id is its ``sys.argv[1]``.
* :func:`run`: ``subprocess.run`` of any program (a compiler, the FMU harness, wine),
  started through a small Python launcher that runs :data:`GUARD` and then ``exec``\\ s the
  program (no ``preexec_fn``, which is unsafe in a process with threads: JAX's). The
  launcher costs one interpreter start without ``site``: 12 ms of CPU per child (measured).

The kernel sends the signal when the *thread* that started the child ends: start a child
from a thread that waits for it (as ``subprocess.run`` and ``communicate`` do). Elsewhere
(no ``prctl``: macOS, Windows) the request is skipped and the children are plain;
jaxflex.isolated's readers then still exit when their pipe to the parent closes.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from typing import Any

# PR_SET_PDEATHSIG = 1, SIGKILL = 9 (linux/prctl.h, signal.h)
GUARD = """\
import ctypes as _ctypes, os as _os, sys as _sys
try:
    _ctypes.CDLL(None, use_errno=True).prctl(1, 9, 0, 0, 0)
except (OSError, AttributeError):
    pass
if _os.getppid() != int(_sys.argv[1]):
    _os._exit(1)
"""
_LAUNCHER = GUARD + "_os.execv(_sys.argv[2], _sys.argv[2:])\n"


def guarded(args: list[str]) -> list[str]:
    """The command line that runs ``args`` (program and arguments) as a child that dies
    with this process (module docstring). FileNotFoundError if the program is not found,
    as subprocess raises it."""
    args = [os.fspath(a) for a in args]
    program = shutil.which(args[0])
    if program is None:
        raise FileNotFoundError(2, "No such file or directory", args[0])
    if not sys.platform.startswith("linux"):
        return [program, *args[1:]]
    return [sys.executable, "-I", "-S", "-c", _LAUNCHER, str(os.getpid()), program, *args[1:]]


def run(args: list[str], **kwargs: Any) -> subprocess.CompletedProcess:
    """``subprocess.run(args, **kwargs)`` whose child dies with this process."""
    return subprocess.run(guarded(args), **kwargs)
