"""Points grouped into blocks with a bound, the data of the pruned deviation.

The points of a model are ordered by a k-d bisection of their coordinates (each segment of
blocks is split at the median of its longest extent until one block of ``block_points``
points remains), so a block is a compact patch of the part. Per block the *centre* is the
member whose shape is nearest to the block's mean shape, and the per-mode radius

    rho_{B,i} = max_{p in B} |phi_i(p) - phi_i(c_B)|    (norm over the displacement components)

bounds every member by the triangle inequality:

    |u_p(t)| <= |u_c(t)| + sum_i rho_{B,i} |q_i(t)|    for every p in B.

Mode shapes are continuous fields over the part, so on a mesh the radius is small against
the displacement and the bound is tight; for shapes without spatial order it stays true but
prunes nothing. The same code builds the blocks of a concrete model once with NumPy
(jaxflex._deviation.blocks_of: no compilation) and of a traced one with jax.numpy inside jit/vmap.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

BLOCK_POINTS = 64


@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True)
class PointBlocks:
    """K points of C displacement components and M modes in nB blocks of b points.

    shapes: (nB, M, C b) mode shapes in the product layout of a block: column c b + j is
        component c of the block's j-th point (m per kg^0.5; padding slots are zero).
    index: (nB, b) original point index of every slot; padding slots hold K.
    centres: (M, C, nB) the centre shapes of the blocks.
    radius: (nB, M) per-mode radius rho_{B,i} of each block about its centre.
    slot: (K,) slot B b + j of every original point.
    """

    shapes: Any
    index: Any
    centres: Any
    radius: Any
    slot: Any

    def tree_flatten(self):
        return (self.shapes, self.index, self.centres, self.radius, self.slot), None

    @classmethod
    def tree_unflatten(cls, _aux, children):
        return cls(*children)

    @property
    def n_points(self) -> int:
        return int(self.slot.shape[-1])

    @property
    def block_points(self) -> int:
        return int(self.index.shape[-1])

    @property
    def n_components(self) -> int:
        return int(self.shapes.shape[-1]) // self.block_points


def _split_levels(n_blocks: int) -> list[np.ndarray]:
    """Per bisection level the segment id of every block (static): a segment of n blocks
    splits into n // 2 and n - n // 2 until every segment is one block."""
    levels = []
    segments = [(0, n_blocks)]
    while any(n > 1 for _, n in segments):
        seg = np.empty(n_blocks, dtype=np.int32)
        for s, (start, n) in enumerate(segments):
            seg[start : start + n] = s
        levels.append(seg)
        segments = [
            part
            for start, n in segments
            for part in (
                ((start, n // 2), (start + n // 2, n - n // 2)) if n > 1 else ((start, n),)
            )
        ]
    return levels


def _segment_extent(xp, values, seg, n_seg: int):
    """(n_seg, 3) lowest and highest ``values`` (N, 3) over each segment ``seg`` (N,) of
    consecutive entries (sorted ids 0 ... n_seg - 1)."""
    if xp is np:
        starts = np.flatnonzero(np.r_[True, seg[1:] != seg[:-1]])
        return np.minimum.reduceat(values, starts), np.maximum.reduceat(values, starts)
    low = jax.ops.segment_min(values, seg, num_segments=n_seg, indices_are_sorted=True)
    high = jax.ops.segment_max(values, seg, num_segments=n_seg, indices_are_sorted=True)
    return low, high


def _namespace(*arrays):
    """numpy for concrete NumPy input (built in milliseconds, nothing to compile), else
    jax.numpy (traceable, for traced models inside jit/vmap)."""
    return np if all(isinstance(a, np.ndarray) for a in arrays) else jnp


def kd_order(points, block_points: int = BLOCK_POINTS):
    """(nB b,) order of the points (K, 3) m into nB = ceil(K / b) spatially compact blocks of
    b = ``block_points`` consecutive entries; entries >= K are padding (at the end of the
    bisection's last segments). NumPy in, NumPy out; otherwise traceable jax.numpy (both
    sorts are stable: the same order)."""
    xp = _namespace(points)
    n_points = points.shape[0]
    n_blocks = -(-n_points // block_points)
    pad = n_blocks * block_points - n_points
    far = xp.max(points, axis=0) + 1.0  # padding sorts last along every axis
    coords = xp.concatenate([points, xp.broadcast_to(far, (pad, 3))], axis=0)
    order = xp.arange(n_blocks * block_points)
    for seg_of_block in _split_levels(n_blocks):
        seg = xp.asarray(np.repeat(seg_of_block, block_points))
        here = coords[order]
        low, high = _segment_extent(xp, here, seg, int(seg_of_block.max()) + 1)
        axis = xp.argmax(high - low, axis=1)[seg]
        key = xp.take_along_axis(here, axis[:, None], axis=1)[:, 0]
        order = order[xp.lexsort((key, seg))]
    return order


def _slots(xp, order, n_points: int):
    """(K,) the slot of every original point in the blocks' ``order`` (padding dropped)."""
    slots = xp.arange(order.shape[0], dtype=xp.int32)
    if xp is np:
        slot = np.zeros(n_points, np.int32)
        real = order < n_points
        slot[order[real]] = slots[real]
        return slot
    return jnp.zeros(n_points, jnp.int32).at[order].set(slots, mode="drop")


def point_blocks(shapes, points, block_points: int = BLOCK_POINTS) -> PointBlocks:
    """:class:`PointBlocks` of ``shapes`` (K, C, M) at ``points`` (K, 3). NumPy arrays in:
    built with NumPy (concrete models: nothing to compile), NumPy arrays out; otherwise
    traceable jax.numpy, where the centres and radii only steer the pruning and carry no
    gradient."""
    xp = _namespace(shapes, points)
    freeze = (lambda x: x) if xp is np else jax.lax.stop_gradient
    n_points, n_comp, n_modes = shapes.shape
    b = int(min(block_points, n_points))
    order = kd_order(points, b)
    n_blocks = order.shape[0] // b
    real = (order < n_points).reshape(n_blocks, b)
    index = xp.where(real, order.reshape(n_blocks, b), n_points)
    padded = xp.concatenate([shapes, xp.zeros((1, n_comp, n_modes), shapes.dtype)], axis=0)
    members = padded[index]  # (nB, b, C, M)
    frozen = freeze(members)
    mean = xp.sum(frozen, axis=1) / xp.sum(real, axis=1)[:, None, None]
    spread = xp.sum((frozen - mean[:, None]) ** 2, axis=(2, 3))
    centre = xp.argmin(xp.where(real, spread, xp.inf), axis=1)  # (nB,)
    centre_shape = xp.take_along_axis(frozen, centre[:, None, None, None], axis=1)[:, 0]
    offset = xp.sqrt(xp.sum((frozen - centre_shape[:, None]) ** 2, axis=2))  # (nB, b, M)
    radius = xp.max(xp.where(real[..., None], offset, 0.0), axis=1)
    return PointBlocks(
        shapes=xp.transpose(members, (0, 3, 2, 1)).reshape(n_blocks, n_modes, n_comp * b),
        index=index.astype(xp.int32),
        centres=xp.transpose(centre_shape, (2, 1, 0)),
        radius=radius.astype(shapes.dtype),
        slot=_slots(xp, order, n_points),
    )
