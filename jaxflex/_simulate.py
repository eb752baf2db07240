"""Response of a modal model to a piecewise-linear base acceleration: an exact recursion.

Each mode is advanced with the exact first-order-hold step (jaxflex._discretize) inside one
jitted ``jax.lax.scan``; the deviation d_k = max_p |u_p(t_k)| follows from the pruned blocked
evaluation of jaxflex._deviation, which never forms the (T, K, 3) displacements.
After the last sample the base is at rest and the part vibrates freely; that continuation is
evaluated in closed form (no scan over zeros).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxflex._blocks import PointBlocks, point_blocks
from jaxflex._deviation import blocks_of, deviation, response_shapes, with_acceleration
from jaxflex._engine import HOLDS, free_states, modal_states
from jaxflex._profile import Move, as_move
from jaxflex._scalars import check_positive
from jaxflex._validation import check_acc, is_traced
from jaxflex.errors import InputError
from jaxflex.model import ModalModel, require_model

_DTYPES = {"float64": jnp.float64, "float32": jnp.float32}


@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True)
class Response:
    """Result of :func:`simulate`. T = n + 1 + n_free samples at t_k = k dt_s.

    t: (T,) s.   q, qd: (T, M) modal coordinates and velocities (kg^0.5 m, kg^0.5 m/s).
    deviation: (T,) d_k = max_p |u_p(t_k)| in m (u_p = sum_i phi_i(p) q_i + D_p a with the
        model's static residual D, jaxflex.model).
    displacement: (T, K, 3) in m, or None unless requested.
    n_steps: number of motion steps n (the move ends at t[n_steps]).
    """

    t: Any
    q: Any
    qd: Any
    deviation: Any
    displacement: Any
    n_steps: int

    def tree_flatten(self):
        return (self.t, self.q, self.qd, self.deviation, self.displacement), self.n_steps

    @classmethod
    def tree_unflatten(cls, n_steps, children):
        return cls(*children, n_steps)

    @property
    def end_state(self):
        """(M, 2) modal state (q, qd) at the end of the motion."""
        return jnp.stack([self.q[self.n_steps], self.qd[self.n_steps]], axis=-1)


def end_state(model: ModalModel, acc, dt_s, x0=None):
    """(M, 2) modal state at t_n; linear in ``acc`` (and in ``x0``). Traceable."""
    return modal_states(model, acc, dt_s, x0=x0)[-1]


@partial(jax.jit, static_argnames=("n_free", "want_displacement", "hold"))
def _simulate(model, blocks, acc, dt_s, x0, n_free: int, want_displacement: bool, hold: str):
    states = modal_states(model, acc, dt_s, x0=x0, hold=hold)
    if n_free > 0:
        tau = dt_s * jnp.arange(1, n_free + 1, dtype=acc.dtype)
        states = jnp.concatenate([states, free_states(model, states[-1], tau)], axis=0)
    q, qd = states[..., 0], states[..., 1]
    t = dt_s * jnp.arange(q.shape[0], dtype=acc.dtype)
    base = jnp.concatenate([acc, jnp.zeros((n_free, 3), acc.dtype)], axis=0)
    coords = with_acceleration(model, q, base, jnp)  # u = Phi q (+ D a: the static residual)
    deviation_m = deviation(blocks, coords)
    shapes = response_shapes(model, jnp)
    displacement = jnp.einsum("kcm,tm->tkc", shapes, coords) if want_displacement else None
    return t, q, qd, deviation_m, displacement


def _check_dtype(dtype: str):
    if dtype not in _DTYPES:
        raise InputError(f"dtype: must be one of {sorted(_DTYPES)}, got {dtype!r}")
    return _DTYPES[dtype]


def on_device(model: ModalModel, dtype: str = "float64") -> tuple[ModalModel, PointBlocks]:
    """``model`` as JAX arrays of ``dtype`` plus its points in blocks for the deviation during
    and after a move (jaxflex._blocks.PointBlocks of jaxflex._deviation.response_shapes).

    For a concrete model the result is cached on the model, so repeated calls transfer and
    reorder nothing; traced models (inside jit/vmap) are converted on the fly.
    """
    jdtype = _check_dtype(dtype)
    traced = is_traced(require_model(model))
    cache = None if traced else model.__dict__.setdefault("_device_cache", {})
    if cache is not None and dtype in cache:
        return cache[dtype]
    cast = jax.tree_util.tree_map(lambda x: jnp.asarray(x, jdtype), model)
    if traced:
        blocks = point_blocks(response_shapes(cast, jnp), model.points)
    else:
        blocks = blocks_of(model, dtype, moving=True)
    entry = (cast, blocks)
    if cache is not None:
        cache[dtype] = entry
    return entry


def free_steps(extend_s: float, dt_s: float) -> int:
    """Whole steps of ``dt_s`` covering ``extend_s`` s of free vibration after the move."""
    if not extend_s:
        return 0
    return int(np.ceil(check_positive("extend_s", extend_s) / dt_s - 1e-9))


def simulate(
    model: ModalModel,
    acc,
    dt_s=None,
    *,
    displacement: bool = False,
    extend_s: float = 0.0,
    x0=None,
    hold: str = "linear",
    dtype: str = "float64",
) -> Response:
    """Response of ``model`` to a :class:`~jaxflex._profile.Move` (or to acceleration samples
    ``acc`` ((n+1, 3), m/s^2) at t_k = k dt_s).

    The acceleration is linear between samples (first-order hold; ``hold="zero"`` holds each
    sample over its step instead); the response at the samples is exact for any ``dt_s``
    (s). With ``extend_s`` > 0 the response continues as free vibration (base at rest) for
    that many seconds, rounded up to whole steps. ``displacement=True`` also returns every
    point's displacement (T, K, 3), m. ``dtype`` is "float64" (default) or "float32".
    Works under jax.jit, jax.grad and jax.vmap (over ``acc`` and over stacked models,
    jaxflex.stack_models).
    """
    model, blocks = on_device(model, dtype)
    if dt_s is None or (isinstance(acc, Move) and not is_traced(dt_s)):
        dt_s = as_move(acc, dt_s).dt_s  # a Move's own step; raw samples need one
    if isinstance(acc, Move):  # checked when it was made
        acc = acc.acc
    elif not is_traced(acc):
        check_acc(acc)
    if not is_traced(dt_s):
        check_positive("dt_s", dt_s)
    if hold not in HOLDS:
        raise InputError(f"hold: must be one of {list(HOLDS)}, got {hold!r}")
    if extend_s and is_traced(dt_s):
        raise InputError("extend_s: needs a concrete dt_s (not traced under jit/grad/vmap)")
    n_free = free_steps(extend_s, float(dt_s)) if extend_s else 0
    jdtype = _DTYPES[dtype]
    acc = jnp.asarray(acc, jdtype)
    x0 = None if x0 is None else jnp.asarray(x0, jdtype)
    t, q, qd, dev, disp = _simulate(
        model, blocks, acc, jnp.asarray(dt_s, jdtype), x0, n_free, bool(displacement), hold
    )
    return Response(t=t, q=q, qd=qd, deviation=dev, displacement=disp, n_steps=acc.shape[0] - 1)


def move_deviation(model, blocks, acc, dt_s):
    """d (n+1,) m at the samples of ``acc`` ((n+1, 3) m/s^2, from rest) for the device model
    and blocks of :func:`on_device`: the modal recursion, the static residual's share and the
    pruned point evaluation. Traceable (the kernel of :func:`simulate`, for benchmarks and
    batches)."""
    q = modal_states(model, acc, dt_s)[..., 0]
    return deviation(blocks, with_acceleration(model, q, acc, jnp))


@jax.jit
def _batch_deviation(models, blocks, accs, dt_s):
    def coordinates(m, a):
        return with_acceleration(m, modal_states(m, a, dt_s)[..., 0], a, jnp)

    q = jax.vmap(coordinates)(models, accs)
    return jax.lax.map(lambda args: deviation(*args), (blocks, q))


def batch_deviation(models: ModalModel, accs, dt_s: float):
    """Deviation d (B, n+1) in m of B stacked models (jaxflex.stack_models) under their moves
    ``accs`` (B, n+1, 3) m/s^2 at step ``dt_s`` s: one jitted function for the batch. The
    modal recursions of all cases run in one ``lax.scan`` (B x M oscillators per step); the
    pruned point evaluation (jaxflex._deviation) runs case by case (``lax.map``), each with
    its own pruning."""
    accs = jnp.asarray(accs, jnp.float64)
    if accs.ndim != 3 or accs.shape[2] != 3 or accs.shape[0] != np.shape(models.freq_hz)[0]:
        raise InputError(
            f"accs: expected shape (B, n+1, 3) with B = {np.shape(models.freq_hz)[0]} models, "
            f"got {accs.shape}"
        )
    check_positive("dt_s", dt_s)
    blocks = _stacked_blocks(models)
    return _batch_deviation(models, blocks, accs, jnp.asarray(dt_s, jnp.float64))


_stacked_blocks = jax.jit(jax.vmap(lambda m: point_blocks(response_shapes(m, jnp), m.points)))
