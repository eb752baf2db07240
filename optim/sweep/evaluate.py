"""Deviation traces of many cases at once: cases of equal model size evaluated together.

For B cases with models of equal size (K points, M modes) and moves of any length, the
deviation d(t) = max_p |u_p(t)| (m) is evaluated every dt / ``substeps`` (exact: the
piecewise-linear profile is the same on the finer grid, as in jaxflex.response.upsample) up to a
common horizon. Two methods give the same numbers (to round-off):

* ``"batched"``: jaxflex.batch_deviation of the stacked models: one jitted function for the
  group (the recursions of all cases in one ``lax.scan``, the points case by case). A plain
  ``jax.vmap`` of the whole per-case function (jaxflex.simulate) was measured 3-7x slower than
  a loop on this CPU: it materialises the (B, T, 3K) displacements at once (0.5 GB for 32
  cases of 600 points), which is memory bound.
* ``"loop"``: jaxflex.simulate case by case (compiled once per padded shape).

Which pays off is measured by ``python -m optim.sweep.bench`` (docs/sweep.md): the batched
form is up to ~1.7x faster for small and mid-size models and ties for large ones; either way
the evaluation costs milliseconds per case against ~0.6-1 s of optimisation and the FE
analysis, so the sweep uses it for its deviation plot; it is not the bottleneck.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

import jaxflex
from jaxflex.errors import InputError
from jaxflex.model import ModalModel, stack_models
from jaxflex.response import Move, padded_steps, rest_padded, upsample

METHODS = ("batched", "loop")


def padded_moves(accs: Sequence[np.ndarray], horizon_steps: int, substeps: int) -> np.ndarray:
    """(B, horizon_steps * substeps + 1, 3): each move followed by rest up to the horizon,
    on the grid dt / substeps (the same piecewise-linear profile, jaxflex.response.upsample)."""
    fine = []
    for b, acc in enumerate(accs):
        if np.shape(acc)[0] > horizon_steps + 1:
            raise InputError(f"horizon_s: shorter than move {b} ({np.shape(acc)[0] - 1} steps)")
        fine.append(upsample(rest_padded(acc, horizon_steps), substeps, np))
    return np.stack(fine)


def deviation_traces(
    models: Sequence[ModalModel],
    moves: Sequence[Move],
    horizon_s: float,
    *,
    substeps: int = 8,
    method: str = "batched",
) -> tuple[np.ndarray, np.ndarray]:
    """Times t (T,) s and deviations d (B, T) m of each model under its move ``moves[b]``
    (a jaxflex.Move of n_b steps; all at one step dt_s), from 0 to ``horizon_s``. All models
    must have the same number of points and modes (one group of the sweep). The horizon is
    rounded up to whole blocks of jaxflex._engine.PAD_STEPS steps (t reaches at least
    ``horizon_s``)."""
    if method not in METHODS:
        raise InputError(f"method: must be one of {list(METHODS)}, got {method!r}")
    if len(models) != len(moves) or not models:
        raise InputError(f"models/moves: need equally many (>= 1), got {len(models)}/{len(moves)}")
    for b, move in enumerate(moves):
        if not isinstance(move, Move):
            raise InputError(f"moves[{b}]: a jaxflex.Move (jaxflex.as_move(acc, dt_s)), got "
                             f"{type(move).__name__}")  # fmt: skip
    steps = sorted({move.dt_s for move in moves})
    if len(steps) != 1:
        raise InputError(f"moves: one group needs one step dt_s, got {steps} s")
    sizes = {(m.n_points, m.n_modes) for m in models}
    if len(sizes) != 1:
        raise InputError(f"models: one group needs one size (points, modes), got {sorted(sizes)}")
    dt_s, accs = steps[0], [move.acc for move in moves]
    # whole blocks of steps, so that groups of similar moves share the compiled code
    horizon_steps = padded_steps(int(np.ceil(horizon_s / dt_s - 1e-9)))
    fine = padded_moves(accs, horizon_steps, substeps)
    h = dt_s / substeps
    t = h * np.arange(fine.shape[1])
    if method == "loop":
        d = [
            np.asarray(jaxflex.simulate(m, a, h).deviation)
            for m, a in zip(models, fine, strict=True)
        ]
        return t, np.stack(d)
    return t, np.asarray(jaxflex.batch_deviation(stack_models(models), fine, h))


def group_by_size(models: dict[str, ModalModel]) -> dict[tuple[int, int], list[str]]:
    """Keys of ``models`` grouped by (points, modes): the groups evaluated together."""
    groups: dict[tuple[int, int], list[str]] = {}
    for key, model in models.items():
        groups.setdefault((model.n_points, model.n_modes), []).append(key)
    return groups
