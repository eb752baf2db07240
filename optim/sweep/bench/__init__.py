"""Benchmarks of the sweeps, each run on its own (JSON on stdout and ``-o FILE``):

* :mod:`optim.sweep.bench.sweep`: throughput serial vs dask, per-case cost, compiled-code
  reuse, batched vs looped evaluation;
* :mod:`optim.sweep.bench.sweep_scale`: thousands of small cases on a LocalCluster
  (throughput, memory, the store's cost per case).
"""
