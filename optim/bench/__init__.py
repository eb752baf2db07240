"""Benchmarks of optim, each run on its own (``python -m optim.bench.X``, JSON out):

* :mod:`optim.bench.targets`: the optimiser's target figures (nominal and robust cycle times
  against the baselines);
* :mod:`optim.bench.cell`: the real cell (obstacles, via points, cup forces, stress);
* :mod:`optim.bench.turning_cell`: the cell's constraints on turning moves;
* :mod:`optim.bench.animate`: the README's press scene animated;
* :mod:`optim.bench.commands`: whole ``jaxflex`` commands timed from outside (the
  ``commands`` section of ``jaxflex bench``).

They take their scenes from fem, as optim may (docs/design.md, Layers).
"""
