"""The shell's turning data (fem.rotation_integrals) of a flat, a curved and a folded part
against computations written here from the facets alone: the 3-D inertia of the faceted
sheet (its fibres' t^2 / 12 included) in closed form, and the shape integrals of the
elastic modes by a quadrature of the stored nodal displacements with a mass of our own.

The sheet's inertia: tests/sheet_parts.sheet_moments (exact for flat facets).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse.linalg import spsolve
from sheet_parts import bracket, sheet_moments

import fem
from fem.mesh.mesh_io import sheet_from_cells
from fem.parts import part_from_mesh
from fem.rotation_integrals import inertia_loads, linear_fields
from jaxflex._rotation import LEVI_CIVITA

CUPS = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]


def _bracket(size_m: float):
    """The 90-degree L-bracket of tests/sheet_parts (0.3 m base, 0.1 m flange, 0.2 m wide,
    2 mm steel) as a shell of ``size_m`` elements."""
    points, quads = bracket(90.0, size_m)
    sheet = sheet_from_cells(points, [("quad", quads)], "bracket")
    return part_from_mesh(sheet, 2e-3, "steel", "shell", "bracket", {})


PARTS = {
    "flat": lambda: (
        fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.05, element="shell"),
        CUPS,
    ),
    "curved": lambda: (
        fem.curved_panel(0.6, 0.4, 1e-3, "steel", 0.05, element="shell"),
        CUPS,
    ),
    "folded": lambda: (_bracket(0.02), fem.ClampedEdge("x1")),
}


@pytest.fixture(scope="module", params=sorted(PARTS))
def held(request):
    part, supports = PARTS[request.param]()
    result = fem.modal_analysis(part, supports, n_modes=4, zeta=0.02, progress=False)
    rho_h = part.material.rho_kg_m3 * part.thickness_m
    layer = result.system.outputs.layer
    return result, sheet_moments(layer.nodes, layer.triangles, rho_h, part.thickness_m)


def test_stored_rigid_inertia_is_the_faceted_sheets(held):
    """The model's mass, centre and inertia tensor about the origin equal the sheet's in
    closed form to round-off (1e-12: sums of products of the same coordinates); before, the
    shell's fictitious drilling inertia rho h^3 / 12 A added m h^2 / 12 about the normal
    (1e-6 of J_zz of the flat plate)."""
    result, (mass, first, second) = held
    rotation = result.to_modal_model(points=10, outputs=False).rotation
    inertia = np.trace(second) * np.eye(3) - second
    assert float(rotation.mass_kg) == pytest.approx(mass, rel=1e-12)
    assert np.abs(np.asarray(rotation.centre_m) - first / mass).max() <= 1e-12
    scale = np.abs(inertia).max()
    assert np.abs(np.asarray(rotation.inertia_kg_m2) - inertia).max() <= 1e-12 * scale


def test_rigid_rotations_do_the_work_of_the_sheets_second_moments(held):
    """The consistent loads of the nine unit fields e_j r_i (fem.rotation_integrals.
    inertia_loads), worked by the rigid rotations e_k x r: int rho (e_k x r)_j r_i dV =
    eps_jka Sigma_ai with the sheet's second moment Sigma, every one of the 27 to round-off
    (the Euler and centrifugal loads' resultant moments, symmetric parts included; before,
    a symmetric field's fibres were left unturned: 2.1e-5 of the largest on the flat plate,
    3.7e-5 on the curved panel)."""
    result, (_, _, second) = held
    system = result.system
    loads = inertia_loads(system, linear_fields(system))
    rotations = system.outputs.rigid_motion(np.zeros(3))[:, 3:]
    work = (rotations.T @ loads).reshape(3, 3, 3)  # [k, i, j]
    expected = np.einsum("jka,ai->kij", LEVI_CIVITA, second)
    assert np.abs(work - expected).max() <= 1e-12 * np.abs(expected).max()


def _linear_quadrature(nodes_m, triangles, shapes, rho_h: float) -> np.ndarray:
    """(M, 3, 3) int rho h u_m . e_j r_i dA of the nodal displacements ``shapes`` (N, 3, M)
    interpolated linearly over each facet (consistent mass of linear triangles,
    int N_a N_b dA = A (1 + delta_ab) / 12)."""
    corners = nodes_m[triangles]
    area = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    pair = (np.ones((3, 3)) + np.eye(3)) / 12
    return rho_h * np.einsum("e,ab,eai,ebjm->mij", area, pair, corners, shapes[triangles])


# the curved panel (clamped on one side) and the folded bracket, each at two mesh sizes
SHELL_PARTS = pytest.mark.parametrize(
    ("name", "build", "sizes_m"),
    [
        (
            "curved",
            lambda s: fem.curved_panel(0.6, 0.4, 1e-3, "steel", s, element="shell"),
            (0.05, 0.025),
        ),
        ("folded", _bracket, (0.02, 0.01)),
    ],
)


@SHELL_PARTS
def test_mode_shape_integrals_against_a_quadrature_of_the_stored_shapes(name, build, sizes_m):
    """The stored S of six modes of a curved panel (clamped on one side) and a folded
    bracket against the integral of the stored nodal displacements (points="all")
    interpolated linearly over the facets: the shell's own field has the cubic normal
    deflection of DKT, so the two differ by O(h^2) (the interpolation error of a smooth
    mode) and the rotary share (1e-6): the difference must fall by 2^1.7 at least per
    halving (measured 2^1.84 to 2^2.0) and stay below 2 % of the largest S at the coarser
    mesh (measured 1.3 % curved, 0.46 % folded)."""
    supports = fem.ClampedEdge("left" if name == "curved" else "x1")
    gaps = []
    for size in sizes_m:
        part = build(size)
        result = fem.modal_analysis(part, supports, n_modes=6, zeta=0.02, progress=False)
        model = result.to_modal_model(points="all", outputs=False)
        stored = np.asarray(model.rotation.shape_integrals)
        ours = _linear_quadrature(
            np.asarray(model.points),
            result.system.outputs.layer.triangles,
            np.asarray(model.shapes),
            part.material.rho_kg_m3 * part.thickness_m,
        )
        gaps.append(np.abs(ours - stored).max() / np.abs(stored).max())
    assert gaps[0] <= 0.02, gaps
    assert np.log2(gaps[0] / gaps[1]) >= 1.7, gaps


def test_mass_products_of_rigid_motions_are_the_sheets_moments(held):
    """The shell's displacement fields at its mass rule's points (fem.elements.shell.ShellOutputs.
    mass_products, from which the couplings G and P of jaxflex._rotation come), for the six
    rigid motions as 'modes' (fields the shell holds exactly): C[a, b] = int rho (v_m)_a
    (v_n)_b dV is m delta_ab between translations, eps_bjc (m c)_c between translation i and
    rotation j, eps_aic eps_bjd Sigma_cd between rotations (the sheet's closed form, fibres
    included), to round-off."""
    result, (mass, first, second) = held
    outputs = result.system.outputs
    products = outputs.mass_products(outputs.rigid_motion(np.zeros(3)))
    eye = np.eye(3)
    expected = np.zeros((3, 3, 6, 6))
    expected[:, :, :3, :3] = mass * np.einsum("ai,bj->abij", eye, eye)
    expected[:, :, :3, 3:] = np.einsum("ai,bjc,c->abij", eye, LEVI_CIVITA, first)
    expected[:, :, 3:, :3] = expected[:, :, :3, 3:].transpose(1, 0, 3, 2)
    expected[:, :, 3:, 3:] = np.einsum("aic,bjd,cd->abij", LEVI_CIVITA, LEVI_CIVITA, second)
    assert np.abs(products - expected).max() <= 1e-12 * np.abs(expected).max()


def test_couplings_against_the_thin_solid():
    """G_k and P_kl of four modes of a curved panel clamped on one side, shell against the
    thin solid (hex2: its DOF operator X_k is exact, every node holding one vector), both at
    25 mm, modes sign-aligned by their shape integrals: the two formulations' modes differ
    (frequencies by 1 %, S by 0.69 % of its largest), and G, P, quadratic in the modes, may
    differ by twice that (measured: G 0.67 %, P 0.12 %; the shell's DOF operator turning its
    rotation vectors, used before, missed by 2.4 % and 0.53 %)."""
    data = {}
    for element in ("hex2", "shell"):
        part = fem.curved_panel(0.6, 0.4, 1e-3, "steel", 0.025, element=element)
        result = fem.modal_analysis(
            part, fem.ClampedEdge("left"), n_modes=4, zeta=0.02, progress=False
        )
        rotation = result.to_modal_model(points=10, outputs=False).rotation
        data[element] = [
            np.asarray(rotation.shape_integrals),
            np.asarray(rotation.gyroscopic),
            np.asarray(rotation.spin),
        ]
    (solid_s, solid_g, solid_p), (shell_s, shell_g, shell_p) = data["hex2"], data["shell"]
    signs = np.sign(np.einsum("mij,mij->m", solid_s, shell_s))
    pair = np.outer(signs, signs)
    gap_s = np.abs(solid_s - signs[:, None, None] * shell_s).max() / np.abs(solid_s).max()
    gap_g = np.abs(solid_g - pair * shell_g).max() / np.abs(solid_g).max()
    gap_p = np.abs(solid_p - pair * shell_p).max() / np.abs(solid_p).max()
    assert gap_s <= 0.01, gap_s
    assert gap_g <= 2 * gap_s, (gap_g, gap_s)
    assert gap_p <= 2 * gap_s, (gap_p, gap_s)


def test_couplings_keep_the_kinetic_energy(held):
    """The sum over k of e_k x (e_k x v) is -2 v: sum_k P_kk = -2 int rho v_m . v_n dV,
    which is phi^T M phi = I (the FE's own mass matrix, assembled elsewhere) less the
    shell's fictitious drilling inertia, the rotary inertia rho h^3 / 12 of each facet's
    rotation about its own normal, which the sheet's fields leave out (computed here with
    linear shape functions: up to 3.3e-5 of a mode's energy on the folded bracket, where
    one facet's drilling is the other's bending): the identity to 1e-10."""
    result, _ = held
    spin = np.asarray(result.to_modal_model(points=10, outputs=False).rotation.spin)
    layer, part = result.system.outputs.layer, result.system.outputs.part
    phi = result.basis @ result.vectors
    theta = phi.reshape(len(layer.nodes), 6, -1)[:, 3:][layer.triangles]  # (E, 3, 3, M)
    corners = layer.nodes[layer.triangles]
    twice = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    area = 0.5 * np.linalg.norm(twice, axis=1)
    drilling = np.einsum("eacm,ec->eam", theta, twice / (2 * area[:, None]))
    pair = (np.ones((3, 3)) + np.eye(3)) / 12
    fibres = part.material.rho_kg_m3 * part.thickness_m**3 / 12
    share = fibres * np.einsum("e,ab,eam,ebn->mn", area, pair, drilling, drilling)
    n_modes = spin.shape[-1]
    assert np.abs(np.einsum("kkmn->mn", spin) + 2 * (np.eye(n_modes) - share)).max() <= 1e-10


def _static_gap(part, supports) -> float:
    """Largest gap, relative to the peak, between the stored static response to the field
    B r (an Euler and a centrifugal load; sum_ij B_ji static_shapes[..., i, j]) at every node
    and a static solve K_ff u = f here with the load lumped at the nodes: a third of each
    facet's mass rho h A at each corner, f = -m_node B x_node."""
    result = fem.modal_analysis(part, supports, n_modes=4, zeta=0.02, progress=False)
    static = np.asarray(result.to_modal_model(points="all", outputs=False).rotation.static_shapes)
    system = result.system
    nodes, triangles = system.outputs.layer.nodes, system.outputs.layer.triangles
    corners = nodes[triangles]
    area = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    rho_h = part.material.rho_kg_m3 * part.thickness_m
    node_mass = rho_h * np.bincount(triangles.ravel(), np.repeat(area / 3, 3), len(nodes))
    alpha, w = np.array([0.3, -0.5, 1.0]), np.array([0.4, 0.2, -0.3])
    field = -np.einsum("kab,b->ka", LEVI_CIVITA, alpha) + np.outer(w, w) - (w @ w) * np.eye(3)
    load = np.zeros((len(nodes), 6))
    load[:, :3] = -node_mass[:, None] * (nodes @ field.T)
    basis = result.basis
    stiffness = (basis.T @ system.K @ basis).tocsc()
    ours = (basis @ spsolve(stiffness, basis.T @ load.ravel())).reshape(-1, 6)[:, :3]
    stored = np.einsum("kcij,ji->kc", static, field)
    return np.abs(ours - stored).max() / np.abs(stored).max()


@SHELL_PARTS
def test_static_response_to_the_rotational_loads_against_a_lumped_solve(name, build, sizes_m):
    """The stored static response to a combined Euler and centrifugal field against a static
    solve with the FE's stiffness and a load lumped here: the lumped and the consistent load
    differ at O(h^2) (the deflection under them too), so the gap must fall by 2^1.8 per
    halving (measured 2^2.03 and 2^2.04) and stay below 3 % of the peak at the coarser mesh
    (measured 1.75 % curved, 0.70 % folded)."""
    supports = fem.ClampedEdge("left" if name == "curved" else "x1")
    gaps = [_static_gap(build(size), supports) for size in sizes_m]
    assert gaps[0] <= 0.03, gaps
    assert np.log2(gaps[0] / gaps[1]) >= 1.8, gaps
