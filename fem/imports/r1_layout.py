"""Where an R1 file's columns sit in time: the three layouts users bring.

An R1 CSV has one row per point and x, y, z per time step (jaxflex._convolution). What the
first step is differs between tools:

* **t = 0**: the first triple is the state at rest before the hat (all zeros), as
  jaxflex writes it (``x_0, y_0, z_0, ...``);
* **t = dt**: the first triple is the response at t_1 = dt, as the preprint's Table 2
  (``x(1) y(1) z(1) ... x(1000) y(1000) z(1000)`` over 10 s at 10 ms) and ANSYS's transient
  output (results from the first substep on) have it;
* **a header with time stamps** (``x_1@0.01s`` as jaxflex writes with ``dt_s``, or
  ``x(t=0.01)``): the times say which, and give the step to check ``dt`` against.

A header with step numbers (``x(1)``, ``x_0``, ``X1``) says which step comes first; without
a header, a first triple of zeros is t = 0 and anything else t = dt (a response from rest
is zero at t = 0 and not at t = dt, where the hat has already acted for one step).
"""

from __future__ import annotations

import csv
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jaxflex.errors import InputError

_NUMBER = r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][-+]?\d+)?)"
_TIME = (
    re.compile(rf"@\s*{_NUMBER}\s*s\s*$"),  # x_1@0.01s (jaxflex)
    re.compile(rf"\bt\s*=\s*{_NUMBER}"),  # x(t=0.01), UX t=0.01 s
)
_STEP = re.compile(r"^\s*([xyz])\s*[_(\[]?\s*(\d+)\s*[)\]]?\s*$", re.IGNORECASE)
HEADER_DT_RTOL = 1e-6  # a header's times are printed with >= 9 significant digits


@dataclass(frozen=True)
class R1Layout:
    """How an R1 file is laid out in time: ``first_step`` 0 (t = 0) or 1 (t = dt),
    ``source`` what said so ("header times", "header step numbers", "first column"),
    ``times_s`` the header's times (None if it states none)."""

    first_step: int
    source: str
    times_s: np.ndarray | None = None

    def describe(self) -> str:
        start = (
            "t = 0 (the state at rest)"
            if self.first_step == 0
            else "t = dt (the preprint's Table 2 / ANSYS transient layout)"
        )
        return f"first column at {start}, from the {self.source}"


def _component(cell: str, index: int) -> None:
    """Header cells must give x, y, z in turn."""
    expected = "xyz"[index % 3]
    match = re.match(r"\s*([a-zA-Z]+)", cell)
    name = match.group(1).lower() if match else ""
    if name in ("x", "y", "z", "ux", "uy", "uz") and name[-1] != expected:
        raise InputError(
            f"header column {index + 1} {cell!r}: expected the {expected} component (columns "
            "run x, y, z per time step)"
        )


def header_layout(cells: list[str], source: str) -> R1Layout | None:
    """The layout a header row states, or None if it states no times or step numbers."""
    if not cells or len(cells) % 3:
        return None
    for pattern in _TIME:
        matches = [pattern.search(cell) for cell in cells]
        if all(matches):
            values = [float(m.group(1).lower().replace("d", "e")) for m in matches]
            times = np.array(values).reshape(-1, 3)
            if np.ptp(times, axis=1).max() > 0:
                raise InputError(f"{source}: the header gives x, y, z of one step different times")
            for i, cell in enumerate(cells):
                _component(cell, i)
            return _from_times(times[:, 0], source)
    matches = [_STEP.match(cell) for cell in cells]
    if all(matches):
        steps = np.array([int(m.group(2)) for m in matches]).reshape(-1, 3)
        letters = "".join(m.group(1).lower() for m in matches)
        if np.ptp(steps, axis=1).max() > 0 or letters != "xyz" * (len(cells) // 3):
            raise InputError(f"{source}: the header's columns are not x, y, z per step")
        if not np.array_equal(steps[:, 0], steps[0, 0] + np.arange(len(steps))):
            raise InputError(f"{source}: the header's step numbers are not consecutive")
        if steps[0, 0] not in (0, 1):
            raise InputError(
                f"{source}: the header's first step is {steps[0, 0]}; R1 starts at step 0 "
                "(t = 0) or 1 (t = dt)"
            )
        return R1Layout(int(steps[0, 0]), "header step numbers")
    return None


def _from_times(times: np.ndarray, source: str) -> R1Layout:
    if times.size < 2:
        raise InputError(f"{source}: the header states one time step only")
    step = float(np.median(np.diff(times)))
    if step <= 0 or np.abs(np.diff(times) - step).max() > HEADER_DT_RTOL * step:
        raise InputError(f"{source}: the header's times are not evenly spaced")
    if abs(times[0]) <= HEADER_DT_RTOL * step:
        return R1Layout(0, "header times", times)
    if abs(times[0] - step) <= HEADER_DT_RTOL * step:
        return R1Layout(1, "header times", times)
    raise InputError(
        f"{source}: the header's first time is {times[0]:.9g} s; R1 starts at t = 0 or at "
        f"t = dt ({step:.9g} s)"
    )


def read_header(path: str | os.PathLike) -> list[str]:
    """The first row of a CSV file (cells)."""
    with Path(path).open(newline="", encoding="utf-8") as handle:
        return next(csv.reader(handle), [])


def detect_layout(path: str | os.PathLike, steps: np.ndarray, dt_s: float) -> R1Layout:
    """The layout of the R1 file ``path`` whose steps (as read: (n, K, 3)) are ``steps``;
    the header's time step, where it states one, must be ``dt_s``."""
    source = repr(str(path))
    layout = header_layout(read_header(path), source)
    peak = float(np.max(np.abs(steps))) if steps.size else 0.0
    first_is_rest = float(np.max(np.abs(steps[0]))) <= 1e-6 * peak
    if layout is None:
        return R1Layout(0 if first_is_rest else 1, "first column (no header times or steps)")
    if layout.times_s is not None:
        step = float(np.median(np.diff(layout.times_s)))
        if abs(step - dt_s) > HEADER_DT_RTOL * step:
            raise InputError(
                f"dt: {dt_s:g} s given, but the header of {source} puts its steps "
                f"{step:.9g} s apart"
            )
    if layout.first_step == 0 and not first_is_rest:
        raise InputError(
            f"{source}: the header puts the first column at t = 0, but it is not zero: the "
            "response to the hat at t_1 starts at rest; check that the file has no time or "
            "node column"
        )
    return layout


def steps_from_zero(steps: np.ndarray, layout: R1Layout) -> np.ndarray:
    """(N+1, K, 3) R1 from t = 0: a file starting at t = dt gets the state at rest first."""
    if layout.first_step == 0:
        return steps
    return np.concatenate([np.zeros((1, *steps.shape[1:])), steps])
