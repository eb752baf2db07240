"""Times and values on a grid, computed as the decimals the user wrote.

A move of 82 steps of dt_s = 0.01 s lasts 0.82 s, but 82 * 0.01 in binary floating point is
0.8200000000000001, and that is what a report would print. Here the step is taken as the
shortest decimal that reads back as the same float (``repr``: 0.01), the product is formed
exactly in decimal, and the result is rounded once to the nearest float: 0.82. For any step
the result differs from ``n * dt_s`` by at most a few ulp (both are within half an ulp of
n times the decimal step, or of n times the binary step, which differ by under n/2 ulp of
dt_s), so no computation changes; only what is printed and compared becomes exact.
"""

from __future__ import annotations

from decimal import Decimal

import numpy as np


def _decimal(value: float) -> Decimal:
    return Decimal(repr(float(value)))


def grid_time(n_steps: int, dt_s: float) -> float:
    """t_n = n_steps * dt_s in s, as the decimal product (module docstring)."""
    return float(_decimal(dt_s) * int(n_steps))


def grid_times(n_steps: int, dt_s: float) -> np.ndarray:
    """The sample times t_k = k dt_s, k = 0..n_steps, (n_steps + 1,) s (module docstring)."""
    step = _decimal(dt_s)
    return np.array([float(step * k) for k in range(int(n_steps) + 1)])


def grid_values(lo: float, hi: float, count: int) -> list[float]:
    """``count`` evenly spaced values from ``lo`` to ``hi`` (both included; ``lo`` alone for
    count 1), computed in decimal like :func:`grid_time`: 0.01, 0.02, 0.03 rather than
    numpy.linspace's 0.01, 0.02, 0.030000000000000002."""
    if count == 1:
        return [float(lo)]
    a, b = _decimal(lo), _decimal(hi)
    return [float(a + (b - a) * k / (count - 1)) for k in range(count)]
