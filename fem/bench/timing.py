"""Wall-time measurement shared by every bench section, and a description of the machine."""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable

import jax
import numpy as np


def best_time_s(fn: Callable[[], object], repeats: int = 5, min_total_s: float = 0.2) -> float:
    """Best mean wall time in s of ``fn`` over ``repeats`` loops (each about
    ``min_total_s / repeats`` long), after one warm-up call (compilation) and one timed call
    that sizes the loops. Results are waited for with ``jax.block_until_ready``."""
    jax.block_until_ready(fn())
    start = time.perf_counter()
    jax.block_until_ready(fn())
    once = max(time.perf_counter() - start, 1e-6)
    loops = max(1, int(min_total_s / repeats / once))
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(loops):
            jax.block_until_ready(fn())
        best = min(best, (time.perf_counter() - start) / loops)
    return float(best)


def machine() -> dict:
    """Python, JAX and CPU of this run (the figures depend on them)."""
    return {
        "python": platform.python_version(),
        "jax": jax.__version__,
        "numpy": np.__version__,
        "cpu_count": os.cpu_count(),
        "processor": platform.processor() or platform.machine(),
        "platform": platform.platform(),
    }
