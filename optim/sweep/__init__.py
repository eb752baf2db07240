"""Gripper-layout sweeps: every layout of a specification with every move, each case's modal
analysis (fem) and optimised cycle time (optim), stored as it finishes, restartable, run
serially or on dask.distributed (an embedded LocalCluster or a scheduler address).

Python::

    from optim.sweep import load_spec, run_sweep

    run = run_sweep(load_spec("sweep.toml"), "sweep_out")  # dask LocalCluster by default
    print(run.summary())  # results in sweep_out/results.csv, sweep.png, deviation.png

Command line: ``jaxflex sweep sweep.toml -o sweep_out`` (``--serial``, ``--workers N``,
``--scheduler tcp://host:8786``). The spec format is described in optim.sweep.spec and
docs/sweep.md; SI units throughout.
"""

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): the package loads at once
    from optim.sweep.evaluate import deviation_traces
    from optim.sweep.run import Executor, SweepRun, run_sweep
    from optim.sweep.spec import SweepSpec, load_spec
    from optim.sweep.table import read_table

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "Executor",
    "SweepRun",
    "SweepSpec",
    "deviation_traces",
    "load_spec",
    "read_table",
    "run_sweep",
]
