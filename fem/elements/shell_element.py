"""The flat-facet shell triangle: DKT bending + ANDES OPT membrane with drilling rotations.

Everything here works on arrays of elements at once (leading axis E). A triangle has three
nodes with six DOFs each, in its local frame (x along edge 1-2, z along the normal):
(u, v, w, theta_x, theta_y, theta_z) per node, theta the rotation vector (right-handed), so
the slopes of the mid-surface are w_x = -theta_y, w_y = theta_x, and the drilling rotation
theta_z is the in-plane rotation (v_x - u_y) / 2 of a rigid rotation.

* Bending: the discrete Kirchhoff triangle (DKT; Batoz, Bathe and Ho, IJNME 15, 1980): the
  slopes are quadratic over the 6-node triangle, equal to the nodal slopes at the corners;
  at the mid-sides the tangential slope is that of the cubic w along the edge and the normal
  slope the mean of the corners'. No transverse shear enters, so it cannot shear-lock at any
  thickness. Curvatures are linear: a 3-point rule integrates the stiffness exactly.
* Membrane: the optimal ANDES triangle with corner drilling freedoms (OPT; Felippa, CMAME
  192, 2003): basic stiffness of the Allman-type boundary field (alpha_b = 3/2) plus the
  higher-order stiffness of deviatoric corner rotations (beta_0 = (1 - 4 nu^2) / 2, at least
  0.01; the "optimal" beta_1..9). It is exact in pure in-plane bending of rectangular
  patches, passes the patch test and has no spurious mode (rank 6 of 9).
* Mass, consistent: u, v with the linear shape functions; w with a cubic per element that
  interpolates w and both slopes at the corners and is exact for quadratics (its centroid
  value is the mean of w_i + grad w_i . (c - x_i) / 2); rotary inertia rho h^3 / 12 on the
  three rotations with linear shape functions (the drilling one is the usual fictitious
  term: it keeps M definite so that (M R)^T M^-1 (M R) is the part's mass).

Strain-displacement evaluations (:func:`membrane_strain_matrix`, :func:`curvature_matrix`)
are public so that stresses can be recovered from mode shapes: in the local frame at
height z from the mid-surface, sigma = C (eps + z kappa) with C = :func:`plane_stress`.
"""

from __future__ import annotations

import numpy as np
from skfem.quadrature import get_quadrature
from skfem.refdom import RefTri

from jaxflex.errors import InputError

MEMBRANE = np.array([0, 1, 5, 6, 7, 11, 12, 13, 17])  # u, v, theta_z of each node
BENDING = np.array([2, 3, 4, 8, 9, 10, 14, 15, 16])  # w, theta_x, theta_y of each node
# OPT: alpha_b and beta_1 ... beta_9 (Felippa 2003, table of the optimal element)
ALPHA_B = 1.5
BETA_OPT = (1.0, 2.0, 1.0, 0.0, 1.0, -1.0, -1.0, -1.0, -2.0)
# interior 3-point rule on the triangle (area coordinates, weights sum to 1): exact for
# quadratics (DKT curvature products)
GAUSS3 = np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]])
GAUSS3_W = np.full(3, 1 / 3)


def plane_stress(E_pa: float, nu: float) -> np.ndarray:
    """(3, 3) plane-stress elasticity for (eps_xx, eps_yy, gamma_xy), Pa."""
    return E_pa / (1 - nu**2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])


def local_frames(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frames, local coordinates and areas of triangles xyz (E, 3, 3) m.

    Returns frames (E, 3, 3) whose rows are the local axes e1 (along edge 1-2), e2, e3 (the
    normal of the node order) in global coordinates; xy (E, 3, 2) local node coordinates
    (node 1 at the origin), m; area (E,) m^2. Degenerate triangles raise InputError.
    """
    d12 = xyz[:, 1] - xyz[:, 0]
    d13 = xyz[:, 2] - xyz[:, 0]
    normal = np.cross(d12, d13)
    double_area = np.linalg.norm(normal, axis=1)
    scale = np.maximum(np.linalg.norm(d12, axis=1), np.linalg.norm(d13, axis=1))
    if (double_area <= 1e-12 * scale**2).any():
        raise InputError("mesh: degenerate (zero-area) triangles in the shell mesh")
    e1 = d12 / np.linalg.norm(d12, axis=1, keepdims=True)
    e3 = normal / double_area[:, None]
    e2 = np.cross(e3, e1)
    frames = np.stack([e1, e2, e3], axis=1)
    rel = xyz - xyz[:, :1]
    xy = np.einsum("enk,eik->eni", rel, frames[:, :2])
    return frames, xy, double_area / 2


def _edges(xy: np.ndarray):
    """x_ij = x_i - x_j and y_ij for the pairs used below, (E,) each (local coordinates)."""
    x, y = xy[..., 0], xy[..., 1]
    d = {}
    for i in range(3):
        for j in range(3):
            if i != j:
                d[f"x{i + 1}{j + 1}"] = x[:, i] - x[:, j]
                d[f"y{i + 1}{j + 1}"] = y[:, i] - y[:, j]
    return d


def opt_beta0(nu: float) -> float:
    """OPT's scaling of the higher-order stiffness for Poisson's ratio ``nu``:
    (1 - 4 nu^2) / 2, at least 0.01 (Felippa 2003)."""
    return max(0.5 * (1 - 4 * nu**2), 0.01)


def _opt_parts(xy: np.ndarray):
    """Pieces of the OPT membrane shared by its stiffness and its strains: L (E, 9, 3)
    (without the thickness), Te (E, 3, 3), Q1..Q3 (E, 3, 3), T_theta_u (E, 3, 9), area."""
    d = _edges(xy)
    x12, x21, x13, x31, x23, x32 = (d[k] for k in ("x12", "x21", "x13", "x31", "x23", "x32"))
    y12, y21, y13, y31, y23, y32 = (d[k] for k in ("y12", "y21", "y13", "y31", "y23", "y32"))
    area = 0.5 * (x21 * y31 - x31 * y21)
    zero = np.zeros_like(area)
    ab = ALPHA_B
    L = 0.5 * np.stack(
        [
            np.stack([y23, zero, x32], -1),
            np.stack([zero, x32, y23], -1),
            np.stack(
                [
                    ab * y23 * (y13 - y21) / 6,
                    ab * x32 * (x31 - x12) / 6,
                    ab * (x31 * y13 - x12 * y21) / 3,
                ],
                -1,
            ),
            np.stack([y31, zero, x13], -1),
            np.stack([zero, x13, y31], -1),
            np.stack(
                [
                    ab * y31 * (y21 - y32) / 6,
                    ab * x13 * (x12 - x23) / 6,
                    ab * (x12 * y21 - x23 * y32) / 3,
                ],
                -1,
            ),
            np.stack([y12, zero, x21], -1),
            np.stack([zero, x21, y12], -1),
            np.stack(
                [
                    ab * y12 * (y32 - y13) / 6,
                    ab * x21 * (x23 - x31) / 6,
                    ab * (x23 * y32 - x31 * y13) / 3,
                ],
                -1,
            ),
        ],
        axis=1,
    )
    a4 = 4 * area
    t_theta_u = (
        np.stack(
            [
                np.stack([x32, y32, a4, x13, y13, zero, x21, y21, zero], -1),
                np.stack([x32, y32, zero, x13, y13, a4, x21, y21, zero], -1),
                np.stack([x32, y32, zero, x13, y13, zero, x21, y21, a4], -1),
            ],
            axis=1,
        )
        / a4[:, None, None]
    )
    l21, l32, l13 = x21**2 + y21**2, x32**2 + y32**2, x13**2 + y13**2
    te = (
        np.stack(
            [
                np.stack([y23 * y13 * l21, y31 * y21 * l32, y12 * y32 * l13], -1),
                np.stack([x23 * x13 * l21, x31 * x21 * l32, x12 * x32 * l13], -1),
                np.stack(
                    [
                        (y23 * x31 + x32 * y13) * l21,
                        (y31 * x12 + x13 * y21) * l32,
                        (y12 * x23 + x21 * y32) * l13,
                    ],
                    -1,
                ),
            ],
            axis=1,
        )
        / (4 * area**2)[:, None, None]
    )
    b1, b2, b3, b4, b5, b6, b7, b8, b9 = BETA_OPT
    inv = np.stack([1 / l21, 1 / l32, 1 / l13], -1)[:, :, None]  # rows: edges 21, 32, 13
    pattern = [
        [[b1, b2, b3], [b4, b5, b6], [b7, b8, b9]],
        [[b9, b7, b8], [b3, b1, b2], [b6, b4, b5]],
        [[b5, b6, b4], [b8, b9, b7], [b2, b3, b1]],
    ]
    q = [(2 * area / 3)[:, None, None] * inv * np.array(p)[None] for p in pattern]
    return L, te, q, t_theta_u, area


def membrane_stiffness(xy: np.ndarray, thickness_m: float, E_pa: float, nu: float) -> np.ndarray:
    """(E, 9, 9) OPT membrane stiffness, N/m, DOFs (u, v, theta_z) per node, local."""
    return membrane_stiffness_of(xy, thickness_m * plane_stress(E_pa, nu), opt_beta0(nu))


def membrane_stiffness_of(xy: np.ndarray, a_n_m: np.ndarray, beta0) -> np.ndarray:
    """(E, 9, 9) OPT membrane stiffness, N/m, DOFs (u, v, theta_z) per node, local, of a
    membrane stiffness ``a_n_m`` (3, 3) or (E, 3, 3) N/m (thickness x plane-stress matrix)
    in the elements' local axes; ``beta0`` scalar or (E,) (:func:`opt_beta0`)."""
    L, te, (q1, q2, q3), t_theta_u, area = _opt_parts(xy)
    a = np.broadcast_to(a_n_m, (len(xy), 3, 3))
    # basic: (1/V) L C L^T with L carrying the thickness
    basic = np.einsum("eia,eab,ejb->eij", L, a, L) / area[:, None, None]
    c_nat = np.einsum("eai,eab,ebj->eij", te, a, te)
    k_theta = np.zeros_like(c_nat)
    for qm in ((q1 + q2) / 2, (q2 + q3) / 2, (q3 + q1) / 2):  # mid-side values
        k_theta += np.einsum("eai,eab,ebj->eij", qm, c_nat, qm)
    k_theta *= (0.75 * np.asarray(beta0) * area)[:, None, None]
    higher = np.einsum("eai,eab,ebj->eij", t_theta_u, k_theta, t_theta_u)
    return basic + higher


def membrane_strain_matrix(xy: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """(E, P, 3, 9) membrane strains (eps_xx, eps_yy, gamma_xy) at area coordinates zeta
    (P, 3) per unit DOF (u, v, theta_z per node), local: the constant basic strain plus the
    OPT higher-order strain field (3/2) Te Q(zeta) T_theta_u, Q linear between the corners."""
    L, te, (q1, q2, q3), t_theta_u, area = _opt_parts(xy)
    basic = np.transpose(L, (0, 2, 1)) / area[:, None, None]
    q = np.einsum("pk,keij->epij", zeta, np.stack([q1, q2, q3]))
    higher = 1.5 * np.einsum("eab,epbc,ecj->epaj", te, q, t_theta_u)
    return basic[:, None] + higher


def _area_gradients(xy: np.ndarray) -> np.ndarray:
    """(E, 3, 2) gradients of the area coordinates zeta_i (1/m)."""
    x, y = xy[..., 0], xy[..., 1]
    j, k = [1, 2, 0], [2, 0, 1]
    b = y[:, j] - y[:, k]
    c = x[:, k] - x[:, j]
    return np.stack([b, c], axis=-1) / (2 * _area(xy))[:, None, None]


def _slopes_at_nodes(xy: np.ndarray) -> np.ndarray:
    """(E, 6, 2, 9): the DKT slopes (w_x, w_y) at the corners and the mid-sides 12, 23, 31
    per unit DOF (w, theta_x, theta_y per node)."""
    n = xy.shape[0]
    s = np.zeros((n, 6, 2, 9))
    corner = np.zeros((3, 2, 9))
    for i in range(3):
        corner[i, 0, 3 * i + 2] = -1.0  # w_x = -theta_y
        corner[i, 1, 3 * i + 1] = 1.0  # w_y = theta_x
    s[:, :3] = corner
    for m, (i, j) in enumerate(((0, 1), (1, 2), (2, 0))):
        d = xy[:, j] - xy[:, i]
        length = np.linalg.norm(d, axis=1)
        t = d / length[:, None]
        nrm = np.stack([t[:, 1], -t[:, 0]], axis=1)
        # tangential slope of the cubic Hermite w along the edge at its middle
        s_t = np.einsum("ek,kd->ed", t, corner[i] + corner[j]) * -0.25
        s_t[:, 3 * j] += 1.5 / length
        s_t[:, 3 * i] -= 1.5 / length
        s_n = 0.5 * np.einsum("ek,kd->ed", nrm, corner[i] + corner[j])
        s[:, 3 + m] = t[:, :, None] * s_t[:, None] + nrm[:, :, None] * s_n[:, None]
    return s


def curvature_matrix(xy: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """(E, P, 3, 9) DKT curvatures (w_xx, w_yy, 2 w_xy) at area coordinates zeta (P, 3) per
    unit DOF (w, theta_x, theta_y per node), local, 1/m."""
    grad = _area_gradients(xy)  # (E, 3, 2)
    # derivatives of the quadratic shape functions N_c = z_c (2 z_c - 1), N_ij = 4 z_i z_j
    # with respect to the area coordinates, at each point: (P, 6, 3)
    p = zeta.shape[0]
    dn = np.zeros((p, 6, 3))
    for c in range(3):
        dn[:, c, c] = 4 * zeta[:, c] - 1
    for m, (i, j) in enumerate(((0, 1), (1, 2), (2, 0))):
        dn[:, 3 + m, i] = 4 * zeta[:, j]
        dn[:, 3 + m, j] = 4 * zeta[:, i]
    dn_dx = np.einsum("pnk,ekx->epnx", dn, grad)  # (E, P, 6, 2)
    slopes = _slopes_at_nodes(xy)  # (E, 6, 2, 9): component s_a
    ds = np.einsum("epnx,enad->epaxd", dn_dx, slopes)  # d s_a / d x_b
    return np.stack([ds[:, :, 0, 0], ds[:, :, 1, 1], ds[:, :, 0, 1] + ds[:, :, 1, 0]], axis=2)


def bending_stiffness_of(xy: np.ndarray, d_nm: np.ndarray) -> np.ndarray:
    """(E, 9, 9) DKT bending stiffness of a bending stiffness ``d_nm`` (3, 3) or (E, 3, 3)
    N m in the elements' local axes, DOFs (w, theta_x, theta_y) per node, local."""
    b = curvature_matrix(xy, GAUSS3)
    d = np.broadcast_to(d_nm, (len(xy), 3, 3))
    return np.einsum("p,e,epai,eab,epbj->eij", GAUSS3_W, _area(xy), b, d, b, optimize=True)


def coupling_stiffness(xy: np.ndarray, b_n: np.ndarray) -> np.ndarray:
    """(E, 9, 9) membrane-bending coupling of a section with N = B kappa_N, M = B^T eps
    (``b_n`` (3, 3) or (E, 3, 3) N, local axes; kappa_N = -kappa, the curvature of the
    Nastran convention eps(z) = eps + z kappa_N): rows the membrane DOFs (u, v, theta_z),
    columns the bending DOFs (w, theta_x, theta_y), -int eps_m^T B kappa dA (3-point rule:
    exact for the linear fields)."""
    eps = membrane_strain_matrix(xy, GAUSS3)
    kappa = curvature_matrix(xy, GAUSS3)
    b = np.broadcast_to(b_n, (len(xy), 3, 3))
    return -np.einsum("p,e,epai,eab,epbj->eij", GAUSS3_W, _area(xy), eps, b, kappa, optimize=True)


def _area(xy: np.ndarray) -> np.ndarray:
    """(E,) signed areas of local triangles xy (E, 3, 2), m^2."""
    d = xy[:, 1:] - xy[:, :1]
    return 0.5 * (d[:, 0, 0] * d[:, 1, 1] - d[:, 1, 0] * d[:, 0, 1])


def _mass_rule():
    points, weights = get_quadrature(RefTri, 6)  # exact for the cubic-times-cubic integrand
    zeta = np.column_stack([1 - points[0] - points[1], points[0], points[1]])
    return zeta, 2 * weights  # weights sum to 1 (fractions of the area)


# the consistent mass's rule: area coordinates (P, 3), weights (P,) summing to 1
MASS_RULE = _mass_rule()


def _cubic_basis(zeta: np.ndarray) -> np.ndarray:
    """(P, 10) cubic monomials in area coordinates: z1, z2, z3, z_i^2 z_j (i != j), z1 z2 z3."""
    z1, z2, z3 = zeta.T
    return np.stack(
        [z1, z2, z3, z1**2 * z2, z1**2 * z3, z2**2 * z1, z2**2 * z3, z3**2 * z1, z3**2 * z2,
         z1 * z2 * z3],
        axis=1,
    )  # fmt: skip


def _cubic_basis_gradient(zeta: np.ndarray) -> np.ndarray:
    """(P, 10, 3) derivatives of :func:`_cubic_basis` with respect to z1, z2, z3."""
    z1, z2, z3 = zeta.T
    o, zero = np.ones_like(z1), np.zeros_like(z1)
    rows = [
        (o, zero, zero), (zero, o, zero), (zero, zero, o),
        (2 * z1 * z2, z1**2, zero), (2 * z1 * z3, zero, z1**2),
        (z2**2, 2 * z2 * z1, zero), (zero, 2 * z2 * z3, z2**2),
        (z3**2, zero, 2 * z3 * z1), (zero, z3**2, 2 * z3 * z2),
        (z2 * z3, z1 * z3, z1 * z2),
    ]  # fmt: skip
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=1)


def deflection_shape(xy: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """(E, P, 9) the cubic deflection w at area coordinates zeta (P, 3) per unit DOF (w,
    theta_x, theta_y per node): interpolates w and its slopes at the corners, exact for
    quadratic w (used for the consistent mass)."""
    n = xy.shape[0]
    corners = np.eye(3)
    grad = _area_gradients(xy)  # (E, 3, 2): d zeta_k / d x
    conditions = np.zeros((n, 10, 10))
    rhs = np.zeros((n, 10, 9))
    values = _cubic_basis(corners)  # (3, 10)
    dbasis = np.einsum("pmk,ekx->epmx", _cubic_basis_gradient(corners), grad)  # (E, 3, 10, 2)
    for i in range(3):
        conditions[:, i] = values[i]
        rhs[:, i, 3 * i] = 1.0
        conditions[:, 3 + 2 * i] = dbasis[:, i, :, 0]  # w_x = -theta_y
        rhs[:, 3 + 2 * i, 3 * i + 2] = -1.0
        conditions[:, 4 + 2 * i] = dbasis[:, i, :, 1]  # w_y = theta_x
        rhs[:, 4 + 2 * i, 3 * i + 1] = 1.0
    # centroid: w(c) = mean_i (w_i + grad w_i . (c - x_i) / 2), exact for quadratics
    centre = xy.mean(axis=1)
    conditions[:, 9] = _cubic_basis(np.full((1, 3), 1 / 3))[0]
    for i in range(3):
        d = centre - xy[:, i]
        rhs[:, 9, 3 * i] += 1 / 3
        rhs[:, 9, 3 * i + 2] += -d[:, 0] / 6
        rhs[:, 9, 3 * i + 1] += d[:, 1] / 6
    coefficients = np.linalg.solve(conditions, rhs)  # (E, 10, 9)
    return np.einsum("pm,emd->epd", _cubic_basis(zeta), coefficients)


def mass_matrix_of(xy: np.ndarray, mass_kg_m2: np.ndarray, inertia_kg: np.ndarray) -> np.ndarray:
    """(E, 18, 18) consistent mass, kg, local DOFs (u, v, w, theta_x, theta_y, theta_z), of
    a mass per area ``mass_kg_m2`` (E,) and a rotary inertia per area ``inertia_kg`` (E,)
    (rho h^3 / 12 for a homogeneous sheet)."""
    area = _area(xy)
    n = xy.shape[0]
    linear = (np.full((3, 3), 1.0) + np.eye(3)) / 12  # int N_i N_j dA / A
    mass = np.zeros((n, 3, 6, 3, 6))
    rho_h, inertia = np.asarray(mass_kg_m2), np.asarray(inertia_kg)
    for comp, value in ((0, rho_h), (1, rho_h), (3, inertia), (4, inertia), (5, inertia)):
        mass[:, :, comp, :, comp] = (value * area)[:, None, None] * linear
    zeta, weights = MASS_RULE
    shape = deflection_shape(xy, zeta)  # (E, P, 9)
    m_w = np.einsum("p,e,epi,epj->eij", weights, rho_h * area, shape, shape)
    full = mass.reshape(n, 18, 18)
    full[np.ix_(np.arange(n), BENDING, BENDING)] += m_w
    return full


def element_matrices(
    xyz: np.ndarray, thickness_m: float, E_pa: float, nu: float, rho_kg_m3: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stiffness and mass (E, 18, 18) in global DOFs (u_x, u_y, u_z, theta_x, theta_y,
    theta_z per node) of triangles xyz (E, 3, 3) m, and their frames (E, 3, 3)."""
    frames, xy, _ = local_frames(xyz)
    c = plane_stress(E_pa, nu)
    rho_h = np.full(len(xyz), rho_kg_m3 * thickness_m)
    k, m = local_matrices(
        xy,
        thickness_m * c,
        None,
        c * thickness_m**3 / 12,
        opt_beta0(nu),
        rho_h,
        rho_h * thickness_m**2 / 12,
    )
    return to_global(k, frames), to_global(m, frames), frames


def local_matrices(xy, a_n_m, b_n, d_nm, beta0, mass_kg_m2, inertia_kg):
    """Stiffness and mass (E, 18, 18) in the local DOFs of triangles ``xy`` (E, 3, 2) of a
    section with membrane ``a_n_m``, coupling ``b_n`` (None: none; see
    :func:`coupling_stiffness`) and bending ``d_nm`` stiffness ((3, 3) or (E, 3, 3), local
    axes), OPT's ``beta0``, mass per area and rotary inertia per area (E,)."""
    n = xy.shape[0]
    k = np.zeros((n, 18, 18))
    rows = np.arange(n)[:, None, None]
    mem, bend = MEMBRANE[None, :, None], BENDING[None, None, :]
    k[rows, mem, MEMBRANE[None, None, :]] = membrane_stiffness_of(xy, a_n_m, beta0)
    k[rows, BENDING[None, :, None], bend] = bending_stiffness_of(xy, d_nm)
    if b_n is not None:
        coupling = coupling_stiffness(xy, b_n)
        k[rows, mem, bend] = coupling
        k[rows, BENDING[None, :, None], MEMBRANE[None, None, :]] = np.swapaxes(coupling, 1, 2)
    return k, mass_matrix_of(xy, mass_kg_m2, inertia_kg)


def to_global(local: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """(E, 18, 18) element matrices from the local frame to global DOFs: T^T A T with T the
    block diagonal of the frame (rows e1, e2, e3) on each translation and rotation triple."""
    n = local.shape[0]
    blocks = local.reshape(n, 6, 3, 6, 3)
    out = np.einsum("eki,eakbl,elj->eaibj", frames, blocks, frames, optimize=True)
    return out.reshape(n, 18, 18)
