"""One budget for all work: the memory and the time a command may use, and the check of a
plan against them before any work.

Every command (``model``, ``optimize``, ``sweep``, ``export``, ``demo``, ``bench``) takes
``--max-memory GB`` and ``--max-time S`` (added by the dispatcher, jaxflex.cli). Without them
the budget comes from the machine: half of the memory this process may use (the least of the
physical memory, the cgroup's ``memory.max`` and the address-space limit ``ulimit -v``) and
:data:`DEFAULT_TIME_S` of wall time. The command line sets the process's budget
(:func:`use_budget`); library functions read it with :func:`current_budget`.

Work is planned from its inputs before it starts: each stage states what it needs as a
:class:`Need` (what, bytes, seconds, what to change), and :func:`require` refuses with a
BudgetError that says what the work would need, the budget, and the option that limits it.
Stages run one after the other, so their times add up and the peak memory is the largest
stage's. Times are estimates from figures measured on the project's 2-core machine (each
need says where its figure comes from); they are meant to tell minutes from days, not
seconds from seconds. Long work also checks its clock as it goes (:func:`check_time`).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import os
import resource
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from jaxflex._scalars import check_positive
from jaxflex.errors import BudgetError, InputError

DEFAULT_TIME_S = 3600.0
MEMORY_SHARE = 0.5  # of what the process may use
PLAN_NOTE_S = 60.0  # work planned to take at least this long is announced before it starts
GB = 1e9
# The least --max-memory: what a jaxflex command's interpreter holds before any work
# (Python, NumPy, SciPy, JAX and the command's modules: 224 MB resident at the dispatch of
# `jaxflex model`, measured on the project's machine), rounded up.
INTERPRETER_BYTES = 250_000_000


@dataclass(frozen=True)
class Budget:
    """What the work may use: ``memory_bytes`` at its peak and ``time_s`` of wall time
    from ``start_s`` (time.monotonic); ``source`` says where each figure comes from."""

    memory_bytes: int
    time_s: float
    memory_source: str = "--max-memory"
    time_source: str = "--max-time"
    start_s: float = 0.0

    def remaining_s(self) -> float:
        """Seconds of the time budget left (never below 0)."""
        if math.isinf(self.time_s):
            return math.inf
        return max(0.0, self.time_s - (time.monotonic() - self.start_s))

    def time_limit_text(self) -> str:
        """``the budget of 20 s (--max-time)``: the time budget as the errors name it."""
        return f"the budget of {format_seconds(self.time_s)} ({self.time_source})"


@dataclass(frozen=True)
class Need:
    """What a stage of work needs: ``memory_bytes`` at its peak and ``time_s`` (estimates);
    ``what`` names the work and its size, ``advice`` what makes it smaller."""

    what: str
    memory_bytes: float = 0.0
    time_s: float = 0.0
    advice: str = ""


def _cgroup_limit_bytes() -> int | None:
    """The memory limit of this process's cgroup (v2 ``memory.max`` or v1), None if none."""
    try:
        lines = Path("/proc/self/cgroup").read_text(encoding="utf-8").splitlines()
    except OSError:
        return None
    candidates = []
    for line in lines:
        _, controllers, group = line.split(":", 2)
        if controllers == "":
            candidates.append(Path("/sys/fs/cgroup") / group.lstrip("/") / "memory.max")
        elif "memory" in controllers.split(","):
            root = Path("/sys/fs/cgroup/memory") / group.lstrip("/")
            candidates.append(root / "memory.limit_in_bytes")
    for path in candidates:
        try:
            text = path.read_text(encoding="utf-8").strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 1 << 60:
            return int(text)
    return None


def physical_memory_bytes() -> int:
    """The machine's physical memory (4 GB where it cannot be read)."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 4 << 30


def _address_space_left() -> int | None:
    """Bytes of address space this process may still map under ``ulimit -v``, or None."""
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY:
        return None
    try:
        fields = Path("/proc/self/statm").read_text(encoding="utf-8").split()
        mapped = int(fields[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        mapped = 0
    return max(0, soft - mapped)


def resident_bytes() -> int:
    """The resident memory of this process (bytes; 0 where it cannot be read)."""
    try:
        pages = int(Path("/proc/self/statm").read_text(encoding="utf-8").split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def machine_memory_bytes() -> tuple[int, str]:
    """(bytes this process may use, where that figure comes from): the least of the
    physical memory, the cgroup limit and the address space left under ``ulimit -v``."""
    found = [(physical_memory_bytes(), "physical memory")]
    cgroup = _cgroup_limit_bytes()
    if cgroup is not None:
        found.append((cgroup, "the cgroup's memory limit"))
    left = _address_space_left()
    if left is not None:
        found.append((left, "the address space left under ulimit -v"))
    return min(found)


def default_budget() -> Budget:
    """The budget without options: MEMORY_SHARE of what the process may use, and
    DEFAULT_TIME_S from now."""
    memory, source = machine_memory_bytes()
    return Budget(
        int(MEMORY_SHARE * memory),
        DEFAULT_TIME_S,
        f"default: half of {source}, {memory / GB:.3g} GB; --max-memory",
        f"default {DEFAULT_TIME_S:g} s; --max-time",
        time.monotonic(),
    )


def make_budget(memory_gb: float | None = None, time_s: float | None = None) -> Budget:
    """The budget of ``memory_gb`` GB and ``time_s`` s from now (the default for each one
    not given); InputError naming the option for a value that is not a finite number > 0."""
    default = default_budget()
    memory, memory_source = default.memory_bytes, default.memory_source
    if memory_gb is not None:
        memory, memory_source = int(check_positive("--max-memory", memory_gb) * GB), "--max-memory"
        if memory < INTERPRETER_BYTES:
            raise InputError(
                f"--max-memory: {memory_gb:g} GB ({format_bytes(memory)}) is less than the "
                "interpreter itself holds before any work (up to "
                f"{format_bytes(INTERPRETER_BYTES)}: Python, NumPy, JAX and the command; this "
                "process now "
                f"{format_bytes(resident_bytes())}); give at least {INTERPRETER_BYTES / GB:g}"
            )
    seconds, time_source = default.time_s, default.time_source
    if time_s is not None:
        seconds, time_source = check_positive("--max-time", time_s), "--max-time"
    return Budget(memory, seconds, memory_source, time_source, time.monotonic())


# the budget of the work at hand: per thread (and asyncio task), set by use_budget
_CURRENT: contextvars.ContextVar[Budget | None] = contextvars.ContextVar("budget", default=None)


def current_budget() -> Budget:
    """The budget the work runs under: the innermost :func:`use_budget` of this thread, else
    the machine's default, its time counted from this call (a library caller's every call
    gets the default anew)."""
    budget = _CURRENT.get()
    return default_budget() if budget is None else budget


@contextlib.contextmanager
def use_budget(budget: Budget) -> Iterator[Budget]:
    """Work inside the block (in this thread) is planned and checked against ``budget``."""
    token = _CURRENT.set(budget)
    try:
        yield budget
    finally:
        _CURRENT.reset(token)


def format_bytes(n: float) -> str:
    """``2.4 GB``, ``310 MB``, ``12 kB`` (decimal units)."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            value = n / size
            return f"{value:,.0f} {unit}" if value >= 1000 else f"{value:.3g} {unit}"
    return f"{n:.0f} B"


def format_seconds(s: float) -> str:
    """``45 s``, ``12 min``, ``3.5 h``, ``41 days``."""
    if not math.isfinite(s):
        return "forever"
    for unit, size in (("years", 3.15e7), ("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if s >= 2 * size or (unit == "min" and s >= size):
            value = s / size
            return f"{value:,.0f} {unit}" if value >= 1000 else f"{value:.3g} {unit}"
    return f"{s:.2g} s" if s < 10 else f"{s:.0f} s"


def require(*needs: Need, budget: Budget | None = None) -> None:
    """Refuse (BudgetError) work whose stages ``needs`` exceed ``budget`` (default: the
    process's): the largest stage's memory against the memory budget, the sum of the times
    against the time left. The message names the stage, what it needs and what to change.
    Work that fits but is planned to take PLAN_NOTE_S or more is announced (a step line on
    stderr) before it starts."""
    budget = current_budget() if budget is None else budget
    if not needs:
        return
    biggest = max(needs, key=lambda need: need.memory_bytes)
    if biggest.memory_bytes > budget.memory_bytes:
        raise BudgetError(
            f"memory: {biggest.what} needs about {format_bytes(biggest.memory_bytes)}, more "
            f"than the budget of {format_bytes(budget.memory_bytes)} ({budget.memory_source})"
            + (f"; {biggest.advice}" if biggest.advice else "")
        )
    total = sum(need.time_s for need in needs)
    left = budget.remaining_s()
    if total > left:
        longest = max(needs, key=lambda need: need.time_s)
        spent = budget.time_s - left
        already = f" ({format_seconds(spent)} of it spent)" if spent >= 1 else ""
        raise BudgetError(
            f"time: {longest.what} needs about {format_seconds(longest.time_s)} on this "
            f"machine"
            + (f" (all the work: {format_seconds(total)})" if len(needs) > 1 else "")
            + f", more than the budget of {format_seconds(budget.time_s)}{already} "
            f"({budget.time_source})" + (f"; {longest.advice}" if longest.advice else "")
        )
    if total >= PLAN_NOTE_S:  # long work says what it plans (a step line: not when quiet)
        from jaxflex._progress import step  # only here: tqdm is no light import

        longest = max(needs, key=lambda need: need.time_s)
        step(
            f"planned: {longest.what}: about {format_seconds(total)} on this machine, within "
            f"the budget of {format_seconds(budget.time_s)} ({budget.time_source})"
        )


def check_time(what: str, advice: str = "") -> None:
    """BudgetError if the process's time budget is spent (called between pieces of long
    work; ``what`` names the work)."""
    budget = current_budget()
    if budget.remaining_s() <= 0:
        raise BudgetError(
            f"time: {what} ran out of {budget.time_limit_text()}"
            + (f"; {advice}" if advice else "")
        )
