"""One-layer thin solid of 27-node hexahedra (ElementHex2) with a vectorised assembly.

The quadrilateral mid-surface is made quadratic (vertices, edge mid-nodes, centres: the
``surface nodes``) and extruded along the unit normals to three layers s = -h/2, 0, +h/2,
so hexahedral node (layer l, surface node k) = l * Ns + k sits at S_k + (l - 1) h/2 n_k.
Stiffness and consistent mass use 3 x 3 x 3 Gauss points (full integration); the element
matrices are computed for blocks of elements at once with einsum, with scikit-fem's
ElementHex2 shape functions (its generic assembly of the same forms is ~20x slower).
Displacements are reported at the mid-surface nodes (layer 1). :class:`SolidOutputs` gives
the rigid motions as nodal DOF vectors and the stress tensor at the centres of every
element's bottom and top faces (the part's two surfaces).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import skfem

from fem.elements.assembly import assemble
from fem.elements.rigid_fields import mass_field_loads
from fem.elements.sides import side_nodes
from fem.mesh.meshes import SurfaceMesh
from fem.supports import Support
from fem.system import (
    Constraints,
    FESystem,
    Spring,
    mesh_stats,
    rigid_motions,
    rigid_translations,
)
from jaxflex.errors import InputError

FORMULATION = (
    "thin solid, one layer of 27-node hexahedra (ElementHex2 shape functions), "
    "full 3x3x3 Gauss integration, vectorised assembly"
)
CHUNK_ELEMENTS = 256

# local surface slot of each of ElementHex2's 27 nodes: corners A B C D, edge mid-nodes AB BC
# CD DA, centre; and its layer (reference coordinate zeta = 0, 1/2, 1 -> layer 0, 1, 2)
_SLOT = {
    (0.0, 0.0): 0, (1.0, 0.0): 1, (1.0, 1.0): 2, (0.0, 1.0): 3,
    (0.5, 0.0): 4, (1.0, 0.5): 5, (0.5, 1.0): 6, (0.0, 0.5): 7, (0.5, 0.5): 8,
}  # fmt: skip
_REF = skfem.ElementHex2.doflocs
LOCAL_SLOT = np.array([_SLOT[(float(x), float(y))] for x, y, _ in _REF])
LOCAL_LAYER = np.rint(2 * _REF[:, 2]).astype(np.int64)


def _gauss_3x3x3() -> tuple[np.ndarray, np.ndarray]:
    g, w = np.polynomial.legendre.leggauss(3)
    g, w = (g + 1) / 2, w / 2  # reference cube [0, 1]^3
    points = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1)
    weights = np.einsum("i,j,k->ijk", w, w, w).ravel()
    return points, weights


def _reference_basis():
    points, weights = _gauss_3x3x3()
    elem = skfem.ElementHex2()
    values, grads = zip(*(elem.lbasis(points, i) for i in range(27)), strict=True)
    return np.array(values), np.array(grads), weights  # (27, Q), (27, 3, Q), (Q,)


class Hex2Layer:
    """Quadratic surface nodes of a quad mid-surface and the extruded 27-node elements."""

    def __init__(self, surface: SurfaceMesh, thickness_m: float):
        nodes, quads = surface.nodes, surface.quads
        n_vert = len(nodes)
        pairs = np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2)
        edges, edge_index = np.unique(np.sort(pairs, axis=1), axis=0, return_inverse=True)
        quad_edges = edge_index.reshape(-1, 4)  # AB BC CD DA
        n_edge = len(edges)
        self.edges = edges
        self.boundary_edges = np.flatnonzero(np.bincount(edge_index.ravel(), minlength=n_edge) == 1)
        self.n_vertices = n_vert
        self.surface_of_quad = np.column_stack(
            [quads, n_vert + quad_edges, n_vert + n_edge + np.arange(len(quads))]
        )  # (E, 9) in quad9 order
        if surface.exact is not None and surface.params is not None:
            uv = surface.params
            mid_uv = np.concatenate([uv[edges].mean(axis=1), uv[quads].mean(axis=1)])
            extra_points, extra_normals = surface.exact(mid_uv)
            normals = np.concatenate([surface.normals, extra_normals])
        else:
            extra_points = np.concatenate([nodes[edges].mean(axis=1), nodes[quads].mean(axis=1)])
            normals = _mitre_offsets(
                nodes, quads, self.surface_of_quad, n_vert + n_edge + len(quads)
            )
        self.surface_points = np.concatenate([nodes, extra_points])  # (Ns, 3)
        self.surface_normals = normals
        self.n_surface = len(self.surface_points)
        self.thickness_m = thickness_m
        offsets = (np.arange(3) - 1) * thickness_m / 2
        self.points = (
            self.surface_points[None] + offsets[:, None, None] * self.surface_normals[None]
        ).reshape(-1, 3)  # (3 Ns, 3)
        self.element_nodes = (
            LOCAL_LAYER[None] * self.n_surface + self.surface_of_quad[:, LOCAL_SLOT]
        )  # (E, 27) in ElementHex2 order

    def layers_of(self, surface_nodes: np.ndarray) -> np.ndarray:
        """Hexahedral node indices of all three layers above ``surface_nodes`` (flat)."""
        return (np.arange(3)[:, None] * self.n_surface + np.asarray(surface_nodes)[None]).ravel()


def _mitre_offsets(nodes, quads, surface_of_quad, n_surface: int) -> np.ndarray:
    """(Ns, 3) extrusion directions of the surface nodes of a mesh-defined mid-surface: per
    node the least-squares m with m . n_f = 1 for the normals n_f of the quads around it, so
    the layer keeps its thickness on each face at a fold (a mitre: length 1/cos(half the
    fold angle)); on a smooth surface the unit normal up to O(angle^2). Directions whose
    spread is below 1e-3 of the largest (smooth curvature) are left out of the solve."""
    a, b, c, d = (nodes[quads[:, k]] for k in range(4))
    face = np.cross(c - a, d - b)
    face /= np.linalg.norm(face, axis=1, keepdims=True)
    gram = np.zeros((n_surface, 3, 3))
    rhs = np.zeros((n_surface, 3))
    outer = np.einsum("ei,ej->eij", face, face)
    for slot in range(9):
        np.add.at(gram, surface_of_quad[:, slot], outer)
        np.add.at(rhs, surface_of_quad[:, slot], face)
    values, vectors = np.linalg.eigh(gram)
    keep = values > 1e-3 * values[:, -1:]
    coeff = np.where(keep, np.einsum("nki,nk->ni", vectors, rhs) / np.where(keep, values, 1), 0)
    return np.einsum("nki,ni->nk", vectors, coeff)


def element_matrices(coords: np.ndarray, lam: float, mu: float, rho: float, basis=None):
    """Stiffness and mass matrices (E, 81, 81) of 27-node hexahedra at coords (E, 27, 3) m;
    local DOF 3 a + i is node a, direction i. Isotropic: lam, mu in Pa, rho in kg/m^3."""
    values, grads, weights = basis or _reference_basis()
    jac = np.einsum("eai,ajq->eqij", coords, grads)  # dx_i / dxi_j
    det = np.linalg.det(jac)
    if (det <= 0).any():
        raise InputError(
            "mesh: inverted or degenerate thin-solid element (check the surface normals and "
            "that the thickness is small against the element size and curvature radius)"
        )
    inv = np.linalg.inv(jac)
    grad = np.einsum("ajq,eqji->eqai", grads, inv)  # dN_a / dx_i
    wdet = det * weights
    s = np.einsum("eq,eqai,eqbj->eaibj", wdet, grad, grad, optimize=True)
    eye = np.eye(3)
    k = lam * s + mu * s.transpose(0, 1, 4, 3, 2)
    k += mu * np.einsum("eakbk->eab", s)[:, :, None, :, None] * eye[None, None, :, None, :]
    m = rho * np.einsum("eq,aq,bq->eab", wdet, values, values)
    m = m[:, :, None, :, None] * eye[None, None, :, None, :]
    n = coords.shape[0]
    return k.reshape(n, 81, 81), m.reshape(n, 81, 81)


def assemble_solid(
    surface: SurfaceMesh, part, supports: list[Support], progress=None
) -> tuple[FESystem, Hex2Layer]:
    """Assemble the thin solid of ``part`` on ``surface`` and ask each of ``supports`` which
    DOFs it holds."""
    layer = Hex2Layer(surface, part.thickness_m)
    mat = part.material
    n_el = len(layer.element_nodes)
    n_dof = 3 * len(layer.points)
    basis = _reference_basis()

    def compute(chunk):
        return element_matrices(
            layer.points[layer.element_nodes[chunk]],
            mat.lame_lambda_pa,
            mat.shear_modulus_pa,
            mat.rho_kg_m3,
            basis,
        )

    # sparsity at node level: 3x3 blocks per pair of nodes sharing an element
    K, M = assemble(
        layer.element_nodes,
        len(layer.points),
        3,
        compute,
        chunk_size=CHUNK_ELEMENTS,
        label=f"assembly (hex2, {n_el} elements)",
        progress=progress,
    )
    mid = np.arange(layer.n_surface) + layer.n_surface
    node_dofs = 3 * mid[:, None] + np.arange(3)
    lengths = np.linalg.norm(np.diff(surface.nodes[layer.edges], axis=1)[:, 0], axis=1)
    stats = mesh_stats("hexahedron27 (one layer)", len(layer.points), n_el, n_dof, lengths)
    outputs = SolidOutputs(layer, part)
    dofs = Hex2LayerDofs(layer, part, outputs)
    system = FESystem.held_by(
        [s.hold_solid(dofs, i) for i, s in enumerate(supports)],
        K=K, M=M, rigid=rigid_translations(n_dof, 3), nodes=layer.surface_points.copy(),
        node_dofs=node_dofs, cells=layer.surface_of_quad, cell_type="quad9", stats=stats,
        formulation=FORMULATION, outputs=outputs,
    )  # fmt: skip
    return system, layer


class SolidOutputs:
    """Rigid motions and surface stresses of the thin solid (fem.system.FormulationOutputs)."""

    moves_in_plane = True

    def __init__(self, layer: Hex2Layer, part) -> None:
        self.layer, self.part = layer, part

    def rigid_motion(self, centre_m: np.ndarray) -> np.ndarray:
        """(n_dof, 6): u = t + theta x (x - centre) at every node, t and theta unit vectors."""
        return rigid_motions(self.layer.points, centre_m).reshape(-1, 6)

    def linear_fields(self, n_dof: int) -> np.ndarray:
        """(n_dof, 3, 3) the fields e_j r_i: their values at every node (translations only;
        fem.system.RotationFields)."""
        out = np.zeros((n_dof, 3, 3))
        for j in range(3):
            out[j::3, :, j] = self.layer.points
        return out

    inertia_loads = staticmethod(mass_field_loads)

    def couplings(self, phi: np.ndarray, mass_phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(G, P) of the modes ``phi`` (fem.system.RotationFields): X_k turns each node's
        translation (the shape functions are the same for the three components, so this is
        exact for the field)."""
        vectors = phi.reshape(-1, 3, phi.shape[1])  # (nodes, 3, M)

        def turned(k: int, v: np.ndarray) -> np.ndarray:  # e_k x v for every vector
            return np.cross(np.eye(3)[k][None, :, None], v, axis=1)

        crossed = [turned(k, vectors) for k in range(3)]
        gyroscopic = np.stack([mass_phi.T @ c.reshape(phi.shape) for c in crossed])
        spin = np.stack(
            [
                np.stack([mass_phi.T @ turned(k, c).reshape(phi.shape) for c in crossed])
                for k in range(3)
            ]
        )
        return gyroscopic, spin

    def surface_frame(
        self, x: float, y: float, z: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(point (3,) on the mid-surface above (x, y) or nearest to (x, y, z), unit normal
        (3,)): the exact surface point and the normal of the nearest mid-surface node."""
        centre = self.part.surface_point([[x, y] if z is None else [x, y, z]])[0]
        k = int(np.argmin(np.linalg.norm(self.layer.surface_points - centre, axis=1)))
        return centre, self.layer.surface_normals[k].copy()

    def stress_operator(self) -> tuple[np.ndarray, sp.csr_matrix]:
        """Stress at the centres of the bottom and top faces of every element per unit DOF:
        points (2 E, 3) m (element e: rows 2 e and 2 e + 1), sparse (12 E, n_dof) Pa."""
        layer, mat = self.layer, self.part.material
        elem = skfem.ElementHex2()
        ref = np.array([[0.5, 0.5], [0.5, 0.5], [0.0, 1.0]])  # bottom and top face centres
        values = np.array([elem.lbasis(ref, i)[0] for i in range(27)])  # (27, 2)
        grads = np.array([elem.lbasis(ref, i)[1] for i in range(27)])  # (27, 3, 2)
        coords = layer.points[layer.element_nodes]  # (E, 27, 3)
        jac = np.einsum("eai,ajq->eqij", coords, grads)
        grad = np.einsum("ajq,eqji->eqai", grads, np.linalg.inv(jac))  # dN_a/dx_i (E, 2, 27, 3)
        lam, mu = mat.lame_lambda_pa, mat.shear_modulus_pa
        n_el = coords.shape[0]
        b = np.zeros((n_el, 2, 6, 27, 3))  # stress row, node, direction
        for i in range(3):
            b[:, :, i, :, i] += 2 * mu * grad[..., i]
            for j in range(3):
                b[:, :, j, :, i] += lam * grad[..., i]
        for row, (i, j) in zip((3, 4, 5), ((1, 2), (0, 2), (0, 1)), strict=True):
            b[:, :, row, :, i] += mu * grad[..., j]
            b[:, :, row, :, j] += mu * grad[..., i]
        rows = np.arange(12 * n_el).reshape(n_el, 2, 6)[..., None, None]
        cols = 3 * layer.element_nodes[:, None, None, :, None] + np.arange(3)
        shape = b.shape
        operator = sp.csr_matrix(
            (
                b.ravel(),
                (np.broadcast_to(rows, shape).ravel(), np.broadcast_to(cols, shape).ravel()),
            ),
            shape=(12 * n_el, 3 * len(layer.points)),
        )
        points = np.einsum("aq,eai->eqi", values, coords).reshape(-1, 3)
        return points, operator


class Hex2LayerDofs:
    """The thin solid's DOFs as supports see them (fem.supports.SolidDofs): DOF 3 n + i is
    direction i of hexahedral node n; a surface node stands for its three layers."""

    def __init__(self, layer: Hex2Layer, part, outputs: SolidOutputs) -> None:
        self.layer, self.part, self.outputs = layer, part, outputs

    @property
    def surface_points(self) -> np.ndarray:
        """(Ns, 3) mid-surface nodes, m (their footprint is the first two columns)."""
        return self.layer.surface_points

    def distance_m(self, x: float, y: float, z: float | None = None) -> np.ndarray:
        """(Ns,) 3-D distance of every mid-surface node from the surface point above (x, y)
        (nearest to (x, y, z))."""
        centre = self.part.surface_point([[x, y] if z is None else [x, y, z]])[0]
        return np.linalg.norm(self.surface_points - centre, axis=1)

    def nearest_vertex(self, x: float, y: float, z: float | None = None) -> int:
        """The mesh vertex (a mid-surface node) nearest to that surface point."""
        return int(np.argmin(self.distance_m(x, y, z)[: self.layer.n_vertices]))

    def disc_nodes(self, x: float, y: float, z: float | None, radius: float) -> np.ndarray:
        """Mid-surface nodes within ``radius`` (m) of that surface point (quadratic elements:
        vertices and mid-nodes resolve the rim to half an element)."""
        return np.flatnonzero(self.distance_m(x, y, z) <= radius * (1 + 1e-9))

    def _node_dofs(self, surface_nodes) -> np.ndarray:
        hexnodes = self.layer.layers_of(surface_nodes)
        return (3 * hexnodes[:, None] + np.arange(3)).ravel()

    def clamp_nodes(self, surface_nodes) -> Constraints:
        """Hold every displacement component through the thickness at ``surface_nodes``."""
        return Constraints(fixed=self._node_dofs(surface_nodes))

    def spring_nodes(
        self, surface_nodes, x: float, y: float, stiffness, z: float | None = None
    ) -> Constraints:
        """Tie the nodes :meth:`clamp_nodes` would hold to a rigid pad at the surface point
        above (x, y) (nearest to (x, y, z)) on springs ``stiffness`` (6,) along and about
        the pad's local axes (fem.system.Spring.on_pad)."""
        centre, normal = self.outputs.surface_frame(x, y, z)
        dofs = self._node_dofs(surface_nodes)
        motions = self.outputs.rigid_motion(centre)[dofs]
        return Constraints(springs=[Spring.on_pad(dofs, motions, centre, normal, stiffness)])

    def pin_nodes(self, surface_nodes) -> Constraints:
        """A pinned point of a one-layer solid holds its nodes through the thickness (the
        same as :meth:`clamp_nodes`; one node alone would be a point load singularity)."""
        return self.clamp_nodes(surface_nodes)

    def hold_side(self, side: str, *, clamped: bool) -> Constraints:
        """Clamp a side (fem.supports.SIDES), or hold the normal and the along-edge
        displacement there (simple support; two tangents at a sharp corner)."""
        layer = self.layer
        nodes, tangents = side_nodes(
            layer.surface_points,
            layer.edges[layer.boundary_edges],
            side,
            n_vertices=layer.n_vertices,
            mid_nodes=layer.n_vertices + layer.boundary_edges,
        )
        if clamped:
            return self.clamp_nodes(nodes)
        directions = []
        for k, held_tangents in zip(nodes, tangents, strict=True):
            held = np.vstack([layer.surface_normals[k], *held_tangents])
            for hexnode in layer.layers_of([k]):
                directions.append((3 * hexnode + np.arange(3), held))
        return Constraints(directions=directions)
