"""The analytic simply supported plate: a fixture must itself be right."""

from __future__ import annotations

import numpy as np
import pytest

from jaxflex._analytic import plate_frequencies_hz, simply_supported_plate


def test_fundamental_frequency_of_a_square_plate():
    # omega_11 = 2 pi^2 / a^2 sqrt(D / (rho h)) (Leissa, Vibration of Plates, SSSS square)
    a, h, E, nu, rho = 1.0, 2e-3, 70e9, 0.33, 2700.0
    D = E * h**3 / (12 * (1 - nu**2))
    expected = 2 * np.pi**2 / a**2 * np.sqrt(D / (rho * h)) / (2 * np.pi)
    f = plate_frequencies_hz(a, a, h, E, nu, rho, np.array([[1, 1]]))
    assert f[0] == pytest.approx(expected, rel=1e-14)


def test_modes_are_mass_normalised_and_orthogonal():
    model = simply_supported_plate(1.2, 0.7, 1e-3, n_modes=6, points=np.zeros((1, 2)))
    # midpoint quadrature on a fine grid: error O(1/N^2) ~ 1e-5 for N = 400
    n = 400
    x = (np.arange(n) + 0.5) / n * 1.2
    y = (np.arange(n) + 0.5) / n * 0.7
    xy = np.stack(np.meshgrid(x, y, indexing="ij"), -1).reshape(-1, 2)
    fine = simply_supported_plate(1.2, 0.7, 1e-3, n_modes=6, points=xy)
    w = fine.shapes[:, 2, :]
    mass_matrix = 7850 * 1e-3 * (w.T @ w) * (1.2 / n) * (0.7 / n)
    np.testing.assert_allclose(mass_matrix, np.eye(6), atol=1e-4)
    # participation Gamma = int rho h w dA
    gamma = 7850 * 1e-3 * w.sum(axis=0) * (1.2 / n) * (0.7 / n)
    np.testing.assert_allclose(gamma, model.gamma[:, 2], atol=1e-4 * np.abs(model.gamma).max())


def test_participation_sums_to_the_mass():
    model = simply_supported_plate(n_modes=2000, points=10)
    mass = model.meta["mass_kg"]
    total = np.sum(model.gamma[:, 2] ** 2)
    # the tail of sum 64/(pi^4 m^2 n^2) over odd orders beyond ~45 x 45 is < 2 %
    assert 0.98 * mass < total < mass
    assert np.all(model.gamma[:, :2] == 0)


def test_frequencies_ascend_and_points_checked():
    model = simply_supported_plate(n_modes=30)
    assert np.all(np.diff(model.freq_hz) >= 0)
    with pytest.raises(ValueError, match="outside"):
        simply_supported_plate(points=np.array([[2.0, 0.1]]))
