"""The turning data of a simply supported rectangular plate against closed forms, for the
Kirchhoff plate (Morley) and the same flat plate meshed as a shell (DKT + OPT: another
element formulation with rotary inertia), with the convergence rate measured by refining.

Plate [0, a] x [0, b] at height z0, thickness h, density rho; mode (m, n) is
w = A sin(m pi x / a) sin(n pi y / b), mass-normalised: A = 2 / sqrt(rho h a b) for the
Kirchhoff plate (no rotary inertia), A = 2 / sqrt(rho h a b (1 + h^2 k^2 / 12)) with
k^2 = pi^2 ((m/a)^2 + (n/b)^2) with the rotary inertia rho h^3 / 12 of the sheet's
fibres (the shell's: its rotations theta = (w_y, -w_x) carry it). The shape integrals
S[i, j] = int rho u . e_j r_i dV of a thin sheet with the fibres' displacement zeta (theta x
e_z) are then S[i, z] = rho h A int w r_i dA (the rotary terms, rho h^3 / 12 int theta dA,
vanish: w = 0 on the whole boundary), products of the 1-D integrals

    int_0^L sin(k pi s / L) ds = L (1 - (-1)^k) / (k pi),
    int_0^L s sin(k pi s / L) ds = (-1)^(k+1) L^2 / (k pi),

and every in-plane column S[:, x], S[:, y] is 0. The rotational participation about x is
int rho h w y dA = S[y, z], about y -int rho h w x dA = -S[x, z], about z 0.

The static response to the unit inertia load rho h r_i along z (jaxflex._rotation: the
displacement under the load -M (e_z r_i), per unit B_zi) is Navier's double series
-sum_mn phi_mn S_mn[i, z] / omega_mn^2, omega_mn^2 = D k^4 / (rho h) (the rotary inertia
does not enter a static solve), summed to m, n <= 300 (the terms fall as 1/(m n (m^2 +
n^2)^2): the tail is < 1e-9 of the sum).
"""

from __future__ import annotations

import numpy as np
import pytest

import fem

A_M, B_M, H_M = 0.6, 0.4, 1e-3
STEEL = fem.PRESETS["steel"]
RHO_H = STEEL.rho_kg_m3 * H_M
# the five lowest modes; (m/a)^2 + (n/b)^2 = 9.03, 17.4, 27.8, 31.3, 36.1 m^-2: at least 12 %
# apart, so no two mix on a mesh that is not symmetric (the next, (3, 2) and (4, 1), are 1.4 %
# apart and are left out)
MODES = ((1, 1), (2, 1), (1, 2), (3, 1), (2, 2))
MESHES_M = {"morley": (0.05, 0.025, 0.0125), "shell": (0.05, 0.025, 0.0125)}
# Both elements converge at O(h^2) in these integrals (Morley: L2 error of the eigenfunctions
# O(h^2), Rannacher 1979; DKT: O(h^2) displacements; the integrals are L2 products with the
# exact linear fields): each halving must cut the error by 2^1.7 at least (measured: 2^1.80
# from the coarsest 50 mm mesh, pre-asymptotic, then 2^1.94 and better), and the finest error
# must lie within 1.5 x its Richardson estimate |S_h - S_h/2| / (2^2 - 1) (a wrong limit
# would not: the mesh change cannot see it).
MIN_RATE = 1.7
RICHARDSON_SAFETY = 1.5


def _one_d(k, length_m):
    """(int sin, int s sin) over [0, L] of sin(k pi s / L)."""
    k = np.asarray(k, dtype=float)
    return (
        length_m * (1 - (-1.0) ** k) / (k * np.pi),
        (-1.0) ** (k + 1) * length_m**2 / (k * np.pi),
    )


def _amplitude(m, n, rotary: bool):
    k2 = np.pi**2 * ((m / A_M) ** 2 + (n / B_M) ** 2)
    return 2 / np.sqrt(RHO_H * A_M * B_M * (1 + (H_M**2 * k2 / 12 if rotary else 0.0)))


def closed_form_integrals(m: int, n: int, z0_m: float, rotary: bool) -> np.ndarray:
    """(3, 3) S[i, j] of mode (m, n) (module docstring), kg^0.5 m."""
    sin_x, x_sin_x = _one_d(m, A_M)
    sin_y, y_sin_y = _one_d(n, B_M)
    out = np.zeros((3, 3))
    out[:, 2] = (
        RHO_H
        * _amplitude(m, n, rotary)
        * np.array([x_sin_x * sin_y, sin_x * y_sin_y, z0_m * sin_x * sin_y])
    )
    return out


def navier_static(xy_m: np.ndarray, z0_m: float, terms: int = 300) -> np.ndarray:
    """(P, 3) deflection (m s^2) at ``xy_m`` (P, 2) per unit B_zi of the load -rho h r_i e_z
    (module docstring)."""
    k = np.arange(1, terms + 1)
    m, n = np.meshgrid(k, k, indexing="ij")
    sin_x, x_sin_x = _one_d(m, A_M)
    sin_y, y_sin_y = _one_d(n, B_M)
    amp = _amplitude(m, n, rotary=False)
    loads = RHO_H * amp * np.stack([x_sin_x * sin_y, sin_x * y_sin_y, z0_m * sin_x * sin_y])
    omega2 = (
        STEEL.bending_stiffness_nm(H_M) / RHO_H * np.pi**4 * ((m / A_M) ** 2 + (n / B_M) ** 2) ** 2
    )
    wave_x = np.sin(np.pi * np.outer(xy_m[:, 0], k) / A_M)
    wave_y = np.sin(np.pi * np.outer(xy_m[:, 1], k) / B_M)
    return -np.einsum("imn,pm,pn->pi", loads * amp / omega2, wave_x, wave_y)


def _fe_data(element: str, mesh_m: float):
    """(S (5, 3, 3) sign-aligned to the closed-form modes, Gamma_rot (5, 3) likewise, the
    static deflection (N, 3) per unit B_zi at every node, the node coordinates (N, 3))."""
    part = fem.rectangular_plate(A_M, B_M, H_M, "steel", mesh_m, element=element)
    result = fem.modal_analysis(
        part, fem.SimplySupportedEdge("all"), n_modes=len(MODES), zeta=0.02, progress=False
    )
    rotation = result.to_modal_model(points="all").rotation
    nodes = result.system.nodes
    shapes = (result.basis @ result.vectors)[result.system.node_dofs[:, 2]]  # w at the nodes
    signs = np.array(
        [
            np.sign(
                shapes[:, i]
                @ (np.sin(m * np.pi * nodes[:, 0] / A_M) * np.sin(n * np.pi * nodes[:, 1] / B_M))
            )
            for i, (m, n) in enumerate(MODES)
        ]
    )
    integrals = np.asarray(rotation.shape_integrals) * signs[:, None, None]
    gamma_rot = np.asarray(rotation.gamma_rot) * signs[:, None]
    static = np.asarray(rotation.static_shapes)[:, 2, :, 2]  # w per unit B_zi
    return integrals, gamma_rot, static, nodes


@pytest.fixture(scope="module", params=sorted(MESHES_M))
def refined(request):
    element = request.param
    return element, [_fe_data(element, h) for h in MESHES_M[element]]


def _rates(errors) -> np.ndarray:
    return np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:]))


def test_shape_integrals_and_participation_against_the_closed_form(refined):
    """Every entry of S and Gamma_rot of the five modes (sign-aligned by the mode's own
    deflection against sin sin, never by the compared numbers) converges to the closed form
    at O(h^2), the finest within its Richardson estimate (module constants)."""
    element, levels = refined
    z0 = float(levels[0][3][0, 2])
    rotary = element == "shell"
    exact = np.stack([closed_form_integrals(m, n, z0, rotary) for m, n in MODES])
    exact_gamma = np.stack([exact[:, 1, 2], -exact[:, 0, 2], np.zeros(len(MODES))], axis=1)
    scale = np.abs(exact).max()
    errors = [np.abs(s - exact).max() / scale for s, *_ in levels]
    gamma_errors = [np.abs(g - exact_gamma).max() / scale for _, g, *_ in levels]
    assert np.all(_rates(errors) >= MIN_RATE), (errors, _rates(errors))
    assert np.all(_rates(gamma_errors) >= MIN_RATE), gamma_errors
    change = np.abs(levels[-2][0] - levels[-1][0]).max() / scale
    assert errors[-1] <= RICHARDSON_SAFETY * change / 3, (errors[-1], change / 3)
    if rotary:  # the shell resolves its rotary inertia: mode (1, 1) without it would be off
        # by the normalisation's h^2 k^2 / 24 = 3.7e-6 of it (measured 3.7e-6 against the
        # Kirchhoff amplitude, 1.8e-8 against the one with rotary inertia at 12.5 mm)
        k2 = np.pi**2 * (A_M**-2 + B_M**-2)
        first = np.abs(levels[-1][0][0] - exact[0]).max() / np.abs(exact[0]).max()
        assert first <= 0.1 * H_M**2 * k2 / 24


def test_static_response_to_the_rotational_loads_against_navier(refined):
    """The stored static deflection per unit B_zi (the load -rho h r_i along z) at every node
    against Navier's series: O(h^2) convergence, the finest within its Richardson estimate
    (Morley measured 6.2 %, 1.6 %, 0.39 % of the peak at 50, 25, 12.5 mm)."""
    _, levels = refined
    errors, finest = [], None
    for _, _, static, nodes in levels:
        exact = navier_static(nodes[:, :2], float(nodes[0, 2]))
        errors.append(np.abs(static - exact).max() / np.abs(exact).max())
        finest = exact
    assert np.all(_rates(errors) >= MIN_RATE), errors
    # the two finest meshes' nodes differ: compare them at the coarser one's nodes, which
    # the finer mesh keeps (nested refinement checked by the coordinates)
    coarse_nodes, fine_nodes = levels[-2][3], levels[-1][3]
    index = {tuple(np.round(p, 9)): k for k, p in enumerate(fine_nodes)}
    shared = [index.get(tuple(np.round(p, 9))) for p in coarse_nodes]
    assert all(k is not None for k in shared), "the finer mesh does not keep the coarser nodes"
    change = np.abs(levels[-2][2] - levels[-1][2][shared]).max() / np.abs(finest).max()
    assert errors[-1] <= RICHARDSON_SAFETY * change / 3, (errors[-1], change / 3)
