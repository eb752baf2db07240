"""The 12-DOF space beam: Timoshenko stiffness (Euler-Bernoulli without shear areas) and
consistent mass, for arrays of elements at once (leading axis E).

Local axes: x along the beam from end A to end B, y and z its section's axes (plane 1 is
x-y, plane 2 x-z, as Nastran's CBAR/CBEAM). DOFs per end (u, v, w, theta_x, theta_y,
theta_z), theta the rotation vector, so w' = -theta_y and v' = theta_z in the Euler-
Bernoulli limit. Section: area A, I1 = int y^2 dA (bending in plane 1), I2 = int z^2 dA,
torsion constant J, shear areas As1, As2 (None or inf: no shear deformation).

* Stiffness (Przemieniecki, Theory of Matrix Structural Analysis, 1968, ch. 5): axial EA/L,
  torsion GJ/L, bending with Phi = 12 E I / (G As L^2): the exact stiffness of a
  Timoshenko beam under end loads.
* Mass (Przemieniecki ch. 11): linear axial and torsional (polar inertia rho (I1 + I2), a
  rod's rho J: its section has no I1, I2) shape functions; bending with the translational
  inertia of the shear beam's exact static shapes (coefficients in Phi; Phi = 0 the
  Euler-Bernoulli consistent mass 156, 22 L, ... / 420), no rotary inertia of the section.
  A rod (``rod``: no bending stiffness) has the linear consistent mass along all three
  translations.
* Pin flags (released DOFs) are condensed statically out of the element (stiffness
  exactly, mass with the same static shapes).
"""

from __future__ import annotations

import numpy as np

from fem.elements.offsets import offset_transform
from jaxflex.errors import InputError

PLANE1 = np.array([1, 5, 7, 11])  # v, theta_z at A and B
PLANE2 = np.array([2, 4, 8, 10])  # w, theta_y at A and B
FLIP = np.diag([1.0, -1.0, 1.0, -1.0])  # plane 2: theta_y = -w'


def _bending_stiffness(ei, length, phi):
    L = length
    k = np.stack(
        [
            np.stack([12 + 0 * L, 6 * L, -12 + 0 * L, 6 * L], -1),
            np.stack([6 * L, (4 + phi) * L**2, -6 * L, (2 - phi) * L**2], -1),
            np.stack([-12 + 0 * L, -6 * L, 12 + 0 * L, -6 * L], -1),
            np.stack([6 * L, (2 - phi) * L**2, -6 * L, (4 + phi) * L**2], -1),
        ],
        -2,
    )
    return (ei / (L**3 * (1 + phi)))[:, None, None] * k


def _bending_mass(mass, length, phi):
    L, p = length, phi
    a = 13 / 35 + 7 * p / 10 + p**2 / 3
    b = (11 / 210 + 11 * p / 120 + p**2 / 24) * L
    c = 9 / 70 + 3 * p / 10 + p**2 / 6
    d = (13 / 420 + 3 * p / 40 + p**2 / 24) * L
    e = (1 / 105 + p / 60 + p**2 / 120) * L**2
    f = (1 / 140 + p / 60 + p**2 / 120) * L**2
    m = np.stack(
        [
            np.stack([a, b, c, -d], -1),
            np.stack([b, e, d, -f], -1),
            np.stack([c, d, a, -b], -1),
            np.stack([-d, -f, -b, e], -1),
        ],
        -2,
    )
    return (mass / (1 + p) ** 2)[:, None, None] * m


def _phi(e, g, inertia, shear_area, length):
    if shear_area is None:
        return np.zeros_like(length)
    shear = np.asarray(shear_area, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = 12 * e * inertia / (g * shear * length**2)
    return np.where(np.isfinite(shear) & (shear > 0) & (g > 0), phi, 0.0)


def local_matrices(
    length, e, g, area, i1, i2, j, rho, nsm, shear1=None, shear2=None, rod=None
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass (E, 12, 12) in local DOFs of beams of ``length`` (E,), moduli
    ``e``, ``g``, section ``area``, ``i1``, ``i2``, ``j``, density ``rho`` and mass per
    length ``nsm`` (E,) each (consistent units); shear areas (E,) or None; ``rod`` (E,)
    bool: axial and torsion only (module docstring)."""
    length = np.asarray(length, dtype=float)
    n = length.size
    e, g, area, i1, i2, j, rho, nsm = (
        np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in (e, g, area, i1, i2, j, rho, nsm)
    )
    rod = np.zeros(n, bool) if rod is None else np.asarray(rod, bool)
    k = np.zeros((n, 12, 12))
    m = np.zeros((n, 12, 12))
    pair = np.array([[1.0, -1.0], [-1.0, 1.0]])
    linear = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6
    rows = np.arange(n)[:, None, None]
    mass = (rho * area + nsm) * length
    for dofs, stiffness, inertia in (
        ([0, 6], e * area / length, mass),
        ([3, 9], g * j / length, rho * np.where(rod, j, i1 + i2) * length),
    ):
        idx = np.array(dofs)
        k[rows, idx[None, :, None], idx[None, None, :]] = stiffness[:, None, None] * pair
        m[rows, idx[None, :, None], idx[None, None, :]] = inertia[:, None, None] * linear
    for dofs, inertia, shear, flip in ((PLANE1, i1, shear1, None), (PLANE2, i2, shear2, FLIP)):
        phi = _phi(e, g, inertia, shear, length)
        kb = _bending_stiffness(e * inertia, length, phi)
        mb = _bending_mass(mass, length, phi)
        if flip is not None:
            kb, mb = flip @ kb @ flip, flip @ mb @ flip
        rod_mass = np.zeros_like(mb)
        rod_mass[:, 0::2, 0::2] = mass[:, None, None] * linear
        mb = np.where(rod[:, None, None], rod_mass, mb)
        kb = np.where(rod[:, None, None], 0.0, kb)
        k[rows, dofs[None, :, None], dofs[None, None, :]] = kb
        m[rows, dofs[None, :, None], dofs[None, None, :]] += mb
    return k, m


def release(k: np.ndarray, m: np.ndarray, released: list[np.ndarray], labels: list[str]):
    """Element matrices with the local DOFs ``released[e]`` (indices 0-11, pin flags)
    condensed out statically: u_r = -K_rr^-1 K_rk u_k (their rows and columns become
    zero). ``labels[e]`` names the element in an error (a release that leaves a
    mechanism)."""
    k, m = k.copy(), m.copy()
    for e, free in enumerate(released):
        if not len(free):
            continue
        kept = np.setdiff1d(np.arange(12), free)
        k_rr = k[e][np.ix_(free, free)]
        if np.linalg.matrix_rank(k_rr) < len(free):
            raise InputError(
                f"deck: {labels[e]}: its pin flags release a motion nothing resists (e.g. "
                "the same component at both ends)"
            )
        shape = np.zeros((12, len(kept)))
        shape[kept, np.arange(len(kept))] = 1.0
        shape[free] = -np.linalg.solve(k_rr, k[e][np.ix_(free, kept)])
        full = np.zeros((12, 12))
        full[:, kept] = shape
        k[e] = full.T @ k[e] @ full
        m[e] = full.T @ m[e] @ full
    return k, m


def to_global(local: np.ndarray, axes: np.ndarray, offsets: np.ndarray | None = None):
    """(E, 6 n, 6 n) element matrices in global DOFs of matrices in local DOFs whose axes
    are the rows of ``axes`` (E, 3, 3) (the same at every node); with ``offsets`` (E, n, 3)
    the element's nodes lie there from the grids (:func:`offset_transform`)."""
    n_el, size = local.shape[:2]
    n = size // 6
    turn = np.zeros((n_el, 2 * n, 3, 2 * n, 3))
    for a in range(2 * n):
        turn[:, a, :, a, :] = axes
    turn = turn.reshape(n_el, size, size)
    out = np.einsum("eai,eab,ebj->eij", turn, local, turn, optimize=True)
    if offsets is not None and np.any(offsets):
        t = offset_transform(offsets)
        out = np.einsum("eai,eab,ebj->eij", t, out, t, optimize=True)
    return out
