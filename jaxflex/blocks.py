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
prunes nothing. Everything is ``jax.numpy`` (traceable: the same code builds the blocks of a
concrete model once, jaxflex.deviation.blocks_of, and of a traced one inside jit/vmap).
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


def kd_order(points, block_points: int = BLOCK_POINTS):
    """(nB b,) order of the points (K, 3) m into nB = ceil(K / b) spatially compact blocks of
    b = ``block_points`` consecutive entries; entries >= K are padding (at the end of the
    bisection's last segments). Traceable."""
    points = jnp.asarray(points)
    n_points = points.shape[0]
    n_blocks = -(-n_points // block_points)
    pad = n_blocks * block_points - n_points
    far = jnp.max(points, axis=0) + 1.0  # padding sorts last along every axis
    coords = jnp.concatenate([points, jnp.broadcast_to(far, (pad, 3))], axis=0)
    order = jnp.arange(n_blocks * block_points)
    for seg_of_block in _split_levels(n_blocks):
        seg = jnp.asarray(np.repeat(seg_of_block, block_points))
        n_seg = int(seg_of_block.max()) + 1
        here = coords[order]
        low = jax.ops.segment_min(here, seg, num_segments=n_seg)
        high = jax.ops.segment_max(here, seg, num_segments=n_seg)
        axis = jnp.argmax(high - low, axis=1)[seg]
        key = jnp.take_along_axis(here, axis[:, None], axis=1)[:, 0]
        order = order[jnp.lexsort((key, seg))]
    return order


def point_blocks(shapes, points, block_points: int = BLOCK_POINTS) -> PointBlocks:
    """:class:`PointBlocks` of ``shapes`` (K, C, M) at ``points`` (K, 3). Traceable; the
    centres and radii only steer the pruning and carry no gradient."""
    shapes = jnp.asarray(shapes)
    n_points, n_comp, n_modes = shapes.shape
    b = int(min(block_points, n_points))
    order = kd_order(points, b)
    n_blocks = order.shape[0] // b
    real = (order < n_points).reshape(n_blocks, b)
    index = jnp.where(real, order.reshape(n_blocks, b), n_points)
    padded = jnp.concatenate([shapes, jnp.zeros((1, n_comp, n_modes), shapes.dtype)], axis=0)
    members = padded[index]  # (nB, b, C, M)
    frozen = jax.lax.stop_gradient(members)
    mean = jnp.sum(frozen, axis=1) / jnp.sum(real, axis=1)[:, None, None]
    spread = jnp.sum((frozen - mean[:, None]) ** 2, axis=(2, 3))
    centre = jnp.argmin(jnp.where(real, spread, jnp.inf), axis=1)  # (nB,)
    centre_shape = jnp.take_along_axis(frozen, centre[:, None, None, None], axis=1)[:, 0]
    offset = jnp.sqrt(jnp.sum((frozen - centre_shape[:, None]) ** 2, axis=2))  # (nB, b, M)
    radius = jnp.max(jnp.where(real[..., None], offset, 0.0), axis=1)
    slot = (
        jnp.zeros(n_points, jnp.int32)
        .at[order]
        .set(jnp.arange(order.shape[0], dtype=jnp.int32), mode="drop")
    )
    return PointBlocks(
        shapes=jnp.transpose(members, (0, 3, 2, 1)).reshape(n_blocks, n_modes, n_comp * b),
        index=index.astype(jnp.int32),
        centres=jnp.transpose(centre_shape, (2, 1, 0)),
        radius=radius,
        slot=slot,
    )
