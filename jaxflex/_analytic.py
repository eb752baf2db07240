"""Closed-form modal model of a simply supported rectangular Kirchhoff plate.

Plate a x b (m) in the xy plane, thickness h (m), Young's modulus E (Pa), Poisson ratio nu,
density rho (kg/m^3), bending stiffness D = E h^3 / (12 (1 - nu^2)). Its modes are

    w_mn(x, y) = 2 / sqrt(rho h a b) * sin(m pi x / a) sin(n pi y / b)    (mass-normalised)
    omega_mn   = pi^2 ((m/a)^2 + (n/b)^2) sqrt(D / (rho h))
    Gamma_mn,z = int rho h w_mn dA = 8 sqrt(rho h a b) / (m n pi^2)  for odd m, n, else 0,

and sum over all modes of Gamma_z^2 equals the plate mass rho h a b. Base acceleration in
x or y does not excite bending modes (Gamma_x = Gamma_y = 0). This is an exact fixture for
tests and the demo before the finite-element pipeline is used.

Also the frequencies of a simply supported (shear-diaphragm) circular cylindrical panel by
Donnell-Mushtari shallow-shell theory (:func:`cylindrical_panel_frequencies_hz`), the
closed form the finite-element shells are checked against.
"""

from __future__ import annotations

import numpy as np

from jaxflex._scalars import check_positive
from jaxflex.model import ModalModel

STEEL = {"E_pa": 210e9, "nu": 0.3, "rho_kg_m3": 7850.0}


def plate_frequencies_hz(
    width_m: float,
    height_m: float,
    thickness_m: float,
    E_pa: float,
    nu: float,
    rho_kg_m3: float,
    orders: np.ndarray,
) -> np.ndarray:
    """Natural frequencies (Hz) of the (m, n) modes given as an (M, 2) integer array."""
    bending = E_pa * thickness_m**3 / (12.0 * (1.0 - nu**2))
    m, n = orders[:, 0], orders[:, 1]
    omega = (
        np.pi**2
        * ((m / width_m) ** 2 + (n / height_m) ** 2)
        * np.sqrt(bending / (rho_kg_m3 * thickness_m))
    )
    return omega / (2.0 * np.pi)


def cylindrical_panel_frequencies_hz(
    axial_m: float,
    arc_m: float,
    radius_m: float,
    thickness_m: float,
    E_pa: float,
    nu: float,
    rho_kg_m3: float,
    count: int,
) -> np.ndarray:
    """The ``count`` lowest frequencies (Hz) of a circular cylindrical panel of axial length
    ``axial_m``, arc length ``arc_m`` and radius ``radius_m``, simply supported on all edges
    (shear diaphragm), by Donnell-Mushtari shallow-shell theory (Soedel, "Vibrations of
    Shells and Plates"): omega^2 = D / (rho h) k^4 + E / (rho R^2) (m pi / a)^4 / k^4 with
    k^2 = (m pi / a)^2 + (n pi / b)^2, m, n = 1 ... 8. Accurate to about 1 % for shallow
    panels (arc / radius below ~0.5)."""
    bending = E_pa * thickness_m**3 / (12.0 * (1.0 - nu**2))
    m, n = np.meshgrid(np.arange(1, 9), np.arange(1, 9), indexing="ij")
    km, kn = m * np.pi / axial_m, n * np.pi / arc_m
    k2 = km**2 + kn**2
    omega2 = (
        bending / (rho_kg_m3 * thickness_m) * k2**2
        + E_pa / (rho_kg_m3 * radius_m**2) * km**4 / k2**2
    )
    return np.sort(np.sqrt(omega2.ravel()) / (2 * np.pi))[:count]


def _mode_orders(n_modes: int, width_m: float, height_m: float) -> np.ndarray:
    span = int(np.ceil(np.sqrt(n_modes))) * 3 + 3
    m, n = np.meshgrid(np.arange(1, span + 1), np.arange(1, span + 1), indexing="ij")
    orders = np.stack([m.ravel(), n.ravel()], axis=1)
    key = (orders[:, 0] / width_m) ** 2 + (orders[:, 1] / height_m) ** 2
    return orders[np.argsort(key, kind="stable")[:n_modes]]


def grid_points(width_m: float, height_m: float, n_points: int) -> np.ndarray:
    """About ``n_points`` points on a regular grid over the plate (edges included), (K, 3)."""
    nx = max(2, round(np.sqrt(n_points * width_m / height_m)))
    ny = max(2, round(n_points / nx))
    x, y = np.meshgrid(np.linspace(0, width_m, nx), np.linspace(0, height_m, ny), indexing="ij")
    return np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)


def simply_supported_plate(
    width_m: float = 1.5,
    height_m: float = 0.8,
    thickness_m: float = 1e-3,
    *,
    E_pa: float = STEEL["E_pa"],
    nu: float = STEEL["nu"],
    rho_kg_m3: float = STEEL["rho_kg_m3"],
    n_modes: int = 20,
    zeta: float = 0.02,
    points: int | np.ndarray = 600,
) -> ModalModel:
    """Modal model of a simply supported plate; ``points`` is a count (regular grid) or an
    array of (x, y) or (x, y, z) coordinates in m on the plate."""
    for name, value in (
        ("width_m", width_m),
        ("height_m", height_m),
        ("thickness_m", thickness_m),
        ("E_pa", E_pa),
        ("rho_kg_m3", rho_kg_m3),
    ):
        check_positive(name, value)
    if not 0 <= nu < 0.5:
        raise ValueError(f"nu: Poisson ratio must lie in [0, 0.5), got {nu}")
    if isinstance(points, int | np.integer):
        xyz = grid_points(width_m, height_m, int(points))
    else:
        xyz = np.asarray(points, dtype=float)
        if xyz.ndim != 2 or xyz.shape[1] not in (2, 3):
            raise ValueError(f"points: expected shape (K, 2) or (K, 3), got {xyz.shape}")
        if xyz.shape[1] == 2:
            xyz = np.column_stack([xyz, np.zeros(len(xyz))])
        outside = (xyz[:, 0] < 0) | (xyz[:, 0] > width_m) | (xyz[:, 1] < 0) | (xyz[:, 1] > height_m)
        if outside.any():
            i = int(np.argmax(outside))
            raise ValueError(
                f"points: point {i} at {xyz[i, :2].tolist()} m lies outside the "
                f"{width_m} x {height_m} m plate"
            )
    orders = _mode_orders(int(n_modes), width_m, height_m)
    m, n = orders[:, 0], orders[:, 1]
    mass_kg = rho_kg_m3 * thickness_m * width_m * height_m
    amplitude = 2.0 / np.sqrt(mass_kg)
    w = (
        amplitude
        * np.sin(np.pi * np.outer(xyz[:, 0], m) / width_m)
        * np.sin(np.pi * np.outer(xyz[:, 1], n) / height_m)
    )
    shapes = np.zeros((len(xyz), 3, len(orders)))
    shapes[:, 2, :] = w
    gamma = np.zeros((len(orders), 3))
    odd = (m % 2 == 1) & (n % 2 == 1)
    gamma[odd, 2] = 8.0 * np.sqrt(mass_kg) / (m[odd] * n[odd] * np.pi**2)
    freq = plate_frequencies_hz(width_m, height_m, thickness_m, E_pa, nu, rho_kg_m3, orders)
    return ModalModel(
        freq_hz=freq,
        zeta=np.full(len(orders), float(zeta)),
        gamma=gamma,
        shapes=shapes,
        points=xyz,
        meta={
            "source": "analytic simply supported Kirchhoff plate",
            "units": "SI (m, s, kg, Pa)",
            "plate": {"width_m": width_m, "height_m": height_m, "thickness_m": thickness_m},
            "material": {"E_pa": E_pa, "nu": nu, "rho_kg_m3": rho_kg_m3},
            "mode_orders": orders.tolist(),
            "mass_kg": mass_kg,
        },
    )
