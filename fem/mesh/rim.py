"""Tensor-grid meshes whose nodes follow the cups' rims (no staircase around a clamped disc).

A rigid cup clamps its disc; on a plain tensor grid the clamped region is the set of cells
whose centre lies in the disc, a staircase whose boundary wanders by up to an element about
the rim, so frequencies and above all the stress at the rim (where the gravity stress of a
held sheet peaks) converge slowly and irregularly. Here each cup's neighbourhood is meshed
anew inside a box of the grid (an "O-grid"):

* the box: the grid lines around the cup at about ``BOX`` x its radius (the cells inside
  are replaced; the box's boundary nodes stay, so the mesh outside is untouched);
* the rim: one node per boundary node of the box, on the rim curve (the circle of the cup
  radius; on a curved surface the footprint curve of the points at 3-D distance ``radius``
  from the cup's surface point, which is what the surface formulations clamp), at the
  position the square-to-disc map gives the boundary node;
* the ring between the rim and the box: ``layers`` rings of quadrilaterals, graded towards
  the rim: the first ``RIM_LAYER`` x the fine spacing thick on every ray, the others growing
  geometrically to the box, so the elements next to the rim are thin, the stress there is
  sampled close to it, and the rim's neighbourhood scales with the spacing whatever the
  box's size (snapped to grid lines) is;
* the disc: the box's own cells scaled into a square of half side ``CORE`` x the radius, and
  one ring from it to the rim; every node there is held by the cup, so their shape only
  needs to be valid (no sliver: a compliant cup ties them to its pad, and a sliver's huge
  stiffness would leave round-off in the pad's rigid motion).

Everything scales with the grid's spacing (the ring count follows radius / fine spacing),
so meshes at h and 2 h are similar, as a Richardson estimate needs (fem.discretisation).
A cup too close to an edge or to another cup for a box that clears its rim keeps the
staircase (and is not listed among the rims).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fem.mesh.meshing import graded_count, grid_quads

BOX = 1.5  # the box's half side, x the cup radius (snapped outwards to grid lines)
CLEARANCE = 0.25  # the box's sides clear the rim by at least this x the fine spacing
RIM_LAYER = 0.15  # the ring at the rim is this x the fine spacing thick
LAYERS_PER_FINE = 1.5  # rings per fine spacing in a cup radius
CORE = 0.5  # the disc's core: the box's cells scaled into a square of half side CORE x radius
ANGLES = 720  # samples of the rim curve for the clearance check


@dataclass(frozen=True)
class Rim:
    """A cup's rim that the mesh follows: the surface point ``centre_m`` (3,) of the cup and
    its ``radius_m`` (3-D distance on the surface), m."""

    centre_m: np.ndarray
    radius_m: float

    def holds(self, centre_m: np.ndarray, radius_m: float) -> bool:
        """Whether a disc of ``radius_m`` around ``centre_m`` is this rim's (to rounding)."""
        tol = 1e-9 * max(self.radius_m, 1e-300)
        return abs(radius_m - self.radius_m) <= tol and bool(
            np.linalg.norm(np.asarray(centre_m) - self.centre_m) <= tol
        )


def ring_layers(radius_m: float, fine_m: float) -> int:
    """The rings between a rim and its box: LAYERS_PER_FINE x radius / fine spacing (at
    least 2), so that a mesh at twice the spacing has about half the rings."""
    return max(2, round(LAYERS_PER_FINE * radius_m / fine_m))


def ring_distances(width_m: np.ndarray, layers: int, first_m: float) -> np.ndarray:
    """(layers + 1, n) distances from the rim of the rings along n rays of ``width_m`` (n,)
    from the rim to the box: the first ring ``first_m`` thick on every ray, the next ones
    growing geometrically by the ray's own ratio so that the last reaches the box (found by
    bisection: first_m (1 + q + ... + q^(layers - 1)) = width, q in [1/4, 4]; the rings are
    then scaled to end at the box exactly)."""
    powers = np.arange(layers)[:, None]
    low, high = np.full(len(width_m), 0.25), np.full(len(width_m), 4.0)
    for _ in range(80):
        q = np.sqrt(low * high)
        short = first_m * np.sum(q[None] ** powers, axis=0) < width_m
        low, high = np.where(short, q, low), np.where(short, high, q)
    thickness = first_m * np.sqrt(low * high)[None] ** powers
    distances = np.concatenate([np.zeros((1, len(width_m))), np.cumsum(thickness, axis=0)])
    return distances * (width_m / distances[-1])[None]


def ring_cells(radius_m: float, size_m: float, fine_m: float) -> float:
    """About how many quadrilaterals the ring of a cup of ``radius_m`` adds on a grid of
    base ``size_m`` and ``fine_m`` at the cup (for fem.mesh.plan, before any meshing)."""
    side = 2 * BOX * radius_m
    per_side = graded_count(side, size_m, [(side / 2 - radius_m, side / 2 + radius_m)], fine_m)
    return 4 * per_side * ring_layers(radius_m, fine_m)


def _square_to_circle(square: np.ndarray) -> np.ndarray:
    """(n, 2) points of the unit circle of points (n, 2) on the boundary of [-1, 1]^2 (the
    elliptical grid map: nearly uniform in angle, corners at 45 degrees)."""
    a, b = square.T
    return np.column_stack([a * np.sqrt(1 - b**2 / 2), b * np.sqrt(1 - a**2 / 2)])


def _signed_areas(nodes: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(Q,) shoelace areas of quadrilaterals, m^2 (positive: counter-clockwise)."""
    x, y = nodes[quads, 0], nodes[quads, 1]
    return 0.5 * np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1)


def _box(x, y, centre, rim_m, fine_m, taken):
    """Grid indices (i0, i1, j0, j1) of the box around a cup, or None where none fits: its
    sides must clear the rim (footprint radii ``rim_m`` (ANGLES,)) by CLEARANCE x the fine
    spacing and its cells must not belong to another cup's box."""
    reach = BOX * float(rim_m.max())
    i0 = max(int(np.searchsorted(x, centre[0] - reach, "right")) - 1, 0)
    i1 = min(int(np.searchsorted(x, centre[0] + reach, "left")), len(x) - 1)
    j0 = max(int(np.searchsorted(y, centre[1] - reach, "right")) - 1, 0)
    j1 = min(int(np.searchsorted(y, centre[1] + reach, "left")), len(y) - 1)
    theta = np.linspace(0, 2 * np.pi, len(rim_m), endpoint=False)
    rim = centre + rim_m[:, None] * np.column_stack([np.cos(theta), np.sin(theta)])
    gap = min(
        (rim[:, 0] - x[i0]).min(),
        (x[i1] - rim[:, 0]).min(),
        (rim[:, 1] - y[j0]).min(),
        (y[j1] - rim[:, 1]).min(),
    )
    if gap < CLEARANCE * fine_m or i1 - i0 < 2 or j1 - j0 < 2 or taken[i0:i1, j0:j1].any():
        return None
    return i0, i1, j0, j1


def _boundary(i0, i1, j0, j1) -> tuple[np.ndarray, np.ndarray]:
    """Grid indices (i, j) of a box's boundary nodes, counter-clockwise from (i0, j0)."""
    i = np.concatenate(
        [np.arange(i0, i1), np.full(j1 - j0, i1), np.arange(i1, i0, -1), np.full(j1 - j0, i0)]
    )
    j = np.concatenate(
        [np.full(i1 - i0, j0), np.arange(j0, j1), np.full(i1 - i0, j1), np.arange(j1, j0, -1)]
    )
    return i, j


@dataclass
class _Builder:
    """The grid's nodes and quads being re-meshed around the cups."""

    x: np.ndarray
    y: np.ndarray
    nodes: np.ndarray
    quads: np.ndarray
    extra_nodes: list
    extra_quads: list

    @property
    def n_nodes(self) -> int:
        return len(self.nodes) + sum(len(n) for n in self.extra_nodes)

    def add(self, points: np.ndarray) -> np.ndarray:
        start = self.n_nodes
        self.extra_nodes.append(points)
        return np.arange(start, start + len(points))

    def follow(self, box, centre, rim_at, fine_m, radius_m) -> bool:
        """Re-mesh the cells of ``box`` (module docstring); False (nothing changed) where a
        cell would not be valid."""
        i0, i1, j0, j1 = box
        ny = len(self.y)
        half = np.array([(self.x[i1] - self.x[i0]) / 2, (self.y[j1] - self.y[j0]) / 2])
        middle = np.array([(self.x[i1] + self.x[i0]) / 2, (self.y[j1] + self.y[j0]) / 2])
        core_m = CORE * float(rim_at(np.linspace(0, 2 * np.pi, ANGLES)).min())
        bi, bj = _boundary(i0, i1, j0, j1)
        outer = bi * ny + bj
        square = (self.nodes[outer] - middle) / half  # the boundary of [-1, 1]^2
        unit = _square_to_circle(square)
        rim = centre + rim_at(np.arctan2(unit[:, 1], unit[:, 0]))[:, None] * unit
        ray = self.nodes[outer] - rim
        width = np.linalg.norm(ray, axis=1)
        layers = ring_layers(radius_m, fine_m)
        t = (ring_distances(width, layers, RIM_LAYER * fine_m) / width)[1:-1, :, None]
        points = [rim, *(rim[None] + t * ray[None]), centre + core_m * square]
        ii, jj = np.meshgrid(np.arange(i0 + 1, i1), np.arange(j0 + 1, j1), indexing="ij")
        inside = (ii * ny + jj).ravel()
        moved = centre + core_m * (self.nodes[inside] - middle) / half
        ci, cj = np.meshgrid(np.arange(i0, i1), np.arange(j0, j1), indexing="ij")
        cells = (ci * (ny - 1) + cj).ravel()
        m = len(outer)
        rings = [self.n_nodes + m * k + np.arange(m) for k in range(layers + 1)]
        remap = np.arange(self.n_nodes)
        remap[outer] = rings[-1]  # the core's boundary: the box's, scaled into the disc
        core = remap[self.quads[cells]]
        rings = [rings[-1], *rings[:-1], outer]  # core boundary, rim, rings, box
        ring_quads = np.concatenate(
            [
                np.column_stack([a, b, np.roll(b, -1), np.roll(a, -1)])
                for a, b in itertools.pairwise(rings)
            ]
        )
        trial = np.concatenate([self.nodes, *self.extra_nodes, *points])
        trial[inside] = moved
        if (_signed_areas(trial, core) <= 0).any() or (_signed_areas(trial, ring_quads) <= 0).any():
            return False
        for ring in points:
            self.add(ring)
        self.nodes[inside] = moved
        self.quads[cells] = core
        self.extra_quads.append(ring_quads)
        return True


def conforming_grid(
    x: np.ndarray,
    y: np.ndarray,
    discs: list[tuple[np.ndarray, float, float]],
    rim_radius: Callable[[int, np.ndarray], np.ndarray],
) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """The tensor grid x by y (grid lines, m) re-meshed around ``discs`` (footprint centre
    (2,), radius m, fine spacing m there each) so that its nodes follow their rims (module
    docstring). ``rim_radius(k, theta)`` is the footprint distance (m) of disc k's rim from
    its centre along the angles ``theta`` (the radius on a flat part).

    Returns the footprint nodes (N, 2), counter-clockwise quads (Q, 4) and the indices of
    the discs whose rims the mesh follows (the others keep the grid's staircase)."""
    nodes, quads = grid_quads(x, y)
    builder = _Builder(x, y, nodes, quads, [], [])
    taken = np.zeros((len(x) - 1, len(y) - 1), dtype=bool)
    theta = np.linspace(0, 2 * np.pi, ANGLES, endpoint=False)
    followed = []
    for k, (centre, radius_m, fine_m) in enumerate(discs):
        centre = np.asarray(centre, dtype=float)
        box = _box(x, y, centre, rim_radius(k, theta), fine_m, taken)
        if box is None:
            continue
        if builder.follow(box, centre, lambda a, k=k: rim_radius(k, a), fine_m, radius_m):
            i0, i1, j0, j1 = box
            taken[i0:i1, j0:j1] = True
            followed.append(k)
    all_nodes = np.concatenate([builder.nodes, *builder.extra_nodes])
    all_quads = np.concatenate([builder.quads, *builder.extra_quads])
    return all_nodes, all_quads, followed
