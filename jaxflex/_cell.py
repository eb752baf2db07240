"""The robot cell: obstacles, the part's pose at the start, the path, gravity.

Coordinates are the cell's (the robot's base frame), in m. The part's model lives in its own
frame (its points, shapes and participation factors); at the start of the move the part
frame's origin is at ``start_m`` and its axes are rotated by ``rotation`` (the robot carries
the part without rotating it), so the model in cell coordinates is
``model.posed(cell.rotation, cell.start_m)``. The move takes the part frame's origin from
``start_m`` through the via points to ``end_m``; accelerations are in cell coordinates.

Obstacles (each with a ``name``):

* :class:`Box`: centre, edge lengths, optional rotation; signed distance (negative inside);
* :class:`HalfSpace`: the solid side {x : normal . x <= offset_m} (a floor, a wall);
* :class:`TriangleMesh`: triangles (from a mesh file via meshio); the unsigned distance to
  the surface (a closed mesh is not treated as a volume: a point inside it far from every
  triangle is not detected, but a part cannot get inside without crossing the surface).

Every obstacle is convex or made of convex pieces (the triangles), and gives for a point its
distance and the closest obstacle point: the tangent plane there separates the point from
the piece, which is what the optimiser's linear rows use.

A cell file (TOML or JSON) is read by optim.cell_file into a :class:`Cell`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from jaxflex._scalars import check_positive
from jaxflex.errors import InputError

VIA_MODES = ("stop", "blend")
DEFAULT_GRAVITY_M_S2 = (0.0, 0.0, -9.81)


def _vector(owner: str, value, size: int = 3) -> np.ndarray:
    try:
        arr = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{owner}: expected {size} numbers, got {value!r}") from exc
    if arr.shape != (size,) or not np.isfinite(arr).all():
        raise InputError(f"{owner}: expected {size} finite numbers, got {value!r}")
    arr.setflags(write=False)
    return arr


def rotation_from_degrees(angles_deg) -> np.ndarray:
    """(3, 3) rotation: about x by angles[0], then about (fixed) y, then about z (degrees)."""
    ax, ay, az = np.radians(_vector("rotation_deg", angles_deg))
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


@dataclass(frozen=True, eq=False)
class Box:
    """A box: ``centre_m`` (3,), edge lengths ``size_m`` (3,) along its axes, which are the
    columns of ``rotation`` (3, 3; default the cell's)."""

    centre_m: np.ndarray
    size_m: np.ndarray
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    name: str = "box"

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre_m", _vector(f"{self.name}.centre_m", self.centre_m))
        size = _vector(f"{self.name}.size_m", self.size_m)
        if (size <= 0).any():
            raise InputError(f"{self.name}.size_m: every edge must be > 0 m, got {size.tolist()}")
        object.__setattr__(self, "size_m", size)
        r = np.asarray(self.rotation, dtype=np.float64)
        if r.shape != (3, 3) or not np.allclose(r @ r.T, np.eye(3), atol=1e-9):
            raise InputError(f"{self.name}.rotation: must be a 3 x 3 rotation matrix")
        object.__setattr__(self, "rotation", r)

    def closest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(signed distance (N,) m, closest boundary point (N, 3)) for points (N, 3)."""
        aligned = np.array_equal(self.rotation, np.eye(3))
        local = points - self.centre_m
        if not aligned:
            local = local @ self.rotation
        half = self.size_m / 2
        outside = np.abs(local) - half
        nearest = np.clip(local, -half, half)
        beyond = np.maximum(outside, 0.0)
        signed = np.sqrt(np.einsum("ij,ij->i", beyond, beyond))
        inside = np.flatnonzero((outside <= 0).all(axis=1))
        if inside.size:  # the nearest face, at minus its depth
            rows = np.arange(inside.size)
            face = np.argmax(outside[inside], axis=1)
            signed[inside] = outside[inside, face]
            on_face = local[inside]
            on_face[rows, face] = np.sign(on_face[rows, face]) * half[face]
            nearest[inside] = on_face
        if not aligned:
            nearest = nearest @ self.rotation.T
        return signed, nearest + self.centre_m

    def describe(self) -> dict:
        return {
            "type": "box",
            "name": self.name,
            "centre_m": self.centre_m.tolist(),
            "size_m": self.size_m.tolist(),
            "rotation": self.rotation.tolist(),
        }


@dataclass(frozen=True, eq=False)
class HalfSpace:
    """The solid region {x : normal . x <= offset_m}; ``normal`` (3,) points out of it."""

    normal: np.ndarray
    offset_m: float
    name: str = "half-space"

    def __post_init__(self) -> None:
        n = _vector(f"{self.name}.normal", self.normal)
        if np.linalg.norm(n) == 0:
            raise InputError(f"{self.name}.normal: must not be zero")
        unit = n / np.linalg.norm(n)
        unit.setflags(write=False)
        object.__setattr__(self, "normal", unit)
        offset = float(self.offset_m)
        if not math.isfinite(offset):
            raise InputError(f"{self.name}.offset_m: must be finite, got {self.offset_m!r}")
        object.__setattr__(self, "offset_m", offset)

    def closest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        signed = points @ self.normal - self.offset_m
        return signed, points - signed[:, None] * self.normal

    def describe(self) -> dict:
        return {
            "type": "half_space",
            "name": self.name,
            "normal": self.normal.tolist(),
            "offset_m": self.offset_m,
        }


def _closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Closest points (N, F, 3) on triangles (F, 3 each) to points (N, 3) (Ericson, Real-Time
    Collision Detection, 5.1.5: Voronoi regions of vertices, edges and the face)."""
    p = p[:, None, :]
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp = p - b
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    cp = p - c
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2

    def safe(num, den):
        return num / np.where(den == 0, 1.0, den)

    denom = va + vb + vc
    v, w = safe(vb, denom), safe(vc, denom)
    out = a + v[..., None] * ab + w[..., None] * ac  # face region
    # edges
    t_bc = safe(d4 - d3, (d4 - d3) + (d5 - d6))
    on_bc = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)
    out = np.where(on_bc[..., None], b + t_bc[..., None] * (c - b), out)
    t_ac = safe(d2, d2 - d6)
    on_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
    out = np.where(on_ac[..., None], a + t_ac[..., None] * ac, out)
    t_ab = safe(d1, d1 - d3)
    on_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
    out = np.where(on_ab[..., None], a + t_ab[..., None] * ab, out)
    # vertices
    out = np.where(((d6 >= 0) & (d5 <= d6))[..., None], c, out)
    out = np.where(((d3 >= 0) & (d4 <= d3))[..., None], b, out)
    out = np.where(((d1 <= 0) & (d2 <= 0))[..., None], a, out)
    return out


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    """Triangles ``vertices`` (V, 3) m, ``triangles`` (F, 3) vertex indices; unsigned distance."""

    vertices: np.ndarray
    triangles: np.ndarray
    name: str = "mesh"
    chunk: int = 256

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=np.float64)
        t = np.asarray(self.triangles, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3 or not np.isfinite(v).all():
            raise InputError(f"{self.name}.vertices: expected finite (V, 3) coordinates in m")
        if t.ndim != 2 or t.shape[1] != 3 or t.size == 0 or t.min() < 0 or t.max() >= len(v):
            raise InputError(f"{self.name}.triangles: expected (F, 3) indices into the vertices")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "triangles", t)

    def closest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        best = np.full(len(points), np.inf)
        nearest = np.zeros_like(points)
        corners = self.vertices[self.triangles]  # (F, 3, 3)
        for start in range(0, len(corners), self.chunk):
            tri = corners[start : start + self.chunk]
            near = _closest_on_triangles(points, tri[:, 0], tri[:, 1], tri[:, 2])
            dist = np.linalg.norm(near - points[:, None], axis=-1)
            j = np.argmin(dist, axis=1)
            d = dist[np.arange(len(points)), j]
            better = d < best
            best = np.where(better, d, best)
            nearest[better] = near[better, j[better]]
        return best, nearest

    def describe(self) -> dict:
        return {"type": "mesh", "name": self.name, "n_triangles": len(self.triangles)}


Obstacle = Box | HalfSpace | TriangleMesh


@dataclass(frozen=True)
class Via:
    """A via point of the path: ``position_m`` (3,) of the part frame's origin (cell
    coordinates); ``mode`` "stop" (pass it at rest) or "blend" (pass within ``tolerance_m``
    per axis, without stopping); ``rotation`` (3, 3) the part frame's axes there (columns,
    cell coordinates, as Cell.rotation at A), or None: the orientation is free there."""

    position_m: np.ndarray
    mode: str = "blend"
    tolerance_m: float = 0.0
    rotation: np.ndarray | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "position_m", _vector("via.position_m", self.position_m))
        if self.mode not in VIA_MODES:
            raise InputError(f"via.mode: must be one of {list(VIA_MODES)}, got {self.mode!r}")
        tol = float(self.tolerance_m)
        if not math.isfinite(tol) or tol < 0:
            raise InputError(f"via.tolerance_m: must be a finite number >= 0, got {tol!r}")
        if self.mode == "blend" and tol == 0:
            raise InputError("via.tolerance_m: a blended via point needs a tolerance > 0 m")
        object.__setattr__(self, "tolerance_m", tol)
        if self.rotation is not None:
            r = np.asarray(self.rotation, dtype=np.float64)
            orthonormal = r.shape == (3, 3) and np.allclose(r @ r.T, np.eye(3), atol=1e-9)
            if not (orthonormal and np.linalg.det(r) > 0):
                raise InputError("via.rotation: must be a 3 x 3 rotation matrix (or None)")
            object.__setattr__(self, "rotation", r)

    def describe(self) -> dict:
        rotation = {} if self.rotation is None else {"rotation": self.rotation.tolist()}
        return {
            "position_m": self.position_m.tolist(),
            "mode": self.mode,
            "tolerance_m": self.tolerance_m,
            **rotation,
        }


@dataclass(frozen=True, eq=False)
class Cell:
    """The cell (module docstring). ``obstacles``: Box, HalfSpace, TriangleMesh; ``start_m``,
    ``end_m`` (3,) the part frame's origin at A and B; ``rotation`` (3, 3) its axes;
    ``via``: Via points; ``gravity_m_s2`` (3,) in cell coordinates; ``thickness_m``: the
    sheet's thickness (m) where the model does not state it (None: the model's)."""

    obstacles: tuple = ()
    start_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    end_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    via: tuple = ()
    gravity_m_s2: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_GRAVITY_M_S2))
    thickness_m: float | None = None

    def __post_init__(self) -> None:
        if self.thickness_m is not None:
            object.__setattr__(
                self, "thickness_m", check_positive("cell.part.thickness_m", self.thickness_m)
            )
        for name in ("start_m", "end_m", "gravity_m_s2"):
            object.__setattr__(self, name, _vector(f"cell.{name}", getattr(self, name)))
        r = np.asarray(self.rotation, dtype=np.float64)
        if r.shape != (3, 3) or not np.allclose(r @ r.T, np.eye(3), atol=1e-9):
            raise InputError("cell.rotation: must be a 3 x 3 rotation matrix")
        object.__setattr__(self, "rotation", r)
        for i, o in enumerate(self.obstacles):
            if not isinstance(o, Box | HalfSpace | TriangleMesh):
                raise InputError(
                    f"cell.obstacles[{i}]: expected Box, HalfSpace or TriangleMesh, got "
                    f"{type(o).__name__}"
                )
        for i, v in enumerate(self.via):
            if not isinstance(v, Via):
                raise InputError(f"cell.via[{i}]: expected Via, got {type(v).__name__}")
        object.__setattr__(self, "obstacles", tuple(self.obstacles))
        object.__setattr__(self, "via", tuple(self.via))
        if not np.any(self.end_m - self.start_m) and not self.via:
            raise InputError("cell.end_m: the move has zero length (end_m equals start_m)")

    @property
    def distance_m(self) -> np.ndarray:
        """(3,) the move from A to B, m."""
        return self.end_m - self.start_m

    def via_offsets(self) -> list[tuple[np.ndarray, str, float]]:
        """Via points relative to the start: (offset (3,) m, mode, tolerance m)."""
        return [(v.position_m - self.start_m, v.mode, v.tolerance_m) for v in self.via]

    def posed(self, model):
        """``model`` in cell coordinates at the start of the move (jaxflex.ModalModel.posed)."""
        return model.posed(self.rotation, self.start_m)

    def describe(self) -> dict:
        return {
            "start_m": self.start_m.tolist(),
            "end_m": self.end_m.tolist(),
            "rotation": self.rotation.tolist(),
            "via": [v.describe() for v in self.via],
            "gravity_m_s2": self.gravity_m_s2.tolist(),
            "thickness_m": self.thickness_m,
            "obstacles": [o.describe() for o in self.obstacles],
        }
