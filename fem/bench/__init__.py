"""Benchmarks of the core engine and of fem (the lowest layer that carries benchmarks: the
core carries none). Each module runs on its own (``python -m fem.bench.X``, JSON out);
``jaxflex bench`` (:mod:`fmu.bench.suite`) gathers the core and accuracy sections.

* :mod:`fem.bench.core`: the core speed figures (K=1099, M=40, N=1000);
* :mod:`fem.bench.metrics`: the preprint's accuracy metrics of a deviation curve;
* :mod:`fem.bench.timing`: wall-time measurement and a description of the machine;
* the methods against the full-order FE transient (``accuracy``, ``methods``, ``fe``,
  ``stability``, ``charts``), every node (``nodes``), turning moves (``turning``);
* fem's own figures: modal analyses (``solves``), the shell's convergence (``shell``), the
  budget's calibration (``budget``), the imports (``imports``, ``nastran_corpus``,
  ``solver_files``).
"""

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): the package loads at once
    from fem.bench.core import QUICK, BenchCase, format_table, run_bench, sine_move, synthetic_model
    from fem.bench.metrics import compare, curve_errors, on_grid, settle_from_samples
    from fem.bench.timing import best_time_s, machine

__getattr__, __dir__ = lazy_names(__name__)

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
