"""Speed and accuracy benchmarks of jaxflex (``jaxflex bench``).

* :mod:`fmu.bench.core`: the core speed figures (K=1099, M=40, N=1000);
* :mod:`fmu.bench.metrics`: the preprint's accuracy metrics of a deviation curve;
* :mod:`fmu.bench.timing`: wall-time measurement and a description of the machine;
* :func:`run_suite` (:mod:`fmu.bench.suite`): the whole ``jaxflex bench`` at a size
  ("tiny", "quick", "medium", "full"), JSON and charts written to a directory, and
  :func:`summary_lines`, its findings as text (what the notebooks use).
"""

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): the package loads at once
    from fmu.bench.core import QUICK, BenchCase, format_table, run_bench, sine_move, synthetic_model
    from fmu.bench.metrics import compare, curve_errors, on_grid, settle_from_samples
    from fmu.bench.suite import SIZES, run_suite, summary_lines
    from fmu.bench.timing import best_time_s, machine

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "QUICK",
    "SIZES",
    "BenchCase",
    "best_time_s",
    "compare",
    "curve_errors",
    "format_table",
    "machine",
    "on_grid",
    "run_bench",
    "run_suite",
    "settle_from_samples",
    "sine_move",
    "summary_lines",
    "synthetic_model",
]
