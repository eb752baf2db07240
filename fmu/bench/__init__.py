"""``jaxflex bench`` and fmu's own benchmarks. Each layer benchmarks itself: the core's and
fem's figures in :mod:`fem.bench`, optim's in :mod:`optim.bench`, the sweeps' in
:mod:`optim.sweep.bench`; here, the top layer:

* :func:`run_suite` (:mod:`fmu.bench.suite`): the whole ``jaxflex bench`` at a size
  ("tiny", "quick", "medium", "full"), gathering the sections of the layers below, JSON and
  charts written to a directory, and :func:`summary_lines`, its findings as text (what the
  notebooks use);
* :mod:`fmu.bench.steps`: the FMU's step, export and hosts (``python -m fmu.bench.steps``).
"""

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): the package loads at once
    from fmu.bench.suite import SIZES, run_suite, summary_lines

__getattr__, __dir__ = lazy_names(__name__)

__all__ = ["SIZES", "run_suite", "summary_lines"]
