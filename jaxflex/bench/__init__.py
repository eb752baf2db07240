"""Speed and accuracy benchmarks of jaxflex (``jaxflex bench``).

* :mod:`jaxflex.bench.core`: the core speed figures (K=1099, M=40, N=1000);
* :mod:`jaxflex.bench.metrics`: the preprint's accuracy metrics of a deviation curve;
* :mod:`jaxflex.bench.timing`: wall-time measurement and a description of the machine.
"""

from jaxflex.bench.core import QUICK, BenchCase, format_table, run_bench, sine_move, synthetic_model
from jaxflex.bench.metrics import compare, curve_errors, on_grid, settle_from_samples
from jaxflex.bench.timing import best_time_s, machine

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
