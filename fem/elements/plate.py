"""Kirchhoff plate (flat parts): Morley or Argyris triangles with scikit-fem.

Deflection w (m) along z; strain energy D/2 int [nu (lap w)^2 + (1 - nu) w_,ij w_,ij] dA with
D = E h^3 / (12 (1 - nu^2)); kinetic energy rho h/2 int w_t^2 dA (no rotary inertia).
Supports choose the DOFs they hold through :class:`PlateMeshDofs` (a suction cup clamps the
elements of its disc: deflection and slopes of their vertices and the normal slopes of their
edges; second derivatives of Argyris are left free, which would over-constrain the disc
boundary; a compliant cup ties the same DOFs to a rigid pad on springs instead).
:class:`PlateOutputs` gives the rigid motions as DOF vectors (exact: a linear function lies
in both element spaces) and the bending stress at the top surface, sigma = -z E/(1 - nu^2)
(w_xx + nu w_yy, ...) at z = +h/2 in every element centroid (Morley's curvature is constant
per element; the bottom surface carries the same stress with the opposite sign, so the same
von Mises stress).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import skfem
from skfem.helpers import dd, ddot, trace

from fem.elements.argyris import ElementTriArgyrisLocal
from fem.elements.rigid_fields import mass_field_loads
from fem.mesh.meshes import PlateMesh
from fem.supports import Support
from fem.system import Constraints, FESystem, Spring, mesh_stats
from jaxflex.errors import InputError
from jaxflex.runtime import progress_bar

ELEMENT_CLASSES = {"morley": skfem.ElementTriMorley, "argyris": ElementTriArgyrisLocal}
FORMULATION = {
    "morley": "Kirchhoff plate, Morley triangles (scikit-fem ElementTriMorley)",
    "argyris": "Kirchhoff plate, Argyris triangles (scikit-fem ElementTriArgyris, basis in "
    "element coordinates: fem.elements.argyris)",
}
CHUNK_ELEMENTS = 4000


def _forms(bending_nm: float, nu: float, mass_per_area: float):
    @skfem.BilinearForm
    def stiffness(u, v, _):
        return bending_nm * ((1 - nu) * ddot(dd(u), dd(v)) + nu * trace(dd(u)) * trace(dd(v)))

    @skfem.BilinearForm
    def mass(u, v, _):
        return mass_per_area * u * v

    return stiffness, mass


def assemble_plate(
    mesh: PlateMesh,
    element: str,
    material,
    thickness_m: float,
    supports: list[Support],
    progress=None,
) -> FESystem:
    """Assemble the plate and ask each of ``supports`` which DOFs it holds."""
    skmesh = skfem.MeshTri(mesh.nodes_xy.T.copy(), mesh.triangles.T.copy())
    elem = ELEMENT_CLASSES[element]()
    stiffness, mass = _forms(
        material.bending_stiffness_nm(thickness_m), material.nu, material.rho_kg_m3 * thickness_m
    )
    n_el = skmesh.t.shape[1]
    chunks = np.array_split(np.arange(n_el), max(1, int(np.ceil(n_el / CHUNK_ELEMENTS))))
    K = M = linear = None
    with progress_bar(
        len(chunks), f"assembly ({element}, {n_el} elements)", progress, unit="chunk"
    ) as bar:
        for chunk in chunks:
            part_basis = skfem.Basis(skmesh, elem, elements=chunk)
            k_part = stiffness.assemble(part_basis)
            m_part = mass.assemble(part_basis)
            K = k_part if K is None else K + k_part
            M = m_part if M is None else M + m_part
            if linear is None:
                linear = RigidFit(part_basis, element)
            linear.add(part_basis)
            bar.update(1)
    n_dof = K.shape[0]
    nodal = linear.nodal  # (n nodal dofs per vertex, N): u [, u_x, u_y, u_xx, u_xy, u_yy]
    facet_dofs = linear.facet_dofs  # u_n per edge
    rigid = np.zeros((n_dof, 3))
    rigid[nodal[0], 2] = 1.0
    nodes = np.column_stack([mesh.nodes_xy, np.full(len(mesh.nodes_xy), mesh.z0)])
    node_dofs = np.full((len(nodes), 3), -1, dtype=np.int64)
    node_dofs[:, 2] = nodal[0]
    outputs = PlateOutputs(
        skmesh, elem, element, nodal, facet_dofs, material, thickness_m, mesh.z0, linear.result()
    )
    dofs = PlateMeshDofs(skmesh, element, nodal, facet_dofs, outputs)
    lengths = np.linalg.norm(np.diff(skmesh.p[:, skmesh.facets], axis=1)[:, 0], axis=0)
    return FESystem.held_by(
        [s.hold_plate(dofs, i) for i, s in enumerate(supports)],
        K=K.tocsr(), M=M.tocsr(), rigid=rigid, nodes=nodes, node_dofs=node_dofs,
        cells=mesh.triangles.copy(), cell_type="triangle",
        stats=mesh_stats("triangle", skmesh.p.shape[1], n_el, n_dof, lengths),
        formulation=FORMULATION[element], outputs=outputs,
    )  # fmt: skip


class RigidFit:
    """The DOF vectors (n_dof, 3) of w = 1, x, y, made chunk by chunk from the assembly's own
    bases (a second basis of the whole mesh for them cost as much as the assembly's bases,
    3.6 of 51 s in a 2 % sizing of the plate): values at the vertices, gradients (Argyris),
    normal slopes on the edges. Each edge's normal slope (its sign is the element's
    convention) is solved from the first element next to it: the field of that element's
    other DOFs plus its three edge DOFs must be x (and y) at its quadrature points (a
    3-unknown least-squares fit, exact in exact arithmetic; an L2 projection of x over the
    whole mesh is ill-conditioned through the second-derivative DOFs). Chunks are runs of
    ascending elements, so an edge's first element is in the first chunk that has the edge,
    and every edge of a chunk is set once the chunk is fitted: the vectors are then checked
    there exactly (the fields they give must be 1, x and y at every quadrature point)."""

    def __init__(self, basis, element: str):
        self.nodal, self.facet_dofs = basis.nodal_dofs, basis.facet_dofs[0]
        p = basis.mesh.p
        self.scale = max(np.abs(p).max(), 1.0)
        self.out = np.zeros((basis.N, 3))
        self.out[self.nodal[0], 0] = 1.0
        self.out[self.nodal[0], 1:] = p.T
        if element == "argyris":
            self.out[self.nodal[1], 1] = self.out[self.nodal[2], 2] = 1.0
        self.is_edge = np.zeros(basis.N, dtype=bool)
        self.is_edge[self.facet_dofs] = True
        self.is_set = ~self.is_edge
        self.error = 0.0

    def add(self, basis) -> None:
        """Fit the edge slopes first met in the chunk of ``basis`` and check its elements."""
        element_dofs = basis.element_dofs  # (n_local, E)
        local_edge = np.flatnonzero(self.is_edge[element_dofs[:, 0]])
        known = np.setdiff1d(np.arange(element_dofs.shape[0]), local_edge)
        # local basis values at the quadrature points: (n_local, E, Q)
        values = np.stack([np.asarray(b[0].value) for b in basis.basis])
        edges, first = np.unique(element_dofs[local_edge].T, return_index=True)
        new = ~self.is_set[edges]
        edges, first = edges[new], first[new]
        x, y = np.asarray(basis.global_coordinates())  # (E, Q) each
        if edges.size:
            fits = np.linalg.pinv(values[local_edge].transpose(1, 2, 0))  # (E, 3, Q)
            for k, target in ((1, x), (2, y)):
                rest = target - np.einsum(
                    "le,leq->eq", self.out[element_dofs[known], k], values[known]
                )
                self.out[edges, k] = np.einsum("ejq,eq->ej", fits, rest).ravel()[first]
            self.is_set[edges] = True
        for k, target in enumerate((np.ones_like(x), x, y)):
            # the field on the chunk, (E, Q): what basis.interpolate sums, from the values
            # above (interpolate first splits the vector by np.unique over the whole mesh's
            # element DOFs, once per call: 27 of 104 s of CPU in a 2 % sizing of the plate)
            w = self.out[:, k]
            field = np.zeros_like(x)
            for i in range(element_dofs.shape[0]):
                field += w[element_dofs[i]][:, None] * values[i]
            self.error = max(self.error, np.abs(field - target).max() / self.scale)

    def result(self) -> np.ndarray:
        """The vectors, once every chunk is added: a wrong slope DOF misses by O(its element's
        size) (>= 1e-4 here); round-off is ~1e-12 on regular elements (fem.elements.argyris),
        up to 1.4e-8 on the slender elements of the rings around a cup (fem.mesh.rim;
        measured with 4.4 mm cup cells)."""
        if not self.is_set.all() or self.error > 1e-6:
            raise RuntimeError(f"plate rigid motions: 1, x, y are missed by {self.error:.1e}")
        return self.out


class PlateOutputs:
    """Rigid motions and surface stresses of the plate (fem.system.FormulationOutputs)."""

    moves_in_plane = False

    def __init__(self, mesh, elem, element, nodal, facet_dofs, material, thickness_m, z0, linear):
        self.mesh, self.elem, self.element = mesh, elem, element
        self.nodal, self.facet_dofs = nodal, facet_dofs
        self.material, self.thickness_m, self.z0 = material, thickness_m, z0
        self.linear = linear  # (n_dof, 3) the DOF vectors of w = 1, x, y (RigidFit)

    def linear_dofs(self) -> np.ndarray:
        """(n_dof, 3) DOF vectors of w = 1, x, y (:class:`RigidFit`, made at assembly)."""
        return self.linear

    def linear_fields(self, n_dof: int) -> np.ndarray:
        """(n_dof, 3, 3) the fields e_j r_i along z only (w = x, y or the mid-plane height
        z0; fem.system.RotationFields): a plate has no in-plane DOFs."""
        out = np.zeros((n_dof, 3, 3))
        ones, x, y = self.linear_dofs().T
        out[:, 0, 2], out[:, 1, 2], out[:, 2, 2] = x, y, self.z0 * ones
        return out

    inertia_loads = staticmethod(mass_field_loads)

    def couplings(self, phi: np.ndarray, mass_phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(G, P) of the modes ``phi`` (fem.system.RotationFields): the deflection w e_z
        turned about any axis is in the plane (G_k = 0), and e_k x (e_l x w e_z) has the z
        component (d_kz d_lz - d_kl) w, so P_kl = (d_kz d_lz - d_kl) phi^T M phi."""
        n = phi.shape[1]
        spin = np.einsum("kl,mn->klmn", np.diag([0.0, 0.0, 1.0]) - np.eye(3), phi.T @ mass_phi)
        return np.zeros((3, n, n)), spin

    def rigid_motion(self, centre_m: np.ndarray) -> np.ndarray:
        """(n_dof, 6): the deflection w of unit rigid motions; a plate has no DOFs for the
        translations along x, y and the rotation about z (zero columns)."""
        ones, x, y = self.linear_dofs().T
        xc, yc = float(centre_m[0]), float(centre_m[1])
        out = np.zeros((ones.size, 6))
        out[:, 2] = ones  # translation along z
        out[:, 3] = y - yc * ones  # rotation about x: w = (y - yc)
        out[:, 4] = -(x - xc * ones)  # rotation about y: w = -(x - xc)
        return out

    def surface_frame(
        self, x: float, y: float, z: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(point (3,) on the mid-surface above (x, y), unit normal (3,)), m (a flat plate:
        ``z`` changes nothing)."""
        return np.array([x, y, self.z0]), np.array([0.0, 0.0, 1.0])

    def stress_operator(self) -> tuple[np.ndarray, sp.csr_matrix]:
        """Stress at the top surface of every element centroid per unit DOF (module
        docstring): points (E, 3) m, sparse (6 E, n_dof) Pa."""
        centroid = skfem.Basis(
            self.mesh, self.elem, quadrature=(np.array([[1 / 3], [1 / 3]]), np.array([0.5]))
        )
        mat, h = self.material, self.thickness_m
        scale = -(h / 2) * mat.E_pa / (1 - mat.nu**2)
        nu = mat.nu
        n_el = self.mesh.t.shape[1]
        hess = np.array([field[0].hess[..., 0] for field in centroid.basis])  # (nb, 2, 2, E)
        voigt = np.zeros((hess.shape[0], 6, n_el))
        voigt[:, 0] = scale * (hess[:, 0, 0] + nu * hess[:, 1, 1])
        voigt[:, 1] = scale * (hess[:, 1, 1] + nu * hess[:, 0, 0])
        voigt[:, 5] = scale * (1 - nu) * hess[:, 0, 1]
        rows = 6 * np.arange(n_el)[None, None, :] + np.arange(6)[None, :, None]
        cols = np.broadcast_to(centroid.element_dofs[:, None, :], voigt.shape)
        operator = sp.csr_matrix(
            (voigt.ravel(), (np.broadcast_to(rows, voigt.shape).ravel(), cols.ravel())),
            shape=(6 * n_el, centroid.N),
        )
        xy = self.mesh.p[:, self.mesh.t].mean(axis=1).T
        points = np.column_stack([xy, np.full(n_el, self.z0 + h / 2)])
        return points, operator


class PlateMeshDofs:
    """The plate's DOF numbering as supports see it (fem.supports.PlateDofs): scikit-fem
    mesh, element name, ``nodal`` (rows u [, u_x, u_y, u_xx, u_xy, u_yy], N vertices),
    ``facet_dofs`` (normal slope u_n per edge) and the plate's outputs (rigid motions)."""

    def __init__(
        self, mesh: skfem.MeshTri, element: str, nodal, facet_dofs, outputs: PlateOutputs
    ) -> None:
        self.mesh, self.element = mesh, element
        self.nodal, self.facet_dofs = nodal, facet_dofs
        self.outputs = outputs

    @property
    def centroids_xy(self) -> np.ndarray:
        """(E, 2) element centroids, m."""
        return self.mesh.p[:, self.mesh.t].mean(axis=1).T

    def nearest_vertex(self, x: float, y: float) -> int:
        """Index of the mesh vertex nearest to (x, y) m."""
        p = self.mesh.p
        return int(np.argmin(np.hypot(p[0] - x, p[1] - y)))

    def _element_dofs(self, held: np.ndarray) -> np.ndarray:
        """Deflection and slopes at the vertices of the elements of the mask ``held`` (E,)
        (not the second derivatives of Argyris), normal slopes on their edges."""
        vertices = np.unique(self.mesh.t[:, held])
        rows = (0, 1, 2) if self.element == "argyris" else (0,)
        dofs = [self.nodal[r, vertices] for r in rows]
        dofs.append(self.facet_dofs[np.unique(self.mesh.t2f[:, held])])
        return np.concatenate(dofs)

    def clamp_elements(self, held: np.ndarray) -> Constraints:
        """Clamp the elements of the mask ``held`` (E,): deflection and slopes at their
        vertices (second derivatives of Argyris are left free, which would over-constrain the
        boundary of the region), normal slopes on their edges."""
        return Constraints(fixed=self._element_dofs(held))

    def spring_elements(
        self, held: np.ndarray, centre_xy: tuple[float, float], axial_n_m: float, tilt_nm_rad: float
    ) -> Constraints:
        """Tie the DOFs :meth:`clamp_elements` would hold to a rigid pad (deflection and two
        tilts about ``centre_xy``) on an axial spring (N/m) and two tilt springs (N m/rad)."""
        dofs = self._element_dofs(held)
        centre = np.array([centre_xy[0], centre_xy[1], 0.0])
        motions = self.outputs.rigid_motion(centre)[dofs][:, [2, 3, 4]]
        frame = np.eye(6)[:, [2, 3, 4]]
        stiffness = np.array([axial_n_m, tilt_nm_rad, tilt_nm_rad], dtype=np.float64)
        centre[2] = self.outputs.z0
        return Constraints(springs=[Spring(dofs, motions, stiffness, frame, centre)])

    def pin_vertices(self, vertices) -> Constraints:
        """Hold the deflection (not the slopes) at ``vertices``."""
        return Constraints(fixed=self.nodal[0, np.asarray(vertices)])

    def hold_side(self, side: str, *, clamped: bool) -> Constraints:
        """Deflection held along a side (fem.supports.SIDES); ``clamped``: the normal slope
        too."""
        skmesh, nodal = self.mesh, self.nodal
        facets = _side_facets(skmesh, side)
        vertices = np.unique(skmesh.facets[:, facets])
        out = [nodal[0, vertices]]
        if clamped:
            out.append(self.facet_dofs[facets])
        if self.element == "argyris":
            out.extend(_argyris_edge_dofs(skmesh, nodal, facets, clamped))
        return Constraints(fixed=np.concatenate(out))


def _side_facets(skmesh, side: str) -> np.ndarray:
    boundary = skmesh.boundary_facets()
    if side == "all":
        return boundary
    mid = skmesh.p[:, skmesh.facets[:, boundary]].mean(axis=1)
    axis = 0 if side[0] == "x" else 1
    target = skmesh.p[axis].min() if side[1] == "0" else skmesh.p[axis].max()
    tol = 1e-6 * np.ptp(skmesh.p, axis=1).max()
    picked = boundary[np.abs(mid[axis] - target) <= tol]
    if picked.size == 0:
        raise InputError(f"edge support side {side!r}: no boundary edge of the part lies there")
    return picked


def _argyris_edge_dofs(skmesh, nodal, facets, clamped: bool) -> list[np.ndarray]:
    """Argyris: w = 0 along an edge also holds the tangential first and second derivatives
    at its vertices (clamped: all first derivatives and the cross derivative as well);
    index rows of ``nodal``: 0 u, 1 u_x, 2 u_y, 3 u_xx, 4 u_xy, 5 u_yy."""
    d = np.diff(skmesh.p[:, skmesh.facets[:, facets]], axis=1)[:, 0]
    length = np.hypot(d[0], d[1])
    along_x = np.abs(d[1]) <= 1e-9 * length
    along_y = np.abs(d[0]) <= 1e-9 * length
    if not (along_x | along_y).all():
        raise InputError(
            "edge supports with element='argyris' need straight edges along x or y; use "
            "element='morley' for other outlines"
        )
    out = []
    for mask, rows in ((along_x, (1, 3, 2, 4)), (along_y, (2, 5, 1, 4))):
        verts = np.unique(skmesh.facets[:, facets[mask]])
        if verts.size == 0:
            continue
        held = rows if clamped else rows[:2]
        out.extend(nodal[r, verts] for r in held)
    return out
