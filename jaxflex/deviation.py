"""Point displacements and the deviation d(t) = max_p |u_p(t)| from modal coordinates.

u_p(t) = sum_i phi_i(p) q_i(t) with mode shapes ``shapes`` (K, 3, M) in m per kg^0.5 and
modal coordinates q (T, M) in kg^0.5 m. :func:`deviation` is the JAX form (one matrix
product over all steps, a cheap custom gradient); :func:`point_norms`,
:func:`point_displacements` and :func:`deviation_curves` are the NumPy forms used where
no compilation is wanted (exact searches, reports, reductions). Shapes may carry only some
displacement components (K, C, M): norms are then taken over those.
:func:`outputs_at` evaluates the other outputs linear in the modal state (cup reactions,
stresses: jaxflex.outputs) exactly at any time.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from jaxflex.engine import states_at
from jaxflex.profile import acceleration_at

CHUNK_POINTS = 1024  # points per matrix product in the blocked NumPy evaluation


def shapes_by_component(shapes):
    """(K, 3, M) mode shapes -> (M, 3K) with all x rows, then all y, then all z: the layout
    in which one matrix product gives every point's displacement for every time step."""
    n_points, _, n_modes = shapes.shape
    return jnp.transpose(shapes, (2, 1, 0)).reshape(n_modes, 3 * n_points)


def _squared_norms(shapes_c, q):
    n_points = shapes_c.shape[1] // 3
    u = (q @ shapes_c).reshape(q.shape[0], 3, n_points)
    return jnp.sum(u * u, axis=1)  # (T, K)


def _safe_sqrt(x):
    positive = x > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, x, 1.0)), 0.0)


@jax.custom_vjp
def deviation(shapes_c, q):
    """d_t = max_p |u_p(t)| (m) for modal coordinates q (T, M); shapes_c from
    :func:`shapes_by_component`. The gradient flows through the maximising point only
    (zero where d = 0), which costs O(T M) instead of a second full matrix product."""
    return _safe_sqrt(jnp.max(_squared_norms(shapes_c, q), axis=1))


def _deviation_fwd(shapes_c, q):
    sq = _squared_norms(shapes_c, q)
    arg = jnp.argmax(sq, axis=1)
    d = _safe_sqrt(jnp.take_along_axis(sq, arg[:, None], axis=1)[:, 0])
    return d, (shapes_c, q, arg, d)


def _deviation_bwd(residuals, d_bar):
    shapes_c, q, arg, d = residuals
    n_modes, n_points = shapes_c.shape[0], shapes_c.shape[1] // 3
    by_point = shapes_c.reshape(n_modes, 3, n_points)
    selected = jnp.take(by_point, arg, axis=2)  # (M, 3, T)
    u_sel = jnp.einsum("mct,tm->tc", selected, q)
    coef = jnp.where(d > 0, d_bar / jnp.where(d > 0, d, 1.0), 0.0)
    weighted = coef[:, None] * u_sel  # (T, 3): d(d_t)/d(u_p*)
    q_bar = jnp.einsum("tc,mct->tm", weighted, selected)
    shapes_bar = (
        jnp.zeros_like(by_point)
        .at[:, :, arg]
        .add(jnp.einsum("tc,tm->mct", weighted, q))
        .reshape(shapes_c.shape)
    )
    return shapes_bar, q_bar


deviation.defvjp(_deviation_fwd, _deviation_bwd)


def point_displacements(shapes: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(T, K, C) displacements in m of the points of ``shapes`` (K, C, M) for q (T, M)."""
    return np.einsum("pcm,tm->tpc", shapes, q, optimize=True)


def point_norms(shapes: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(K, T) |u_p(t)| in m for the points of ``shapes`` (K, C, M) and q (T, M)."""
    u = np.einsum("pcm,tm->pct", shapes, q, optimize=True)
    return np.sqrt(np.einsum("pct,pct->pt", u, u))


@dataclass(frozen=True)
class Curves:
    """Deviation over every point (``all``, (T,) m, with the point index ``argmax`` (T,)) and
    over each requested subset of points (``subsets`` (S, T) m)."""

    all: np.ndarray
    argmax: np.ndarray
    subsets: np.ndarray


def deviation_curves(
    shapes: np.ndarray, q: np.ndarray, subsets: Sequence[np.ndarray] = ()
) -> Curves:
    """d(t) = max_p |u_p(t)| for all points of ``shapes`` (K, C, M) and for each index
    subset, from modal coordinates ``q`` (T, M); blocks of CHUNK_POINTS points, so memory
    grows with T x CHUNK_POINTS, not T x K."""
    n_points = shapes.shape[0]
    best = np.full(q.shape[0], -1.0)
    where = np.zeros(q.shape[0], dtype=np.int64)
    masks = []
    for idx in subsets:
        mask = np.zeros(n_points, dtype=bool)
        mask[np.asarray(idx, dtype=np.int64)] = True
        masks.append(mask)
    sub = np.zeros((len(masks), q.shape[0]))
    for start in range(0, n_points, CHUNK_POINTS):
        block = shapes[start : start + CHUNK_POINTS]
        u = (block.reshape(-1, block.shape[2]) @ q.T).reshape(block.shape[0], block.shape[1], -1)
        norms = np.sqrt(np.einsum("kdt,kdt->kt", u, u))
        local = np.argmax(norms, axis=0)
        value = norms[local, np.arange(norms.shape[1])]
        better = value > best
        best = np.where(better, value, best)
        where = np.where(better, local + start, where)
        for s, mask in enumerate(masks):
            inside = mask[start : start + block.shape[0]]
            if inside.any():
                sub[s] = np.maximum(sub[s], norms[inside].max(axis=0))
    return Curves(all=best, argmax=where, subsets=sub)


def deviation_curve(
    model, acc, dt_s: float, until_s: float, substeps: int = 8
) -> tuple[np.ndarray, np.ndarray]:
    """(t (T,) s, d (T,) m): the exact deviation every dt_s / ``substeps`` during the move
    ``acc`` ((n+1, 3) m/s^2) and after it, until at least ``until_s`` (and at least one step
    past the end of the move). Exact samples of d(t), not interpolations."""
    n_steps = np.shape(acc)[0] - 1
    h = dt_s / substeps
    t_move = h * np.arange(n_steps * substeps)
    after = max(1, int(np.ceil((until_s - n_steps * dt_s) / h)) + 1)
    t = np.concatenate([t_move, n_steps * dt_s + h * np.arange(after)])
    q = states_at(model, acc, dt_s, t)[..., 0]
    return t, deviation_curves(np.asarray(model.shapes), q).all


def outputs_at(model, outputs, acc, dt_s: float, t_s, offset=None) -> np.ndarray:
    """(T, Y) exact values of ``outputs`` (jaxflex.outputs.LinearOutputs of ``model``) at
    times ``t_s`` (T,) s during the move ``acc`` ((n+1, 3) m/s^2, at rest at its end) and
    after it, plus the constant ``offset`` (Y,) (e.g. the share of gravity)."""
    t = np.asarray(t_s, dtype=np.float64)
    values = outputs.values(states_at(model, acc, dt_s, t), acceleration_at(acc, dt_s, t))
    return values if offset is None else values + offset
