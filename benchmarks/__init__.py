"""Speed and accuracy benchmarks of jaxflex (``jaxflex bench``).

* :mod:`benchmarks.core`: the core speed figures (K=1099, M=40, N=1000);
* :mod:`benchmarks.metrics`: the preprint's accuracy metrics of a deviation curve;
* :mod:`benchmarks.timing`: wall-time measurement and a description of the machine.
"""

from benchmarks.core import QUICK, BenchCase, format_table, run_bench, sine_move, synthetic_model
from benchmarks.metrics import compare, curve_errors, on_grid, settle_from_samples
from benchmarks.timing import best_time_s, machine

__all__ = [
    "QUICK",
    "BenchCase",
    "best_time_s",
    "compare",
    "curve_errors",
    "format_table",
    "machine",
    "on_grid",
    "run_bench",
    "settle_from_samples",
    "sine_move",
    "synthetic_model",
]
