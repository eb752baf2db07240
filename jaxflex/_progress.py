"""Progress of long work, the same for every command and every package.

Where it goes (always stderr, so that stdout keeps the results):

* on a terminal: a tqdm bar with count, total, rate and time left, cleared when done;
* anywhere else (a log file, a pipe, CI): plain lines, never a carriage return: one every
  LOG_INTERVAL_S with count, total, elapsed and estimated time left, and one when the work
  ends ("baselines: 18/18 in 0.9 s");
* quiet: nothing.

``progress_bar(total, desc)`` is the bar, ``step(message)`` one line saying what starts now
(work without a count: a factorisation, an eigen solve), ``note(message)`` a line that shows
even when quiet. Both take ``enabled``: True shows,
False hides, None (the default everywhere) follows the process-wide setting, which the
``jaxflex`` command line sets from ``--quiet`` (:func:`set_quiet`).
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from tqdm import tqdm

LOG_INTERVAL_S = 10.0

_state = {"quiet": False}


def set_quiet(quiet: bool) -> None:
    """Hide (True) or show (False) every progress display and step line of this process."""
    _state["quiet"] = bool(quiet)


def _shown(enabled: bool | None) -> bool:
    return not _state["quiet"] if enabled is None else bool(enabled)


def _on_terminal(stream: TextIO) -> bool:
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


def _duration(seconds: float) -> str:
    """'0.9 s', '42 s', '3 min 05 s', '1 h 02 min'."""
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 60:
        return f"{seconds:.0f} s"
    minutes, sec = divmod(round(seconds), 60)
    if minutes < 60:
        return f"{minutes} min {sec:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min"


def step(message: str, *, enabled: bool | None = None, stream: TextIO | None = None) -> None:
    """One line on stderr saying what starts now (unless quiet), above a running bar."""
    if _shown(enabled):
        note(message, stream=stream)


def note(message: str, *, stream: TextIO | None = None) -> None:
    """One line on stderr that shows even when quiet (a lost worker, a dashboard link),
    printed above a running bar instead of through it."""
    tqdm.write(message, file=stream or sys.stderr)


class Progress:
    """A count of done work out of ``total`` (None: unknown). Use as a context manager or
    call :meth:`close`; tqdm's ``update``, ``set_postfix_str`` and ``total`` work as there."""

    def __init__(
        self,
        total: int | None,
        desc: str,
        *,
        unit: str = "it",
        enabled: bool | None = None,
        stream: TextIO | None = None,
        interval_s: float = LOG_INTERVAL_S,
    ) -> None:
        self.desc, self.unit, self.n = desc, unit, 0
        self._total = total
        self._postfix = ""
        self._stream = stream or sys.stderr
        self._start = self._last = time.monotonic()
        self._interval_s = interval_s
        self._closed = False
        self._shown = _shown(enabled)
        self._bar = None
        if self._shown and _on_terminal(self._stream):
            self._bar = tqdm(
                total=total,
                desc=desc,
                unit=unit,
                leave=False,
                file=self._stream,
                dynamic_ncols=True,
                disable=False,
            )

    @property
    def total(self) -> int | None:
        return self._total

    @total.setter
    def total(self, value: int | None) -> None:
        self._total = value
        if self._bar is not None:
            self._bar.total = value
            self._bar.refresh()

    def update(self, n: int = 1) -> None:
        self.n += n
        if self._bar is not None:
            self._bar.update(n)
        elif self._shown and time.monotonic() - self._last >= self._interval_s:
            self._line()

    def set_postfix_str(self, text: str) -> None:
        self._postfix = text
        if self._bar is not None:
            self._bar.set_postfix_str(text)

    def _count(self) -> str:
        if self._total is None:
            return f"{self.n} {self.unit}"
        return f"{self.n}/{self._total} {self.unit}"

    def _line(self, final: bool = False) -> None:
        now = time.monotonic()
        elapsed = now - self._start
        text = f"{self.desc}: {self._count()}"
        if final:
            text += f" in {_duration(elapsed)}"
        else:
            text += f", {_duration(elapsed)} elapsed"
            if self._total and 0 < self.n < self._total:
                left = elapsed / self.n * (self._total - self.n)
                text += f", about {_duration(left)} left"
        if self._postfix:
            text += f" ({self._postfix})"
        print(text, file=self._stream, flush=True)
        self._last = now

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self._bar is not None:
            self._bar.close()
        elif self._shown:
            self._line(final=True)

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def progress_bar(
    total: int | None, desc: str, enabled: bool | None = None, unit: str = "it"
) -> Progress:
    """A :class:`Progress` on stderr (module docstring); ``enabled`` True/False forces it
    on/off, None follows the process-wide setting (:func:`set_quiet`)."""
    return Progress(total, desc, unit=unit, enabled=enabled)
