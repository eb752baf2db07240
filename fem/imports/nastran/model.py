"""A Nastran deck as one finite-element model with six DOFs per grid (SI units): its shells
(flat facets of our shell), beams, rods, springs, bushings, gaps, shear panels and masses
assembled in basic axes, its sheet as a fem part (where cups sit and what the model
reports), and the outputs (cup reactions, surface stresses) of fem.outputs.

The grids of the model are the shells' corner grids (first: they are the part's nodes,
where displacements are monitored), then the grids of the other elements and of the rigid
elements and MPCs. Element matrices are computed in the deck's units and converted once:
K_SI = m L^2 D K D, M_SI = WTMASS m L^2 D M D (m, L the unit system's mass and length in
kg and m, D = 1/L on translations, 1 on rotations: energy m L^2 s^-2 per deck unit).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from fem.elements.assembly import assemble
from fem.elements.rigid_fields import mass_field_loads, six_dof_fields
from fem.elements.shell import ShellLayer, ShellMeshDofs, ShellOutputs, surface_stress
from fem.elements.shell_element import local_frames
from fem.imports.nastran.bdf import BulkData
from fem.imports.nastran.beam_sections import BeamSections
from fem.imports.nastran.connectors import Patches, connectors
from fem.imports.nastran.constraints import DeckConstraints
from fem.imports.nastran.coords import DeckGeometry
from fem.imports.nastran.lines import LineElements, line_elements
from fem.imports.nastran.materials import Materials, ShellSection
from fem.imports.nastran.panels import shear_panels
from fem.imports.nastran.points import PointMatrices, point_matrices
from fem.imports.nastran.shells import (
    Facets,
    ShellSections,
    facet_matrices,
    facet_resultants,
    facets,
)
from fem.imports.nastran.solids import SolidElements, read_solids, solid_chunk
from fem.imports.units import Units
from fem.materials import Material
from fem.mesh.mesh_io import sheet_from_cells
from fem.mesh.meshes import ShellMesh
from fem.parts import part_from_mesh
from fem.system import mesh_stats, rigid_motions

FORMULATION = (
    "Nastran deck, 6 DOFs per grid: shell facets (DKT bending + ANDES OPT membrane, "
    "Kirchhoff), 12-DOF beams, springs, bushings, gaps, shear panels, fasteners and spot "
    "welds, masses, rigid elements and MPCs; consistent mass (shear panels: lumped)"
)
CHUNK_FACETS = 2000


@dataclass
class DeckParts:
    """The deck read into elements (deck units): shells as facets, lines, point elements,
    their sections, the model's grids (``grid_ids``, shell grids first, ``n_shell``)."""

    facets: Facets
    shell_sections: ShellSections
    lines: LineElements
    points: PointMatrices
    beam_sections: BeamSections
    materials: Materials
    grid_ids: np.ndarray
    n_shell: int
    index: dict[int, int]  # grid id -> node
    solids: list[SolidElements] = field(default_factory=list)
    solid_mass: sp.csr_matrix | None = None  # the solids' mass (6 N, 6 N), deck units


def read_parts(
    bulk: BulkData, geometry: DeckGeometry, shells, constraints: DeckConstraints, shell_sections
):
    """Every modelled element of the deck (fem.imports.nastran.scope decides what is modelled);
    ``shell_sections`` the deck's ShellSections (their Materials serve the beams too)."""
    materials = shell_sections.materials
    beam_sections = BeamSections(bulk, materials)
    lines = line_elements(bulk, geometry, beam_sections)
    points = point_matrices(bulk, geometry)
    shear_panels(bulk, geometry, materials, points)
    shell_grids = sorted({g for s in shells for g in s.grids})
    solids = read_solids(bulk, materials)
    others = {g for pair in lines.grids for g in pair} | {g for gs in points.grids for g in gs}
    others |= {int(g) for group in solids for g in group.grids.ravel()}
    others = sorted((others | constraints.grids) - set(shell_grids))
    grid_ids = np.array(shell_grids + others, dtype=np.int64)
    index = {int(g): i for i, g in enumerate(grid_ids)}
    shell_facets = facets(shells, shell_sections, geometry, index)
    nodes = np.array([geometry.positions[int(g)] for g in grid_ids])
    connectors(bulk, geometry, materials, Patches(shell_facets, nodes, grid_ids), points)
    return DeckParts(
        shell_facets,
        shell_sections,
        lines,
        points,
        beam_sections,
        materials,
        grid_ids,
        len(shell_grids),
        index,
        solids,
    )


def _assemble_blocks(nodes, k: np.ndarray, m: np.ndarray, n_nodes: int, label, progress):
    if not len(nodes):
        empty = sp.csr_matrix((6 * n_nodes, 6 * n_nodes))
        return empty, empty
    return assemble(
        nodes,
        n_nodes,
        6,
        lambda chunk: (k[chunk], m[chunk]),
        chunk_size=10_000,
        label=label,
        progress=progress,
    )


def assemble_deck(parts: DeckParts, geometry: DeckGeometry, unit: Units, wtmass: float, progress):
    """(K, M) of the whole model in basic axes, SI units (module docstring)."""
    n = len(parts.grid_ids)
    index = parts.index
    nodes = np.array([geometry.positions[int(g)] for g in parts.grid_ids])
    f = parts.facets
    K, M = assemble(
        f.triangles,
        n,
        6,
        lambda chunk: facet_matrices(f, parts.shell_sections, nodes, chunk),
        chunk_size=CHUNK_FACETS,
        label=f"assembly (deck, {len(f.triangles)} shell facets)",
        progress=progress,
    )
    k_lines, m_lines = parts.lines.matrices()
    line_nodes = np.array([[index[a], index[b]] for a, b in parts.lines.grids], dtype=np.int64)
    k_add, m_add = _assemble_blocks(
        line_nodes.reshape(-1, 2), k_lines, m_lines, n, "beams", progress
    )
    K, M = K + k_add, M + m_add
    for size in sorted({len(g) for g in parts.points.grids}):
        chosen = [i for i, g in enumerate(parts.points.grids) if len(g) == size]
        point_nodes = np.array([[index[g] for g in parts.points.grids[i]] for i in chosen])
        k_pts = np.array([parts.points.stiffness[i] for i in chosen])
        m_pts = np.array([parts.points.mass[i] for i in chosen])
        k_add, m_add = _assemble_blocks(
            point_nodes, k_pts, m_pts, n, "springs and masses", progress
        )
        K, M = K + k_add, M + m_add
    parts.solid_mass = sp.csr_matrix((6 * n, 6 * n))
    for group in parts.solids:
        k_add, m_add = _solid_blocks(group, nodes, parts.index, n, progress)
        K, M = K + k_add, M + m_add
        parts.solid_mass = parts.solid_mass + m_add
    return to_si(K, unit), to_si(M, unit, wtmass)


def _solid_blocks(group: SolidElements, nodes: np.ndarray, index: dict, n: int, progress):
    """(K, M) (6 n, 6 n) of a group of solids: assembled on translations, placed on the
    grids' first three DOFs."""
    k3, m3 = assemble(
        np.vectorize(index.get)(group.grids),
        n,
        3,
        lambda chunk: solid_chunk(group, nodes, index, chunk),
        chunk_size=2000,
        label=f"assembly ({len(group.cards)} {group.kind})",
        progress=progress,
    )
    translations = (6 * np.arange(n)[:, None] + np.arange(3)).ravel()
    place = sp.csr_matrix((np.ones(3 * n), (translations, np.arange(3 * n))), shape=(6 * n, 3 * n))
    return place @ k3 @ place.T, place @ m3 @ place.T


def to_si(matrix: sp.spmatrix, unit: Units, wtmass: float = 1.0) -> sp.csr_matrix:
    """A stiffness (or, with ``wtmass``, mass) matrix of six DOFs per grid in SI units from
    the deck's (module docstring)."""
    n = matrix.shape[0] // 6
    d = sp.diags(np.tile(np.r_[np.full(3, 1 / unit.length_m), np.ones(3)], n))
    return (wtmass * unit.mass_kg * unit.length_m**2 * (d @ matrix @ d)).tocsr()


def representative(parts: DeckParts, mass_kg: float, unit: Units):
    """(thickness m, fem Material, the section) standing for the sheet in the part's
    description: the section over the largest area, its mean thickness, and the density
    that gives the part the model's mass (thickness x area x density = the mass)."""
    f = parts.facets
    pids, counts = np.unique(f.pid, return_counts=True)
    pid = int(pids[np.argmax(counts)])
    section: ShellSection = parts.shell_sections.read[pid]
    rows = f.pid == pid
    t_m = float(np.mean(f.t_mean[rows])) * unit.length_m
    a, _, d, _, _ = section.resultants(f.t_mean[rows][:1], f.t3_mean[rows][:1])
    a, d = a[0], d[0]
    if a[1, 1] > 0:
        e_file = (a[0, 0] - a[0, 1] ** 2 / a[1, 1]) / f.t_mean[rows][0]
        nu = a[0, 1] / a[1, 1]
    else:
        e_file = 12 * (d[0, 0] - d[0, 1] ** 2 / d[1, 1]) / f.t3_mean[rows][0]
        nu = d[0, 1] / d[1, 1]
    return t_m, e_file * unit.modulus_to_si, float(np.clip(nu, 0.0, 0.49)), section


def shell_cells(elements, triangles: np.ndarray, owner: np.ndarray, index: dict):
    """The cells of the sheet (fem.mesh.mesh_io.sheet_from_cells blocks, node indices by
    ``index``): linear elements by their corners, quadratic ones by their ``triangles``
    (F, 3) whose ``owner`` (F,) is the element."""
    tris, quads = [], []
    for element in elements:
        if not element.quadratic:
            corners = [index[g] for g in element.corners]
            (quads if len(corners) == 4 else tris).append(corners)
    quadratic = np.array([e.quadratic for e in elements], dtype=bool)
    tris.extend(triangles[quadratic[owner]].tolist())
    return [(k, np.array(c)) for k, c in (("triangle", tris), ("quad", quads)) if c]


def sheet_part(parts: DeckParts, geometry, unit: Units, path: str, mass_kg: float, name: str):
    """The fem part of the deck's shells (SI), and its ShellMesh (oriented facets)."""
    f = parts.facets
    xyz = np.array([geometry.positions[int(g)] for g in parts.grid_ids[: parts.n_shell]])
    xyz = xyz * unit.length_m
    blocks = shell_cells(f.elements, f.triangles, f.element, parts.index)
    sheet = sheet_from_cells(xyz, blocks, path, weld=False, max_extent_m=np.inf)
    thickness, e_pa, nu, _ = representative(parts, mass_kg, unit)
    area = sheet.area_m2
    rho = mass_kg / (thickness * area) if mass_kg > 0 and area > 0 else 1.0
    material = Material(f"deck (equivalent: {mass_kg:.4g} kg over the sheet)", e_pa, nu, rho)
    description = {"shape": "Nastran deck", "path": path}
    part = part_from_mesh(sheet, thickness, material, "shell", name, description)
    return part, ShellMesh(sheet.nodes, sheet.all_triangles())


class DeckOutputs:
    """Rigid motions and surface stresses of the deck model (fem.system.FormulationOutputs):
    every grid has six DOFs; stresses at the facets' bottom and top surfaces (the section's
    membrane and bending moduli A / t and 12 D / t^3, heights ZOFFS -+ t / 2)."""

    moves_in_plane = True

    def __init__(self, shell: ShellOutputs, nodes_m: np.ndarray, stress) -> None:
        self.shell, self.nodes_m, self._stress = shell, nodes_m, stress

    def rigid_motion(self, centre_m: np.ndarray) -> np.ndarray:
        out = np.zeros((len(self.nodes_m), 2, 3, 6))
        out[:, 0] = rigid_motions(self.nodes_m, centre_m)
        out[:, 1, :, 3:] = np.eye(3)
        return out.reshape(-1, 6)

    def surface_frame(self, x: float, y: float, z: float | None = None):
        return self.shell.surface_frame(x, y, z)

    def linear_fields(self, n_dof: int) -> np.ndarray | None:
        """(n_dof, 3, 3) the fields e_j r_i at the grids' six DOFs (fem.system.RotationFields)."""
        return six_dof_fields(self.nodes_m, n_dof)

    inertia_loads = staticmethod(mass_field_loads)

    def couplings(self, phi: np.ndarray, mass_phi: np.ndarray) -> None:
        """None: the deck's DOFs may sit in rotated nodal systems (jaxflex._turning then
        bounds the couplings by energy)."""
        return None

    def stress_operator(self):
        return self._stress()


def deck_outputs(parts: DeckParts, part, mesh: ShellMesh, nodes_m, unit: Units):
    """The outputs of the model and the DOFs its cups hold (fem.supports.SolidDofs)."""
    frames, _, _ = local_frames(mesh.nodes[mesh.triangles])
    layer = ShellLayer(mesh, frames)
    f = parts.facets

    def stress():
        chunk = np.arange(len(f.triangles))
        a, _, d, _, _, _ = facet_resultants(f, parts.shell_sections, chunk)
        t = f.t_mean * unit.length_m
        c_m = a * unit.modulus_to_si / f.t_mean[:, None, None]
        c_b = 12 * d * unit.modulus_to_si / f.t3_mean[:, None, None]
        z = f.offset[:, None] * unit.length_m + np.array([-0.5, 0.5]) * t[:, None]
        return surface_stress(nodes_m, f.triangles, 6 * len(nodes_m), c_m, c_b, z)

    outputs = DeckOutputs(ShellOutputs(layer, part), nodes_m, stress)
    return outputs, ShellMeshDofs(layer, part, outputs)


def stats(parts: DeckParts, nodes_m: np.ndarray) -> dict:
    f = parts.facets
    edges = np.concatenate([f.triangles[:, [0, 1]], f.triangles[:, [1, 2]], f.triangles[:, [2, 0]]])
    lengths = np.linalg.norm(nodes_m[edges[:, 0]] - nodes_m[edges[:, 1]], axis=1)
    n_elements = len(f.triangles) + len(parts.lines.cards) + len(parts.points.cards)
    return mesh_stats("triangle (shell)", len(nodes_m), n_elements, 6 * len(nodes_m), lengths)
