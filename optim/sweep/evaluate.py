"""Deviation traces of many cases at once: cases of equal model size evaluated together.

For B cases with models of equal size (K points, M modes) and moves of any length, the
deviation d(t) = max_p |u_p(t)| (m) is evaluated every dt / ``substeps`` (exact: the
piecewise-linear profile is the same on the finer grid, as in jaxflex.upsample) up to a
common horizon. Two methods give the same numbers (to round-off):

* ``"batched"``: one jitted function for the group. The modal recursions of all B cases run
  in one ``lax.scan`` (``jax.vmap`` over the cases: B x M independent oscillators per step),
  and the deviation is a ``lax.map`` over the cases (one (T, M) x (M, 3K) product at a time).
  A plain ``jax.vmap`` of the whole per-case function (jaxflex.simulate) was measured 3-7x
  slower than a loop on this CPU: it materialises the (B, T, 3K) displacements at once
  (0.5 GB for 32 cases of 600 points), which is memory bound.
* ``"loop"``: jaxflex.simulate case by case (compiled once per padded shape).

Which pays off is measured by ``python -m optim.sweep.bench`` (docs/sweep.md): the batched
form is up to ~1.7x faster for small and mid-size models and ties for large ones; either way
the evaluation costs milliseconds per case against ~0.6-1 s of optimisation and the FE
analysis, so the sweep uses it for its deviation plot; it is not the bottleneck.
"""

from __future__ import annotations

from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np

import jaxflex
from jaxflex.discretize import foh_coefficients
from jaxflex.errors import InputError
from jaxflex.model import ModalModel
from jaxflex.simulate import shapes_by_component

METHODS = ("batched", "loop")
HORIZON_BLOCK = 64


def _states(freq_hz, zeta, gamma, acc, h):
    """(T, M) modal displacements of one case (FOH recursion, as jaxflex.modal_states)."""
    phi, g0, g1 = foh_coefficients(2.0 * jnp.pi * freq_hz, zeta, h)
    force = -acc @ gamma.T
    drive = g0[None] * force[:-1, :, None] + g1[None] * force[1:, :, None]
    p11, p12, p21, p22 = phi[:, 0, 0], phi[:, 0, 1], phi[:, 1, 0], phi[:, 1, 1]

    def step(x, b):
        q, v = x[:, 0], x[:, 1]
        x_next = jnp.stack([p11 * q + p12 * v + b[:, 0], p21 * q + p22 * v + b[:, 1]], axis=-1)
        return x_next, x_next[:, 0]

    _, qs = jax.lax.scan(step, jnp.zeros((freq_hz.shape[0], 2), acc.dtype), drive)
    return jnp.concatenate([jnp.zeros((1, freq_hz.shape[0]), acc.dtype), qs], axis=0)


@jax.jit
def _batched(freq_hz, zeta, gamma, shapes_c, acc, h):
    q = jax.vmap(_states, in_axes=(0, 0, 0, 0, None))(freq_hz, zeta, gamma, acc, h)
    n_points = shapes_c.shape[-1] // 3

    def one(args):
        q_b, s_b = args
        u = (q_b @ s_b).reshape(q_b.shape[0], 3, n_points)
        return jnp.sqrt(jnp.max(jnp.sum(u * u, axis=1), axis=1))

    return jax.lax.map(one, (q, shapes_c))


def padded_moves(accs: Sequence[np.ndarray], horizon_steps: int, substeps: int) -> np.ndarray:
    """(B, horizon_steps * substeps + 1, 3): each move followed by rest up to the horizon,
    on the grid dt / substeps (linear interpolation: the same piecewise-linear profile)."""
    coarse = np.zeros((len(accs), horizon_steps + 1, 3))
    for b, acc in enumerate(accs):
        acc = np.asarray(acc, dtype=float)
        if acc.shape[0] > horizon_steps + 1:
            raise InputError(f"horizon_s: shorter than move {b} ({acc.shape[0] - 1} steps)")
        coarse[b, : acc.shape[0]] = acc
    frac = (np.arange(substeps) / substeps)[None, None, :, None]
    fine = (1.0 - frac) * coarse[:, :-1, None] + frac * coarse[:, 1:, None]  # (B, n, s, 3)
    fine = fine.reshape(len(accs), horizon_steps * substeps, 3)
    return np.concatenate([fine, coarse[:, -1:]], axis=1)


def deviation_traces(
    models: Sequence[ModalModel],
    accs: Sequence[np.ndarray],
    dt_s: float,
    horizon_s: float,
    *,
    substeps: int = 8,
    method: str = "batched",
) -> tuple[np.ndarray, np.ndarray]:
    """Times t (T,) s and deviations d (B, T) m of each model under its move ``accs[b]``
    ((n_b + 1, 3) m/s^2 at step ``dt_s``), from 0 to ``horizon_s``. All models must have
    the same number of points and modes (one group of the sweep). The horizon is rounded up
    to whole blocks of :data:`HORIZON_BLOCK` steps (t reaches at least ``horizon_s``)."""
    if method not in METHODS:
        raise InputError(f"method: must be one of {list(METHODS)}, got {method!r}")
    if len(models) != len(accs) or not models:
        raise InputError(f"models/accs: need equally many (>= 1), got {len(models)}/{len(accs)}")
    sizes = {(m.n_points, m.n_modes) for m in models}
    if len(sizes) != 1:
        raise InputError(f"models: one group needs one size (points, modes), got {sorted(sizes)}")
    # whole blocks of HORIZON_BLOCK steps, so that groups of similar moves share the compiled code
    steps = int(np.ceil(horizon_s / dt_s - 1e-9))
    horizon_steps = HORIZON_BLOCK * -(-steps // HORIZON_BLOCK)
    fine = padded_moves(accs, horizon_steps, substeps)
    h = dt_s / substeps
    t = h * np.arange(fine.shape[1])
    if method == "loop":
        d = [
            np.asarray(jaxflex.simulate(m, a, h).deviation)
            for m, a in zip(models, fine, strict=True)
        ]
        return t, np.stack(d)
    stack = {
        name: np.stack([np.asarray(getattr(m, name)) for m in models])
        for name in ("freq_hz", "zeta", "gamma")
    }
    shapes_c = np.stack([np.asarray(shapes_by_component(np.asarray(m.shapes))) for m in models])
    d = _batched(stack["freq_hz"], stack["zeta"], stack["gamma"], shapes_c, fine, h)
    return t, np.asarray(d)


def group_by_size(models: dict[str, ModalModel]) -> dict[tuple[int, int], list[str]]:
    """Keys of ``models`` grouped by (points, modes): the groups evaluated together."""
    groups: dict[tuple[int, int], list[str]] = {}
    for key, model in models.items():
        groups.setdefault((model.n_points, model.n_modes), []).append(key)
    return groups
