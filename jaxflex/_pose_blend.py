"""Blended orientation paths: through via orientations without stopping at them.

jaxflex._pose.orientation_path stops at every via orientation (each segment a geodesic turn
from rest to rest). :func:`blended_path` goes through them without stopping: the rotation
vector relative to the start, theta (R = R_0 exp([theta]x)), follows a C2 cubic spline
through the vias' rotation vectors theta_i = log(R_0^T R_i) (knots at the cumulative chord
lengths, natural ends), and the spline's parameter s follows one jerk-limited rest-to-rest
profile (jaxflex._pose.turn_acceleration, corners on the grid) over its whole length. The
path passes through every via exactly (s' > 0 there) and ends at rest at the last one.

At the samples (exact, to round-off, from the profile's piecewise-cubic s(t)):

    w = J_r(theta) theta',  alpha = w',  jerk = alpha'   (body components)

with theta' = theta_s s', J_r(theta) = I - (1 - cos a) / a^2 K + (a - sin a) / a^3 K^2
(K = [theta]x, a = |theta|) the right Jacobian of the exponential map: R^T R' = [w]x. The
time derivatives come from forward-mode differentiation (JAX) of the closed forms within
each step. The rate, acceleration and jerk limits (Euclidean norms) are checked at every
sample and mid-step (the jerk jumps at the grid's corners and at the spline's knots); where
the spline's shape adds to them (|theta_s| > 1 between knots, its curvature) the profile's
limit that is exceeded is lowered by the excess until they all hold. The vias must lie
within a half turn of the start (|theta_i| < pi: the exponential map is one-to-one there);
split a longer path.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from scipy.interpolate import CubicSpline

from jaxflex._pose import PosePath, as_rotation, axis_angle, axis_rotation, turn_acceleration
from jaxflex._profile import integrate
from jaxflex._scalars import check_positive
from jaxflex.errors import InputError

MAX_SLOWDOWNS = 50
PAD_SAMPLES = 512
HALF_TURN_MARGIN_RAD = 1e-3


def _right_jacobian(theta):
    """J_r(theta) (3, 3) of the exponential map (module docstring), series near 0."""
    a2 = theta @ theta
    small = a2 < 1e-8
    a = jnp.sqrt(jnp.where(small, 1.0, a2))
    c1 = jnp.where(small, 0.5 - a2 / 24.0, (1.0 - jnp.cos(a)) / jnp.where(small, 1.0, a2))
    c2 = jnp.where(
        small, 1.0 / 6.0 - a2 / 120.0, (a - jnp.sin(a)) / (a * jnp.where(small, 1.0, a2))
    )
    k = jnp.array(
        [[0.0, -theta[2], theta[1]], [theta[2], 0.0, -theta[0]], [-theta[1], theta[0], 0.0]]
    )
    return jnp.eye(3) - c1 * k + c2 * (k @ k)


def _rates(tau, start, coeffs, knot):
    """(theta, w, alpha, jerk) (4, 3) at ``tau`` s into a step that starts with the
    parameter's (s, s', s'', s''') = ``start`` (4,), on the spline piece with polynomial
    ``coeffs`` (4, 3) (highest power first) from ``knot``."""

    def theta(t):
        s = start[0] + start[1] * t + start[2] * t**2 / 2 + start[3] * t**3 / 6
        d = s - knot
        return ((coeffs[0] * d + coeffs[1]) * d + coeffs[2]) * d + coeffs[3]

    def omega(t):
        value, rate = jax.jvp(theta, (t,), (jnp.ones_like(t),))
        return _right_jacobian(value) @ rate

    def alpha(t):
        return jax.jvp(omega, (t,), (jnp.ones_like(t),))[1]

    jerk = jax.jvp(alpha, (tau,), (jnp.ones_like(tau),))[1]
    return jnp.stack([theta(tau), omega(tau), alpha(tau), jerk])


@jax.jit
def _rates_at(tau, starts, coeffs, knots):
    return jax.vmap(_rates)(tau, starts, coeffs, knots)


def _evaluate(spline: CubicSpline, profile: np.ndarray, dt_s: float, tau_s: float):
    """(T, 4, 3) theta, w, alpha, jerk at ``tau_s`` into every step of the parameter's
    ``profile`` (T, 4) (s, s', s'', s''' at each sample and its step's jerk)."""
    s = profile[:, 0] + profile[:, 1] * tau_s + profile[:, 2] * tau_s**2 / 2
    s = s + profile[:, 3] * tau_s**3 / 6
    piece = np.clip(np.searchsorted(spline.x, s, side="right") - 1, 0, spline.c.shape[1] - 1)
    padded = -(-len(s) // PAD_SAMPLES) * PAD_SAMPLES  # one compilation per bucket of lengths
    fill = (0, padded - len(s))
    out = _rates_at(
        jnp.full(padded, tau_s),
        jnp.asarray(np.pad(profile, (fill, (0, 0)), mode="edge")),
        jnp.asarray(np.pad(np.moveaxis(spline.c[:, piece], 1, 0), (fill, (0, 0), (0, 0)), "edge")),
        jnp.asarray(np.pad(spline.x[piece], fill, mode="edge")),
    )
    return np.asarray(out)[: len(s)]


def _parameter_profile(length: float, limits: tuple[float, float, float], dt_s: float):
    """(n+1, 4) s, s', s'' and the jerk of the step from each sample (0 at the last) of the
    jerk-limited rest-to-rest profile over ``length`` within ``limits`` (rate, acc, jerk)."""
    acc = turn_acceleration(length, *limits, dt_s)
    padded = np.zeros((acc.size, 3))
    padded[:, 0] = acc
    rate, position = (v[:, 0] for v in integrate(padded, dt_s))
    rate[-1] = 0.0  # at rest at the end (its round-off: the path must end at rest exactly)
    jerk = np.append(np.diff(acc) / dt_s, 0.0)
    return np.column_stack([position, rate, acc, jerk])


def via_rotation_vectors(poses: list[np.ndarray]) -> np.ndarray:
    """(N, 3) rotation vectors (rad) of R_0^T R_i for the rotations ``poses``; InputError
    where one is a half turn or more from the start (module docstring)."""
    out = []
    for i, pose in enumerate(poses):
        axis, angle = axis_angle(poses[0].T @ pose)
        if angle > np.pi - HALF_TURN_MARGIN_RAD:
            raise InputError(
                f"orientations[{i}]: {np.degrees(angle):.1f} deg from the start; a blended path "
                "stays within a half turn (< 180 deg) of its start: split the path there"
            )
        out.append(axis * angle)
    return np.array(out)


def blended_path(
    orientations, rate_rad_s: float, acc_rad_s2: float, jerk_rad_s3: float, dt_s: float
) -> PosePath:
    """The path through ``orientations`` (at least two rotation vectors (3,) rad or (3, 3)
    matrices, body to world; the first is the start) without stopping at the vias, within
    |w| <= ``rate_rad_s``, |alpha| <= ``acc_rad_s2`` and |jerk| <= ``jerk_rad_s3`` (module
    docstring), samples at ``dt_s`` s, from rest to rest."""
    dt_s = check_positive("dt_s", dt_s)
    limits = tuple(
        check_positive(n, v)
        for n, v in (("rate", rate_rad_s), ("acc", acc_rad_s2), ("jerk", jerk_rad_s3))
    )
    poses = [as_rotation(o, f"orientations[{i}]") for i, o in enumerate(orientations)]
    if len(poses) < 2:
        raise InputError("orientations: at least two (a start and a goal)")
    vias = via_rotation_vectors(poses)
    chords = np.linalg.norm(np.diff(vias, axis=0), axis=1)
    if not (chords > 1e-9).all():
        raise InputError("orientations: two consecutive orientations are the same")
    spline = CubicSpline(np.concatenate([[0.0], np.cumsum(chords)]), vias, bc_type="natural")
    scaled = limits
    for _ in range(MAX_SLOWDOWNS):
        profile = _parameter_profile(float(spline.x[-1]), scaled, dt_s)
        at_samples = _evaluate(spline, profile, dt_s, 0.0)
        mid_step = _evaluate(spline, profile[:-1], dt_s, 0.5 * dt_s)
        peaks = np.linalg.norm(np.concatenate([at_samples, mid_step]), axis=2).max(axis=0)[1:]
        ratio = peaks / np.array(limits)
        if (ratio <= 1.0 + 1e-9).all():
            theta = at_samples[:, 0]
            angle = np.linalg.norm(theta, axis=1)
            axes = theta / np.where(angle > 0, angle, 1.0)[:, None]
            turns = np.array(
                [axis_rotation(a, np.array([t]))[0] for a, t in zip(axes, angle, strict=True)]
            )
            return PosePath(poses[0][None] @ turns, at_samples[:, 1], at_samples[:, 2], dt_s)
        # the limit that is exceeded is lowered by its excess (the curvature's share of the
        # acceleration and jerk grows with the rate: it goes down with the rate's)
        scaled = tuple(v / max(1.0, 1.01 * r) for v, r in zip(scaled, ratio, strict=True))
    raise InputError(
        "orientations: no blended path within the limits found (the vias turn too sharply); "
        "use jaxflex.response.orientation_path (stops at each via)"
    )
