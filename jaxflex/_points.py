"""Choosing monitored points: the preprint's voxel downsampling plus always-kept key points.

Per voxel (a cube of edge ``voxel_size_m``) the mesh node nearest the voxel centre is kept;
then nodes closer than ``min_distance_m`` to an already kept node are dropped (key points
first, so they always survive). Key points (weld spots, clamp locations) are given as
coordinates and snapped to the nearest node.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from jaxflex._scalars import check_positive
from jaxflex.errors import InputError


def _as_points(name: str, points) -> np.ndarray:
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        raise InputError(f"{name}: expected shape (N, 3) with N >= 1 (m), got {arr.shape}")
    if not np.isfinite(arr).all():
        raise InputError(f"{name}: coordinates must be finite")
    return arr


def snap_key_points(nodes: np.ndarray, key_points, tolerance_m: float) -> np.ndarray:
    """Indices of the nodes nearest to ``key_points`` (Kk, 3); each must lie within
    ``tolerance_m`` of a node (else it is probably not on the part)."""
    keys = _as_points("key_points", key_points)
    distance, index = cKDTree(nodes).query(keys)
    far = distance > tolerance_m
    if far.any():
        i = int(np.argmax(far))
        raise InputError(
            f"key_points: point {i} at {keys[i].tolist()} m is {distance[i]:.4g} m from the "
            f"nearest node (tolerance {tolerance_m:.4g} m); is it on the part?"
        )
    return index


def voxel_downsample(
    nodes,
    voxel_size_m: float,
    *,
    min_distance_m: float | None = None,
    key_points=None,
    key_tolerance_m: float | None = None,
) -> np.ndarray:
    """Indices (sorted, unique) of the representative nodes of ``nodes`` (N, 3) in m.

    ``min_distance_m`` defaults to half the voxel size; ``key_points`` (Kk, 3) are always kept
    (snapped to the nearest node within ``key_tolerance_m``, default one voxel size).
    """
    nodes = _as_points("nodes", nodes)
    voxel = check_positive("voxel_size_m", voxel_size_m)
    min_distance = 0.5 * voxel if min_distance_m is None else float(min_distance_m)
    if min_distance < 0:
        raise InputError(f"min_distance_m: must be >= 0, got {min_distance_m}")
    origin = nodes.min(axis=0)
    cell = np.floor((nodes - origin) / voxel).astype(np.int64)
    centre = origin + (cell + 0.5) * voxel
    dist = np.linalg.norm(nodes - centre, axis=1)
    _, cell_id = np.unique(cell, axis=0, return_inverse=True)
    cell_id = cell_id.ravel()
    order = np.lexsort((np.arange(len(nodes)), dist, cell_id))
    first = np.ones(len(order), dtype=bool)
    first[1:] = cell_id[order][1:] != cell_id[order][:-1]
    candidates = order[first]

    keys = np.empty(0, dtype=np.int64)
    if key_points is not None and len(np.atleast_1d(key_points)):
        tol = (
            voxel if key_tolerance_m is None else check_positive("key_tolerance_m", key_tolerance_m)
        )
        keys = np.unique(snap_key_points(nodes, key_points, tol))
    ranked = np.concatenate([keys, candidates[~np.isin(candidates, keys)]])
    if min_distance == 0:
        return np.unique(ranked)
    tree = cKDTree(nodes[ranked])
    removed = np.zeros(len(ranked), dtype=bool)
    for i in range(len(ranked)):
        if removed[i]:
            continue
        for j in tree.query_ball_point(nodes[ranked[i]], min_distance * (1 - 1e-12)):
            if j > i and j >= len(keys):
                removed[j] = True
    return np.sort(ranked[~removed])


def downsample_to_count(
    nodes, target: int, *, key_points=None, key_tolerance_m: float | None = None
) -> np.ndarray:
    """Voxel-downsample ``nodes`` to about ``target`` points (within 10 %, or the closest the
    voxel grid allows), keeping ``key_points``. Returns sorted node indices."""
    nodes = _as_points("nodes", nodes)
    if int(target) < 1:
        raise InputError(f"target: must be >= 1, got {target}")
    if target >= len(nodes):
        return np.arange(len(nodes))
    extent = float(np.linalg.norm(nodes.max(axis=0) - nodes.min(axis=0))) or 1.0
    tol = key_tolerance_m if key_tolerance_m is not None else 0.05 * extent

    def count(voxel: float) -> np.ndarray:
        return voxel_downsample(nodes, voxel, key_points=key_points, key_tolerance_m=tol)

    lo, hi = extent * 1e-6, extent  # many points .. few points
    best = count(hi)
    for _ in range(60):
        mid = np.sqrt(lo * hi)
        picked = count(mid)
        if abs(len(picked) - target) < abs(len(best) - target):
            best = picked
        if abs(len(picked) - target) <= 0.1 * target:
            break
        if len(picked) > target:
            lo = mid
        else:
            hi = mid
    return best
