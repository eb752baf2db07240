"""Point displacements and the deviation d(t) = max_p |u_p(t)| from modal coordinates.

u_p(t) = sum_i phi_i(p) q_i(t) with mode shapes ``shapes`` (K, C, M) in m per kg^0.5 (C = 3
displacement components, or fewer: norms are then taken over those) and modal coordinates
q (T, M) in kg^0.5 m.

During a move a model with a static residual D (jaxflex.model: the quasi-static share of the
modes it does not keep, u_p = Phi q + D_p a) adds D a(t): the evaluation treats the three
acceleration components as three more coordinates with "shapes" D (:func:`response_shapes`,
:func:`with_acceleration`, ``moving=True`` in :func:`blocks_of`), so every bound, the pruning
and the gradient below hold unchanged. After the move a = 0 and only the modes remain.

:func:`deviation` and :func:`deviation_point` are the JAX forms. They never materialise the
(T, K, C) displacements: the points are grouped in spatially compact blocks
(jaxflex._blocks) whose centre and per-mode radius bound every member,
|u_p(t)| <= |u_c(t)| + sum_i rho_{B,i} |q_i(t)|, and the largest centre value is a lower
bound of d(t). Only the (block, step) pairs whose bound reaches that lower bound are
evaluated, in units of one block and up to UNIT_STEPS steps, with a running maximum per step
(``lax.while_loop``: no host round trip, the same code on CPU and GPU). Pruning is exact: a
pruned pair's bound, inflated by a multiple of the round-off of its computation, lies below
a value that is attained, so the result equals the dense evaluation (value and arg-max, ties
to the lowest point index). The gradient flows through the maximising point only (custom
VJP, O(T M)). Memory: O(T nB) for the bounds, nB = K / BLOCK_POINTS, plus one batch of units.

:func:`max_norms` is the NumPy entry to the same evaluation (for code that is not traced);
:func:`point_norms`, :func:`point_displacements` and :func:`deviation_curves` are NumPy
forms for the places that need every point's value (reports, subset reductions).
:func:`outputs_at` evaluates the other outputs linear in the modal state (cup reactions,
stresses: jaxflex._outputs) exactly at any time.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from jaxflex._blocks import PointBlocks, point_blocks
from jaxflex._engine import PAD_STEPS, padded_steps, states_at
from jaxflex._profile import Move, acceleration_at
from jaxflex._validation import is_traced
from jaxflex.model import shape_cache

CHUNK_POINTS = 1024  # points per matrix product in the blocked NumPy evaluation
UNIT_STEPS = 32  # steps evaluated together for one block
BATCH_UNITS = 16  # units per iteration of the evaluation loop
# A pair is pruned if its bound times (1 + ROUND_OFF_FACTOR (M + C) eps) lies below the lower
# bound: the bound, the centre value and the evaluated norms each carry a relative round-off
# of at most (M + C) eps (dot products of length M, sums of C squares).
ROUND_OFF_FACTOR = 16


def block_bounds(centres, radius, q, xp=jnp):
    """(centre (T, nB), upper (T, nB)) for modal coordinates q (T, M): the attained value
    |u_c(t)| of each block's centre and the bound |u_c(t)| + sum_i rho_{B,i} |q_i(t)| of every
    member, from ``centres`` (M, C, nB) and ``radius`` (nB, M) of jaxflex._blocks.PointBlocks
    (or a subset of their blocks). ``xp``: jax.numpy or numpy."""
    n_modes, n_comp, n_blocks = centres.shape
    u_centre = (q @ centres.reshape(n_modes, n_comp * n_blocks)).reshape(-1, n_comp, n_blocks)
    centre = xp.sqrt(xp.sum(u_centre * u_centre, axis=1))
    return centre, centre + xp.abs(q) @ radius.T


def round_off_slack(n_modes: int, n_comp: int, dtype) -> float:
    """1 + the relative round-off a bound or a norm of length-M dot products can carry (see
    ROUND_OFF_FACTOR): bounds are inflated by it before they prune."""
    return 1.0 + ROUND_OFF_FACTOR * (n_modes + n_comp) * float(np.finfo(dtype).eps)


def _alive_tiles(blocks: PointBlocks, q):
    """(nB, T / UNIT_STEPS) bool: the (block, tile of UNIT_STEPS steps) pairs in which some
    step's bound reaches the largest centre value of that step. T must be a multiple of
    UNIT_STEPS."""
    n_steps, n_modes = q.shape
    centre, upper = block_bounds(blocks.centres, blocks.radius, q)
    lower = jnp.max(centre, axis=1, keepdims=True)
    slack = round_off_slack(n_modes, blocks.n_components, q.dtype)
    alive = (upper * slack >= lower) & (upper > 0)
    return jnp.any(alive.reshape(n_steps // UNIT_STEPS, UNIT_STEPS, -1), axis=1).T


def _block_max(q, shapes, members, big: int):
    """Largest |u|^2 of a block's points and its lowest-index maximiser: q (..., S, M),
    shapes (..., M, C b) and member indices (..., b) -> (value (..., S), point (..., S))."""
    b = members.shape[-1]
    u = jnp.einsum("...sm,...mx->...sx", q, shapes)
    sq = jnp.sum(u.reshape(*u.shape[:-1], -1, b) ** 2, axis=-2)  # (..., S, b)
    value = jnp.max(sq, axis=-1)
    who = jnp.min(jnp.where(sq == value[..., None], members[..., None, :], big), axis=-1)
    return value, who


def _evaluate(blocks: PointBlocks, q):
    """(d^2 (T,), point (T,)): max_p |u_p(t)|^2 over the alive tiles and its lowest-index
    maximiser (0 where d = 0, as a dense arg-max of zeros). A single block has nothing to
    prune: it is evaluated at once."""
    n_steps, n_modes = q.shape
    big = blocks.n_points
    if blocks.radius.shape[0] == 1:
        value, who = _block_max(q, blocks.shapes[0], blocks.index[0], big)
        return value, jnp.where(value > 0, who, 0)
    n_tiles = -(-n_steps // UNIT_STEPS)
    q_tiles = jnp.zeros((n_tiles * UNIT_STEPS, n_modes), q.dtype).at[:n_steps].set(q)
    alive = _alive_tiles(blocks, q_tiles).ravel()  # block-major
    todo = jnp.nonzero(alive, size=alive.size, fill_value=0)[0].astype(jnp.int32)
    n_todo = jnp.sum(alive, dtype=jnp.int32)
    q_tiles = q_tiles.reshape(n_tiles, UNIT_STEPS, n_modes)

    def body(state):
        start, best, point = state
        unit = start + jnp.arange(BATCH_UNITS, dtype=jnp.int32)
        valid = unit < n_todo
        which = todo[jnp.minimum(unit, todo.shape[0] - 1)]
        block, tile = which // n_tiles, which % n_tiles
        value, who = _block_max(q_tiles[tile], blocks.shapes[block], blocks.index[block], big)
        value = jnp.where(valid[:, None], value, -1.0)
        raised = best.at[tile].max(value)
        point = jnp.where(raised > best, big, point)
        point = point.at[tile].min(jnp.where(value == raised[tile], who, big))
        return start + BATCH_UNITS, raised, point

    state = (
        jnp.int32(0),
        jnp.zeros((n_tiles, UNIT_STEPS), q.dtype),
        jnp.zeros((n_tiles, UNIT_STEPS), jnp.int32),
    )
    _, best, point = jax.lax.while_loop(lambda s: s[0] < n_todo, body, state)
    return best.ravel()[:n_steps], point.ravel()[:n_steps]


@jax.custom_vjp
def deviation_point(blocks: PointBlocks, q):
    """(d (T,) m, point (T,) int): d_t = max_p |u_p(t)| for modal coordinates q (T, M) and
    the maximising point (lowest index among ties; 0 where d = 0)."""
    best, point = _evaluate(blocks, q)
    return jnp.sqrt(best), point


def _deviation_fwd(blocks, q):
    d, point = deviation_point(blocks, q)
    return (d, point), (blocks, q, point, d)


def _zero_cotangent(x):
    if jnp.issubdtype(x.dtype, jnp.integer):
        return np.zeros(x.shape, dtype=jax.dtypes.float0)
    return jnp.zeros_like(x)


def _deviation_bwd(residuals, cotangents):
    blocks, q, point, d = residuals
    d_bar = cotangents[0]
    n_blocks, n_modes, width = blocks.shapes.shape
    b, n_comp = blocks.block_points, blocks.n_components
    by_point = blocks.shapes.reshape(n_blocks, n_modes, n_comp, b)
    slot = blocks.slot[point]
    block, member = slot // b, slot % b
    selected = by_point[block, :, :, member]  # (T, M, C)
    u_sel = jnp.einsum("tmc,tm->tc", selected, q)
    coef = jnp.where(d > 0, d_bar / jnp.where(d > 0, d, 1.0), 0.0)
    weighted = coef[:, None] * u_sel  # (T, C): d(d_t)/d(u_p*)
    q_bar = jnp.einsum("tc,tmc->tm", weighted, selected)
    shapes_bar = (
        jnp.zeros_like(by_point)
        .at[block, :, :, member]
        .add(jnp.einsum("tc,tm->tmc", weighted, q))
        .reshape(n_blocks, n_modes, width)
    )
    zero = jax.tree_util.tree_map(_zero_cotangent, blocks)
    return PointBlocks(shapes_bar, zero.index, zero.centres, zero.radius, zero.slot), q_bar


deviation_point.defvjp(_deviation_fwd, _deviation_bwd)


def deviation(blocks: PointBlocks, q):
    """d_t = max_p |u_p(t)| (T,) in m for modal coordinates q (T, M) and the points of
    ``blocks`` (jaxflex._blocks.point_blocks, or :func:`blocks_of` a model). Differentiable
    in both (through the maximising point; zero where d = 0)."""
    return deviation_point(blocks, q)[0]


_max_norms = jax.jit(deviation_point)


def residual_of(model):
    """The static residual D (K, 3, 3) of a concrete or traced model, or None where the model
    knows no static displacement (jaxflex.model)."""
    if model.static_shapes is None:
        return None
    if not is_traced(model):
        return model.static_residual
    omega = 2.0 * np.pi * model.freq_hz
    return model.static_shapes + model.shapes @ (model.gamma / omega[:, None] ** 2)


def response_shapes(model, xp=np):
    """(K, 3, M) the mode shapes, or (K, 3, M + 3) with the static residual's columns where
    the model has one: the shapes of the displacement during a move (module docstring)."""
    residual = residual_of(model)
    shapes = xp.asarray(model.shapes)
    return shapes if residual is None else xp.concatenate([shapes, xp.asarray(residual)], axis=2)


def with_acceleration(model, q, acc, xp=np):
    """The coordinates of :func:`response_shapes`: q (T, M), followed by the base accelerations
    ``acc`` (T, 3) m/s^2 at the same times where the model has a static residual."""
    if residual_of(model) is None:
        return q
    return xp.concatenate([q, xp.asarray(acc, q.dtype)], axis=-1)


def block_model(shapes, points, dtype: str = "float64") -> PointBlocks:
    """:class:`PointBlocks` of concrete ``shapes`` (K, C, M) at ``points`` (K, 3) m, for
    :func:`max_norms`, built with NumPy (nothing to compile) and placed on the device."""
    blocks = point_blocks(np.asarray(shapes, dtype), np.asarray(points, np.float64))
    return jax.device_put(blocks)  # jnp.asarray would compile a copy program per shape (~7 ms)


def _moving_cache(model) -> dict | None:
    """The per-model cache of data built from :func:`response_shapes` (they depend on the
    frequencies too), or None where the model has no static residual (the modes' data
    serve)."""
    if residual_of(model) is None:
        return None
    return model.__dict__.setdefault("_moving_blocks", {})


def blocks_of(model, dtype: str = "float64", *, moving: bool = False) -> PointBlocks:
    """The :class:`PointBlocks` of a concrete model's shapes in ``dtype`` (built once, then
    shared by the models with the same shapes and points); with
    ``moving`` those of :func:`response_shapes` (coordinates :func:`with_acceleration`)."""
    moving_cache = _moving_cache(model) if moving else None
    if moving_cache is not None:
        if dtype not in moving_cache:
            moving_cache[dtype] = block_model(response_shapes(model), model.points, dtype)
        return moving_cache[dtype]
    cache = shape_cache(model).setdefault("blocks", {})
    if dtype not in cache:
        cache[dtype] = block_model(model.shapes, model.points, dtype)
    return cache[dtype]


def component_blocks(
    model, components: tuple[int, ...], *, moving: bool = False
) -> tuple[np.ndarray, PointBlocks]:
    """The shapes (K, C, M) of a concrete model restricted to the displacement
    ``components`` it uses, and their :class:`PointBlocks` (float64), built once per shapes
    and points (cached per shapes and points: the scenarios of a robust grid share them); with
    ``moving`` those of :func:`response_shapes` (K, C, M + 3 where there is a residual)."""
    moving_cache = _moving_cache(model) if moving else None
    cache = shape_cache(model) if moving_cache is None else moving_cache
    key = ("components", tuple(components))
    if key not in cache:
        full = response_shapes(model) if moving_cache is not None else np.asarray(model.shapes)
        shapes = full[:, list(components), :]
        cache[key] = (shapes, block_model(shapes, model.points))
    return cache[key]


# max_norms evaluates the states in chunks of this many (the last padded with rest): one
# compilation per model size whatever the number of states (the optimiser's residuals ask
# for a different number at every move length; each compilation costs ~0.4 s).
NORM_CHUNK_STEPS = 4 * PAD_STEPS


def max_norms(blocks: PointBlocks, q) -> tuple[np.ndarray, np.ndarray]:
    """NumPy (d (T,) m, point (T,)) of :func:`deviation_point` for q (T, M) as NumPy, in
    chunks of NORM_CHUNK_STEPS states."""
    q = np.asarray(q)
    n_steps = q.shape[0]
    padded = np.zeros((padded_steps(n_steps, NORM_CHUNK_STEPS), q.shape[1]), q.dtype)
    padded[:n_steps] = q
    dtype = blocks.shapes.dtype
    parts = [
        _max_norms(blocks, jnp.asarray(padded[start : start + NORM_CHUNK_STEPS], dtype))
        for start in range(0, padded.shape[0], NORM_CHUNK_STEPS)
    ]
    d = np.concatenate([np.asarray(part[0]) for part in parts])
    point = np.concatenate([np.asarray(part[1]) for part in parts])
    return d[:n_steps], point[:n_steps]


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
    model, move: Move, until_s: float, substeps: int = 8, max_after: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(t (T,) s, d (T,) m): the exact deviation every dt_s / ``substeps`` during the
    :class:`~jaxflex._profile.Move` ``move`` (samples ``acc`` at step ``dt_s``) and after it,
    until at least ``until_s`` (and at least one step past the end of the move); with
    ``max_after``, at most that many samples after the move (spread evenly: a picture of a
    settling of hours needs no millisecond samples). Exact samples of d(t), not
    interpolations; the points are evaluated by the pruned blocked evaluation
    (:func:`max_norms`)."""
    dt_s, n_steps = move.dt_s, move.n_steps
    h = dt_s / substeps
    t_move = h * np.arange(n_steps * substeps)
    span = until_s - n_steps * dt_s
    if max_after is not None and span > h * max_after:
        h = span / max_after
    after = max(1, int(np.ceil(span / h)) + 1)
    t = np.concatenate([t_move, n_steps * dt_s + h * np.arange(after)])
    q = states_at(model, move, t)[..., 0]
    q = with_acceleration(model, q, acceleration_at(move, t))
    return t, max_norms(blocks_of(model, moving=True), q)[0]


def outputs_at(model, outputs, move: Move, t_s, offset=None) -> np.ndarray:
    """(T, Y) exact values of ``outputs`` (jaxflex._outputs.LinearOutputs of ``model``) at
    times ``t_s`` (T,) s during ``move`` (at rest at its end) and after it, plus the constant
    ``offset`` (Y,) (e.g. the share of gravity)."""
    t = np.asarray(t_s, dtype=np.float64)
    values = outputs.values(states_at(model, move, t), acceleration_at(move, t))
    return values if offset is None else values + offset
