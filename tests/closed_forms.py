"""Closed-form responses of one damped mode to piecewise-linear forcing (test oracle).

q'' + 2 zeta w q' + w^2 q = f(t), at rest at t = 0. A ramp f = t (from t = 0) gives

    r(t) = (1/w^2) [t - 2 zeta / w
                    + e^{-zeta w t} ((2 zeta / w) cos(wd t) - ((1 - 2 zeta^2) / wd) sin(wd t))]

and any piecewise-linear force with breakpoints t_k is a sum of ramps started at t_k with
the change of slope there. This derivation is independent of jaxflex._discretize.
"""

from __future__ import annotations

import numpy as np

import fem


def ramp_response(t, omega: float, zeta: float):
    t = np.asarray(t, dtype=float)
    tp = np.maximum(t, 0.0)
    wd = omega * np.sqrt(1 - zeta**2)
    decay = np.exp(-zeta * omega * tp)
    r = (
        tp
        - 2 * zeta / omega
        + decay
        * ((2 * zeta / omega) * np.cos(wd * tp) - ((1 - 2 * zeta**2) / wd) * np.sin(wd * tp))
    ) / omega**2
    return np.where(t > 0, r, 0.0)


def piecewise_linear_response(t, force_samples, dt_s: float, omega: float, zeta: float):
    """Response at times t to a force linear between samples f_k at k dt (f_0 = 0 required,
    constant f_n after the last sample)."""
    f = np.asarray(force_samples, dtype=float)
    assert f[0] == 0.0
    slopes = np.diff(f) / dt_s
    slope_change = np.diff(np.concatenate([[0.0], slopes, [0.0]]))  # at t_0 .. t_n
    out = np.zeros_like(np.asarray(t, dtype=float))
    for k, c in enumerate(slope_change):
        if c != 0.0:
            out += c * ramp_response(np.asarray(t) - k * dt_s, omega, zeta)
    return out


def step_response(t, omega: float, zeta: float):
    """Response to a unit force switched on at t = 0."""
    t = np.asarray(t, dtype=float)
    wd = omega * np.sqrt(1 - zeta**2)
    s = zeta * omega
    return np.where(
        t >= 0, (1 - np.exp(-s * t) * (np.cos(wd * t) + s / wd * np.sin(wd * t))) / omega**2, 0.0
    )


def ss_plate_stress_error(element: str, mesh_m: float) -> float:
    """Largest error of the modal surface stresses (first four modes, sigma_xx, sigma_yy,
    tau_xy where the model reports them: element centroids, on the top surface or on both)
    of a simply supported 0.6 x 0.4 m, 1 mm steel plate in formulation ``element`` against
    the closed form, relative to each mode's peak: for mode (m, n), mass-normalised
    w = A sin(m pi x/a) sin(n pi y/b) with A = 2 / sqrt(rho h a b), so on the surface z = +-h/2
    sigma_xx = +-(h/2) E/(1 - nu^2) A pi^2 (m^2/a^2 + nu n^2/b^2) sin sin, and alike."""
    a, b, h = 0.6, 0.4, 1e-3
    part = fem.rectangular_plate(a, b, h, "steel", mesh_m, element=element)
    result = fem.modal_analysis(part, fem.SimplySupportedEdge("all"), n_modes=4, zeta=0.02)
    model = result.to_modal_model(points=10)
    steel = part.material
    amp = 2 / np.sqrt(steel.rho_kg_m3 * h * a * b)
    factor = (h / 2) * steel.E_pa / (1 - steel.nu**2) * amp * np.pi**2
    points = np.asarray(model.stress.points_m)
    x, y = points[:, :2].T
    side = np.where(points[:, 2] < 0, -1.0, 1.0)  # the bottom surface bends the other way
    modes = sorted(
        [(1, 1), (2, 1), (3, 1), (1, 2)], key=lambda k: (k[0] / a) ** 2 + (k[1] / b) ** 2
    )
    q_map = np.asarray(model.stress.stress.q_map).reshape(-1, 6, model.n_modes)
    worst = 0.0
    for i, (m, n) in enumerate(modes):
        ss = np.sin(m * np.pi * x / a) * np.sin(n * np.pi * y / b)
        cc = np.cos(m * np.pi * x / a) * np.cos(n * np.pi * y / b)
        exact = np.zeros((len(x), 6))
        exact[:, 0] = factor * ((m / a) ** 2 + steel.nu * (n / b) ** 2) * ss
        exact[:, 1] = factor * ((n / b) ** 2 + steel.nu * (m / a) ** 2) * ss
        exact[:, 5] = -factor * (1 - steel.nu) * (m / a) * (n / b) * cc
        exact *= side[:, None]
        ours = q_map[:, :, i] * np.sign(np.sum(q_map[:, :, i] * exact))  # sign is arbitrary
        worst = max(worst, np.abs(ours - exact).max() / np.abs(exact).max())
    return worst
