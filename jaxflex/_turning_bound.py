"""The bound on the terms the turning engine leaves out, true at any step (JAX).

The turning engine (jaxflex._turning) integrates the modal forcing of the rigid motion and
leaves out the loads of the deformation itself: -M [2 w x u' + alpha x u + w x (w x u)]
(gyroscopic, Euler-on-deformation, spin softening). In the kept modes they are a load linear
in the modal state x = (q, q') (total q, the sag included),

    N(t) x = Q(t) q + V(t) q',   Q = -(G(alpha) + P(w)),   V = -2 G(w),

with the couplings G(v) = sum_k v_k G_k and P(w) = sum_kl w_k w_l P_kl of jaxflex._rotation.
The error e = q_full - q obeys e'' + 2 Z Omega e' + Omega^2 e = N (x + e), e(0) = 0; split
e = y + d.

**The path and the state between samples.** Within a step (s in [0, h], h = dt_s) the angular
acceleration is linear (the path's first-order hold) and the rate its integral,
alpha(s) = alpha_k + (alpha_k+1 - alpha_k) s / h, w(s) = w_k + alpha_k s + (alpha_k+1 -
alpha_k) s^2 / (2 h): exact for a turn about a fixed axis and the geodesic segments of
jaxflex._pose (jaxflex._turning_collision turns the part between samples the same way). So
Q(s) = sum_p Q_p s^p (p <= 4) and V(s) = sum_p V_p s^p (p <= 2) are polynomials, written in
the path's principal axes (:func:`principal_axes`) as sums over nine coupling matrices (the
G's and the pairs of P's) with scalar coefficients. The kept state between samples is the
engine's, exact for the forcing f linear on the step: per mode x_j(s) = Phi_j(s) z_j +
(c0_j + c1_j s, c1_j), the free vibration of z_j = x_j,k - (c0_j, c1_j) plus the particular
solution of the linear forcing (c1 = (f_k+1 - f_k) / (h omega^2), c0 = (f_k - 2 zeta omega
c1) / omega^2).

**First order, exact at any time.** y'' + 2 Z Omega y' + Omega^2 y = N(t) x(t) along the
computed response, N without its s^3 and s^4 terms (the rate times the jerk and the jerk
squared: ~1e-4 of the load at robot rates; they join the remainder below). At a time tau
into the step (variation of constants)

    y(tau) = Phi(tau) y_k + sum_p sum_j [Q_p,mj H^q_p,mj(tau) + V_p,mj H^v_p,mj(tau)] z_j
             + polynomial terms,
    H^r_p,mj(tau) = int_0^tau Phi_m(tau - s) b s^p e_r^T Phi_j(s) ds      (2 x 2 per pair),

and the polynomial terms the same with the kernels int_0^tau Phi_m(tau - s) b s^p ds. The
kernels depend only on the modes and the step: computed once per model and dt by composite
Gauss-Legendre quadrature (QUADRATURE_NODES per panel, panels short enough that (omega_m +
omega_j) times a panel is at most PANEL_RAD: the integrands are entire, the quadrature error
is far below rounding), stepped from one sub-sample to the next (K(tau') = Phi_m(tau' - tau)
K(tau) + the integral over [tau, tau']), so the set-up grows with omega_max dt, not with its
square (a part 1e6 times stiffer than steel at 1 ms: 16 min before, about a minute now);
tests/test_turning_bound.py checks the kernels and y against adaptive integrations. y is so
exact for the continuous load, not its samples: the load oscillates at the modes'
frequencies, which a 10 ms step does not resolve (the bound taken at the samples saw
0.78-0.97 of the true effect there). Only the steps where the path turns carry a load
(:func:`turning_window`): y is zero before them and vibrates freely after them.

**Its largest displacement, certified.** y is evaluated at S sub-samples per step (S from the
modes: omega_max h / S <= SUBSTEP_RAD and omega_1 h / S <= FIRST_MODE_RAD). At every point,
between two sub-samples a < b, |Phi_p y(t)| <= max(|Phi_p y(a)|, |Phi_p y(b)|) + (b - a)^2 / 8
sum_m |phi_m(p)| sup |y_m''| (convexity of the norm, as jaxflex._settle), with sup |y_m''| <=
sup |g_m| + (1 + 2 zeta) omega_m (E_m(a) + (b - a) sup |g_m|): the energy radius E_m =
sqrt(y_m'^2 + omega_m^2 y_m^2) grows at most by |g_m| per second, and sup |g_m| over a step
follows from the coefficients (the triangle inequality over the nine matrices, exact entry
by entry for a turn about a fixed axis) and the kept state's free and particular parts. The
maximum over points and sub-samples is exact where it is certified: the CANDIDATES
sub-samples with the largest bound sum_m max_p |phi_m(p)| |y_m| are evaluated at every point
(jaxflex._deviation's pruned evaluation, with the caller's deviation: :class:`NeglectedTerms`)
and the rest stay below the next largest bound (the larger of the two is taken). After the
load y vibrates freely: a point moves at most sum_m |phi_m(p)| E_m / omega_m of the energy
where it ends.

**Remainder, Gronwall.** d = e - y obeys the full equation forced by N y and by the s^3 and
s^4 terms R x left out of y, its own neglected load N d feeding back. With E = sqrt(|d'|^2 +
|Omega d|^2), the damping taking energy out and |d'.V d'| <= |V_sym| |d'|^2: E' <= |N y| +
|R x| + c(t) E, c = |V_sym| + |Q Omega^-1|, so E(t) <= exp(int c) int (|N y| + |R x|) (a
point moves at most F E, F = max_p sqrt(sum_m |phi_m(p)|^2 / omega_m^2)): second order in
the rates but for the tiny R x, each bounded over a step by the coefficients as above (c by
the matrices' Frobenius norms, above the spectral ones) and |y| by its energy at the
sub-samples plus the step's growth. Every bound is of the modal matrices in the path's own
axes, so the same turn gives the same bound in any frame.

The bound is the first order's largest displacement plus F E. **Fallback**: a model without
the couplings gets the energy estimate alone (jaxflex._rotation): the gyroscopic load does no
work, the other two are at most (|alpha| + |w|^2) |e|_M, so E' <= L(t) + c(t) E with
L = 2 |w| |q'| + (|alpha| + |w|^2) |q| and c = (|alpha| + |w|^2) / omega_1, each bounded over
the step (the rates by the path's polynomials, the state by its free and particular parts).

Measured against an independent floating-frame integration with every term
(tests/test_turning_bound.py, ``python tests/floating_frame.py [--panel]``): 1.3-1.4 times
the true effect on the curved panel at 10 ms and 2 ms, 1.6-1.9 on a stiff cantilever.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from numpy.polynomial.legendre import leggauss

from jaxflex._budget import Need
from jaxflex._discretize import propagators
from jaxflex._engine import padded_steps

SUBSTEP_RAD = 2.0  # omega_max times the sub-sample step of the first-order response
FIRST_MODE_RAD = 0.5  # omega_1 times it (the modes that carry the response)
CANDIDATES = 64  # sub-samples evaluated at every point
QUADRATURE_NODES = 10
PANEL_RAD = 1.0  # (omega_m + omega_j) times a quadrature panel
DEGREE = 4  # of Q(s); V(s) has degree 2
# the unordered pairs (k, l) of P(w) = sum_kl w_k w_l P_kl: P_kk, and P_kl + P_lk for k < l
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
# the eight coefficient matrices of N(s) on a step: s^p Q_p on q (p = 0..4), s^p V_p on q'
# (p = 0..2); row c acts on component ROW_OF[c] of x with the power POWER_OF[c]. The first
# EXACT rows are integrated exactly, the last two (s^3 Q_3 + s^4 Q_4, the rate times the jerk
# and the jerk squared) are bounded in the remainder (module docstring)
ROW_OF = (0, 0, 0, 1, 1, 1, 0, 0)
POWER_OF = (0, 1, 2, 0, 1, 2, 3, 4)
EXACT = 6
CHUNK_ELEMENTS = 1 << 21  # steps per chunk: at most this many entries of a step term
EPS = float(np.finfo(np.float64).eps)
# rates below this share of the path's largest are the rounding of its integration (a turn
# ends at rest to ~1e-16 rad/s): the load they carry is far below the rounding of y
REST_SHARE = 1e-12
# the kernels' set-up (bound_data), planned: CPU s per term of its quadratures' einsum (6.2-8.4
# ns measured on the project's 2-core machine for 4-30 modes and 330-3 300 sub-samples), and
# the copies of the kernels held at once (the steps' integrals, the stepped kernels, their
# reshaped copy, the device's)
SETUP_S_PER_TERM = 1e-8
SETUP_COPIES = 4


def substeps(omega_rad_s: np.ndarray, dt_s: float) -> int:
    """Sub-samples S per step of the first-order response (module docstring)."""
    omega = np.asarray(omega_rad_s, dtype=np.float64)
    need = max(omega.max() * dt_s / SUBSTEP_RAD, omega.min() * dt_s / FIRST_MODE_RAD)
    return max(1, math.ceil(need - 1e-9))


def _quadrature(length_s: float, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, weights) of composite Gauss-Legendre on [0, length_s], panels of at most
    PANEL_RAD / rate."""
    panels = max(1, math.ceil(rate * length_s / PANEL_RAD))
    x, w = leggauss(QUADRATURE_NODES)
    edges = np.linspace(0.0, length_s, panels + 1)
    mid, half = 0.5 * (edges[:-1] + edges[1:]), 0.5 * np.diff(edges)
    return (mid[:, None] + half[:, None] * x).ravel(), (half[:, None] * w).ravel()


def _kernel_steps(omega, zeta, starts_s: np.ndarray, step_s: float, u, w):
    """The kernels of the module docstring's integrands over [start, start + step_s] only,
    taken at tau = start + step_s, for each start of ``starts_s`` (K,): homogeneous (K, M,
    EXACT, M, 2 i, 2 o) and polynomial (K, 4, M, 2), by the quadrature (nodes ``u``, weights
    ``w``) on [0, step_s] shifted to each step: the left factor Phi_m(tau - s) is the same
    for all."""
    left = propagators(omega, zeta, (step_s - u)[:, None], np).phi[..., :, 1]  # (X, M, 2)
    s = starts_s[:, None] + u  # (K, X)
    right = propagators(omega, zeta, s[..., None], np).phi  # (K, X, M, 2 r, 2 i)
    powers = s[..., None] ** np.arange(4)  # (K, X, 4)
    rows = right[..., ROW_OF[:EXACT], :]  # (K, X, M j, EXACT, 2 i)
    weighted = w[:, None] * powers[..., list(POWER_OF[:EXACT])]  # (K, X, EXACT)
    homogeneous = np.einsum("kxc,xmo,kxjci->kmcjio", weighted, left, rows)
    polynomial = np.einsum("x,kxp,xmo->kpmo", w, powers, left)
    return homogeneous, polynomial


def _kernels(omega, zeta, dt_s: float, n_sub: int) -> tuple[np.ndarray, np.ndarray]:
    """The kernels of the module docstring at the sub-samples tau_s = s dt / S (s = 1..S):
    homogeneous (S, M, EXACT, M, 2 i, 2 o) [s, m, c, j, i, o] = int_0^tau [Phi_m(tau - s') b]_o
    s'^p [Phi_j(s')]_(r, i) ds' (p, r of row c) and polynomial (S, 4, M, 2) [s, p, m, o] =
    int_0^tau [Phi_m(tau - s') b]_o s'^p ds'. Stepped from one tau to the next, K(tau') =
    Phi_m(tau' - tau) K(tau) + the integral over [tau, tau'] (Phi_m(tau' - s) = Phi_m(tau' -
    tau) Phi_m(tau - s)), so the quadrature covers [0, dt] once: its cost grows with omega_max
    dt, not with its square. The sub-steps are equal: their integrals are evaluated together,
    in chunks of steps (CHUNK_ELEMENTS entries of the homogeneous kernels each)."""
    m, step_s = np.size(omega), dt_s / n_sub
    starts = step_s * np.arange(n_sub)
    u, w = _quadrature(step_s, 2.0 * float(np.max(omega)))
    chunk = max(1, CHUNK_ELEMENTS // (u.size * m * EXACT * m * 4))  # terms of the einsum
    parts = [
        _kernel_steps(omega, zeta, starts[i : i + chunk], step_s, u, w)
        for i in range(0, n_sub, chunk)
    ]
    step_h = np.concatenate([h for h, _ in parts])
    step_p = np.concatenate([p for _, p in parts])
    carry = propagators(omega, zeta, step_s, np).phi  # (M, 2, 2): Phi over one sub-step
    homogeneous, polynomial = np.empty_like(step_h), np.empty_like(step_p)
    homogeneous[0], polynomial[0] = step_h[0], step_p[0]
    for k in range(1, n_sub):
        homogeneous[k] = np.einsum("mab,mcjib->mcjia", carry, homogeneous[k - 1]) + step_h[k]
        polynomial[k] = np.einsum("mab,pmb->pma", carry, polynomial[k - 1]) + step_p[k]
    return homogeneous, polynomial


@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True)
class BoundData:
    """What the bound needs of a model at one step, built once (:func:`bound_data`).

    step_phi (M, 2, 2) Phi(dt); sub_phi (S, M, 2, 2) Phi at the sub-samples tau_s = s dt / S
    (s = 1..S); homogeneous (M, 6, M, 2, 2 S) and polynomial (M, 2, 6, 2 S): the kernels of
    each row at every tau_s, the polynomial ones for c0 and c1 (module docstring); basis
    gyroscopic (3, M, M) and spin (3, 3, M, M) the couplings (jaxflex._rotation; all None: the
    energy estimate); norms (K, M) the shape norms, peak (M,)
    their largest per mode, flex () F.
    """

    omega: Any
    zeta: Any
    step_phi: Any
    sub_phi: Any
    homogeneous: Any
    polynomial: Any
    gyroscopic: Any
    spin: Any
    norms: Any
    peak: Any
    flex: Any
    dt_s: float
    substeps: int

    def tree_flatten(self):
        children = (self.omega, self.zeta, self.step_phi, self.sub_phi, self.homogeneous,
                    self.polynomial, self.gyroscopic, self.spin, self.norms,
                    self.peak, self.flex)  # fmt: skip
        return children, (self.dt_s, self.substeps)

    @classmethod
    def tree_unflatten(cls, aux, children):
        return cls(*children, *aux)


def setup_need(model, dt_s: float) -> Need:
    """What :func:`bound_data` takes to build the kernels of ``model`` at step ``dt_s`` s
    (nothing for a model without the modes' couplings): S sub-samples per step (growing with
    omega_max dt), each kernel (M, 6, M, 2, 2) entries, one quadrature over the step; in
    memory SETUP_COPIES of them, in time SETUP_S_PER_TERM per term of the quadratures."""
    rotation = getattr(model, "rotation", None)
    if rotation is None or rotation.gyroscopic is None:
        return Need("the turning bound's kernels (none: no mode couplings)")
    omega = np.asarray(model.omega_rad_s, dtype=np.float64)
    n_sub, m = substeps(omega, dt_s), omega.size
    panels = max(1, math.ceil(2.0 * float(omega.max()) * dt_s / n_sub / PANEL_RAD))
    entries = n_sub * m * EXACT * m * 4
    return Need(
        f"the turning bound's kernels ({n_sub:,} sub-samples per {dt_s:g} s step, {m} modes)",
        SETUP_COPIES * 8.0 * entries,
        SETUP_S_PER_TERM * QUADRATURE_NODES * panels * entries,
        "use a coarser --dt or fewer modes",
    )


def bound_data(model, dt_s: float, n_sub: int | None = None) -> BoundData:
    """The :class:`BoundData` of a concrete ``model`` with its rotation data at step
    ``dt_s`` s, built with NumPy once per model and step (cached on the model)."""
    cache = model.__dict__.setdefault("_turning_bound", {})
    if (dt_s, n_sub) not in cache:
        cache[dt_s, n_sub] = jax.device_put(_build(model, float(dt_s), n_sub))
    return cache[dt_s, n_sub]


def _build(model, dt_s: float, n_sub) -> BoundData:
    omega, zeta = np.asarray(model.omega_rad_s), np.asarray(model.zeta)
    n_sub = substeps(omega, dt_s) if n_sub is None else n_sub
    taus = dt_s * np.arange(1, n_sub + 1) / n_sub
    norms = np.asarray(model.shape_norms)
    flex = np.sqrt(np.max(np.sum(norms**2 / omega**2, axis=1)))
    rotation = model.rotation
    homogeneous = polynomial = None
    if rotation.gyroscopic is not None:
        kernels, poly = _kernels(omega, zeta, dt_s, n_sub)
        m = omega.size
        homogeneous = np.moveaxis(kernels, 0, -2)  # (M, 6, M, 2, S, 2)
        homogeneous = homogeneous.reshape(m, EXACT, m, 2, 2 * n_sub)
        poly = np.moveaxis(poly, 0, 2)  # (4, M, S, 2)
        rows = zip(ROW_OF[:EXACT], POWER_OF[:EXACT], strict=True)
        # the particular part (c0 + c1 s, c1): c0 s^p and c1 s^(p+1) on q, c1 s^p on q'
        pairs = [(p, p + 1) if row == 0 else (None, p) for row, p in rows]
        zero = np.zeros_like(poly[0])
        poly0 = np.stack([zero if p is None else poly[p] for p, _ in pairs], axis=1)
        poly1 = np.stack([poly[p] for _, p in pairs], axis=1)  # (M, 6, S, 2)
        polynomial = np.stack([poly0, poly1], axis=1).reshape(m, 2, EXACT, 2 * n_sub)
    return BoundData(
        omega=omega,
        zeta=zeta,
        step_phi=propagators(omega, zeta, dt_s, np).phi,
        sub_phi=propagators(omega[None], zeta[None], taus[:, None], np).phi,
        homogeneous=homogeneous,
        polynomial=polynomial,
        gyroscopic=rotation.gyroscopic,
        spin=rotation.spin,
        norms=norms,
        peak=norms.max(axis=0),
        flex=flex,
        dt_s=dt_s,
        substeps=n_sub,
    )


# _SELECT[a, b, p] = 1 where a + b = p: the powers of a product of two quadratics
_SELECT = np.zeros((3, 3, DEGREE + 1))
for _a in range(3):
    for _b in range(3):
        _SELECT[_a, _b, _a + _b] = 1.0


def rate_polynomials(omega_rad_s, alpha_rad_s2, dt_s: float):
    """(W (N, 3, 3) [step, power, axis], A (N, 2, 3)): w(s) = sum_p W_p s^p and alpha(s) =
    sum_p A_p s^p on each step of the path's samples (N+1, 3) (module docstring)."""
    w, a = omega_rad_s, alpha_rad_s2
    slope = (a[1:] - a[:-1]) / dt_s
    return (
        jnp.stack([w[:-1], a[:-1], 0.5 * slope], axis=1),
        jnp.stack([a[:-1], slope], axis=1),
    )


def load_coefficients(w_poly, a_poly):
    """(N, 8, 9) the coefficients of N(s) on each step: row c (ROW_OF, POWER_OF) is
    sum_x coef[c, x] B_x over the basis B = (G_0, G_1, G_2, the pairs of P):
    Q_p = -(G(A_p) + sum_{a+b=p} P(W_a, W_b)), V_p = -2 G(W_p)."""
    k, l = np.array(PAIRS).T
    products = jnp.einsum("nak,nbl,abp->npkl", w_poly, w_poly, _SELECT)[:, :, k, l]  # (N, 5, 6)
    gyro_q = jnp.concatenate([a_poly, jnp.zeros_like(products[:, :3, :3])], axis=1)
    q = -jnp.concatenate([gyro_q, products], axis=2)  # (N, 5, 9): p = 0..4
    v = jnp.concatenate([-2.0 * w_poly, jnp.zeros_like(products[:, :3])], axis=2)
    return jnp.concatenate([q[:, :3], v, q[:, 3:]], axis=1)


def kept_parts(data: BoundData, states, force):
    """The kept state on each step as free vibration plus the particular solution of its
    linear forcing (module docstring): z (N, M, 2), c0, c1 (N, M), and sup |q_j|, sup |q_j'|
    over the step (N, M) (the free part's energy does not grow; an allowance for the rounding
    of the subtraction, as jaxflex._engine.derivative_bounds)."""
    omega, zeta, dt = data.omega, data.zeta, data.dt_s
    slope = (force[1:] - force[:-1]) / dt
    c1 = slope / omega**2
    c0 = (force[:-1] - 2.0 * zeta * omega * c1) / omega**2
    q, v = states[:-1, :, 0], states[:-1, :, 1]
    z = jnp.stack([q - c0, v - c1], axis=-1)
    scale = omega * jnp.abs(q) + jnp.abs(force[:-1]) / omega + 3.0 * jnp.abs(c1) + jnp.abs(v)
    free = jnp.hypot(z[..., 1], omega * z[..., 0]) + 8.0 * EPS * scale
    sup_q = free / omega + jnp.maximum(jnp.abs(c0), jnp.abs(c0 + c1 * dt))
    return z, c0, c1, sup_q, free + jnp.abs(c1)


class FrameBasis(NamedTuple):
    """The couplings in the path's principal frame (:func:`principal_axes`): ``basis``
    (9, M, M) G'_0, G'_1, G'_2 and the pairs of P' (PAIRS), ``size`` (9, M, M) their
    absolute values, ``norms`` (2, 9) |B_x Omega^-1| and |sym B_x| (Frobenius)."""

    basis: Any
    size: Any
    norms: Any


def frame_basis(data: BoundData, axes) -> FrameBasis:
    """The :class:`FrameBasis` of the couplings for the orthonormal ``axes`` (3, 3)
    (columns)."""
    gyro = jnp.einsum("ka,kmj->amj", axes, data.gyroscopic)
    spin = jnp.einsum("ka,lb,klmj->abmj", axes, axes, data.spin)
    pairs = [spin[k, l] if k == l else spin[k, l] + spin[l, k] for k, l in PAIRS]
    basis = jnp.concatenate([gyro, jnp.stack(pairs)])
    sym = 0.5 * (basis + jnp.swapaxes(basis, 1, 2))
    norms = jnp.stack([jnp.sqrt(jnp.sum((basis / data.omega) ** 2, axis=(1, 2))),
                       jnp.sqrt(jnp.sum(sym**2, axis=(1, 2)))])  # fmt: skip
    return FrameBasis(basis, jnp.abs(basis), norms)


def coefficient_sizes(data: BoundData, coef):
    """(N, 3, 9) sup over each step of |the coefficient of B_x| on q and on q' (rows 0, 1)
    and of the rows bounded, not integrated (2, on q): the coefficients' absolute values
    times the step's powers."""
    powers = data.dt_s ** np.array(POWER_OF, dtype=np.float64)
    rows = np.array(ROW_OF)
    select = np.stack([rows == 0, rows == 1, np.arange(rows.size) >= EXACT])
    return jnp.einsum("ncx,c,rc->nrx", jnp.abs(coef), powers, select)


def row_sup(frame: FrameBasis, sizes, sup_q, sup_v):
    """(N, M) sup over each step of |(Q(s) a + V(s) b)_m| for any a, b with |a_j| <= sup_q,
    |b_j| <= sup_v (N, M): sum_x |coefficient_x| (|B_x| a)_m, the triangle inequality over
    the basis of the path's frame (exact entry by entry for a turn about a fixed axis), with
    the coefficient sizes (N, 2, 9) on q and q'."""
    size = jnp.stack([sup_q, sup_v], axis=1)  # (N, 2, M)
    return jnp.einsum("nrx,nrxm->nm", sizes, jnp.einsum("xmj,nrj->nrxm", frame.size, size))


def _step_terms(data: BoundData, frame: FrameBasis, w_poly, a_poly, z, c0, c1):
    """On each step of a chunk: the forced part of y at the sub-samples (N, M, S, 2) of the
    EXACT rows and the coefficient sizes (N, 3, 9) (:func:`coefficient_sizes`)."""
    coef = load_coefficients(w_poly, a_poly)
    exact = coef[:, :EXACT]
    loads = jnp.einsum("ncx,xmj->mncj", exact, frame.basis)  # (M, N, EXACT, M)
    m, n = loads.shape[:2]
    forced = jnp.einsum("mncj,nji,mcjiy->nmy", loads, z, data.homogeneous)
    # the particular parts: sum_x coef_x B_x c, one product with the basis for both
    particular = jnp.einsum("xmj,nkj->nkxm", frame.basis, jnp.stack([c0, c1], axis=1))
    particular = jnp.einsum("ncx,nkxm->nmkc", exact, particular)
    forced += jnp.einsum("nmkc,mkcy->nmy", particular, data.polynomial)
    return forced.reshape(n, m, data.substeps, 2), coefficient_sizes(data, coef)


def _chunked(function, arrays, n_modes: int):
    """``function`` of the per-step ``arrays`` (leading axis N) applied in chunks of steps
    (jax.lax.map) so that a chunk's step terms hold at most CHUNK_ELEMENTS entries."""
    n = arrays[0].shape[0]
    chunk = n
    while chunk * 16 * n_modes * n_modes > CHUNK_ELEMENTS and chunk % 2 == 0:
        chunk //= 2
    if chunk == n:
        return function(*arrays)
    split = [x.reshape(n // chunk, chunk, *x.shape[1:]) for x in arrays]
    out = jax.lax.map(lambda xs: function(*xs), split)
    return jax.tree_util.tree_map(lambda x: x.reshape(n, *x.shape[2:]), out)


def _recursion(phi, drive):
    """x_{k+1} = phi x_k + drive_k from rest: (N+1, M, 2) for phi (M, 2, 2), drive (N, M, 2)."""

    def step(x, b):
        x_next = jnp.einsum("mab,mb->ma", phi, x) + b
        return x_next, x_next

    _, xs = jax.lax.scan(step, jnp.zeros_like(drive[0]), drive)
    return jnp.concatenate([jnp.zeros_like(drive[:1]), xs], axis=0)


def _energies(data: BoundData, x):
    """(..., M) the modes' energy radius sqrt(q'^2 + omega^2 q^2) of states (..., M, 2)."""
    return jnp.hypot(x[..., 1], data.omega * x[..., 0])


def first_order_response(data: BoundData, frame, rates, states, force, valid):
    """The first-order response y to the neglected load of the kept response (module
    docstring): (y at the samples (N+1, M, 2), y at the sub-samples (N, S, M, 2) of each step,
    the coefficient sizes (N, 2, 9), sup |g_m| (N, M), the growth c (N,), the bounded rows'
    sup |R x| (N,)), for the couplings
    in the path's frame ``frame`` (:func:`frame_basis`), the rates ``rates`` (2, N+1, 3)
    (angular velocity and acceleration in that frame), the total modal states (N+1, M, 2) and
    the turning forces (N+1, M) from rest, the load on the steps where ``valid`` (N,) (the
    move; zero on the others). Traceable."""
    w_poly, a_poly = rate_polynomials(rates[0], rates[1], data.dt_s)
    z, c0, c1, sup_q, sup_v = kept_parts(data, states, force)
    forced, sizes = _chunked(
        lambda *xs: _step_terms(data, frame, *xs), (w_poly, a_poly, z, c0, c1), z.shape[1]
    )
    sizes = jnp.where(valid[:, None, None], sizes, 0.0)
    forced = jnp.where(valid[:, None, None, None], forced, 0.0)
    y = _recursion(data.step_phi, forced[:, :, -1])
    free = jnp.sum(data.sub_phi[None] * y[:-1, None, :, None, :], axis=-1)  # (N, S, M, 2)
    fine = free + jnp.swapaxes(forced, 1, 2)
    growth = jnp.einsum("nrx,rx->n", sizes[:, :2], frame.norms)
    # the rows bounded, not integrated (on q): their load on the kept state
    rest = jnp.concatenate([sizes[:, 2:], jnp.zeros_like(sizes[:, 2:])], axis=1)
    rest = jnp.linalg.norm(row_sup(frame, rest, sup_q, sup_v), axis=1)
    return y, fine, sizes[:, :2], row_sup(frame, sizes[:, :2], sup_q, sup_v), growth, rest


class NeglectedTerms(NamedTuple):
    """The bound of the module docstring but for its one evaluation at every point: the
    modal coordinates (K, M) of y at the ``candidates`` (the CANDIDATES sub-samples with the
    largest bound sum_m max_p |phi_m(p)| |y_m|; their largest displacement is evaluated by
    the caller with the rest of its response, jaxflex._deviation), the bound ``others`` of the
    other sub-samples (the next largest of that bound), the ``excess`` between sub-samples,
    the free vibration ``after`` the load, the ``second`` order F E (m), and the energy-norm
    bound ``energy`` (kg^0.5 m/s)."""

    candidates: Any
    others: Any
    excess: Any
    after: Any
    second: Any
    energy: Any

    def bound(self, candidate_peak):
        """(bound on any point's displacement change, m; energy-norm bound) for the largest
        displacement ``candidate_peak`` (m) of the candidates."""
        during = jnp.maximum(candidate_peak, self.others) + self.excess
        return jnp.maximum(during, self.after) + self.second, self.energy


def _candidates(data: BoundData, fine_q):
    """(candidates (K, M), the next largest bound) of y (T, M) at the sub-samples."""
    upper = jnp.abs(fine_q) @ data.peak
    count = min(CANDIDATES, upper.shape[0] - 1)
    top, index = jax.lax.top_k(upper, count + 1)
    return fine_q[index[:count]], top[count]


def _coupled_terms(data: BoundData, omega_rad_s, alpha_rad_s2, states, force, valid, axes):
    frame = frame_basis(data, axes)
    rates = jnp.stack([omega_rad_s, alpha_rad_s2]) @ axes
    y, fine, sizes, sup_g, growth, rest = first_order_response(
        data, frame, rates, states, force, valid
    )
    n, n_sub = fine.shape[:2]
    sub_dt = data.dt_s / n_sub
    # the modes' energy at each sub-step's start and their reach over it (N, S, M)
    starts = _energies(data, jnp.concatenate([y[:-1, None], fine[:, :-1]], axis=1))
    reach = starts + sub_dt * sup_g[:, None]
    curvature = sup_g[:, None] + (1.0 + 2.0 * data.zeta) * data.omega * reach
    excess = sub_dt**2 / 8.0 * jnp.max(curvature, axis=(0, 1))  # (M,)
    candidates, others = _candidates(data, fine[..., 0].reshape(n * n_sub, -1))
    # after the window the load is zero: free vibration, its energy only decays
    settling = _energies(data, y[-1]) / data.omega
    excess, after = jnp.max(data.norms @ jnp.stack([excess, settling], axis=1), axis=0)
    # second order (Gronwall): the load N y over each step from y's reach, the growth c
    step_reach = reach.max(axis=1)  # (N, M)
    load = jnp.linalg.norm(row_sup(frame, sizes, step_reach / data.omega, step_reach), axis=1)
    second = jnp.exp(data.dt_s * growth.sum()) * data.dt_s * (load + rest).sum()
    energy = jnp.max(jnp.sqrt(jnp.sum(reach**2, axis=-1)))
    return NeglectedTerms(candidates, others, excess, after, data.flex * second, energy + second)


def _energy_terms(data: BoundData, omega_rad_s, alpha_rad_s2, states, force, valid, axes):
    w_poly, a_poly = rate_polynomials(omega_rad_s, alpha_rad_s2, data.dt_s)
    _, _, _, sup_q, sup_v = kept_parts(data, states, force)
    dt = data.dt_s
    sizes = jnp.linalg.norm(w_poly, axis=2)  # (N, 3) |W_p|
    rate = sizes[:, 0] + dt * sizes[:, 1] + dt**2 * sizes[:, 2]
    acceleration = jnp.maximum(
        jnp.linalg.norm(a_poly[:, 0], axis=1),
        jnp.linalg.norm(a_poly[:, 0] + dt * a_poly[:, 1], axis=1),
    )
    stiff = acceleration + rate**2
    load = 2.0 * rate * jnp.linalg.norm(sup_v, axis=1) + stiff * jnp.linalg.norm(sup_q, axis=1)
    growth = stiff / jnp.min(data.omega)
    energy = (
        jnp.exp(dt * jnp.where(valid, growth, 0.0).sum()) * dt * jnp.where(valid, load, 0.0).sum()
    )
    return _only(data, data.flex * energy, energy)


def _only(data: BoundData, second, energy) -> NeglectedTerms:
    """The terms of a bound without a first-order response (no candidates)."""
    zero = jnp.zeros(())
    return NeglectedTerms(jnp.zeros((0, data.omega.shape[0])), zero, zero, zero, second, energy)


def principal_axes(omega_rad_s: np.ndarray, alpha_rad_s2: np.ndarray) -> np.ndarray:
    """(3, 3) orthonormal axes (columns) of a path's rates (n+1, 3): the principal axes of
    the stacked angular velocity and acceleration samples (the eigenvectors of their 3 x 3
    Gram matrix, largest first). A turn about a fixed axis has its rates along the first, so
    that the load's bounds (:func:`row_sup`) are exact entry by entry; the axes turn with the
    frame, so the bound is the same in any frame."""
    rates = np.vstack([omega_rad_s, alpha_rad_s2])
    return np.linalg.eigh(rates.T @ rates)[1][:, ::-1]


def turning_window(omega_rad_s: np.ndarray, alpha_rad_s2: np.ndarray, n_padded: int):
    """(start, size): the steps of a path's samples (n+1, 3) that carry a neglected load (a
    rate or an angular acceleration at either end above the rounding of the path's
    integration, REST_SHARE of its largest), whole blocks of PAD_STEPS from ``start`` (within
    ``n_padded`` steps); (0, 0) for a path that does not turn. Before the window y is zero,
    after it a free vibration (module docstring)."""
    rates = [np.abs(np.asarray(x)).max(axis=1) for x in (omega_rad_s, alpha_rad_s2)]
    turning = np.zeros(rates[0].shape, dtype=bool)
    for rate in rates:
        turning |= rate > REST_SHARE * rate.max()
    steps = np.flatnonzero(turning[:-1] | turning[1:])
    if steps.size == 0:
        return 0, 0
    size = padded_steps(int(steps[-1] - steps[0] + 1))
    return min(int(steps[0]), n_padded - size), size


def neglected_terms(data: BoundData, omega_rad_s, alpha_rad_s2, states, force, n_steps, window):
    """The :class:`NeglectedTerms` of the module docstring's bound for the path's rates
    (N+1, 3) in body components, the total modal states (N+1, M, 2) at the samples and the
    turning forces (N+1, M), of which the first ``n_steps`` steps are the move (the rest
    padding); ``window`` (start, size, axes) of :func:`turning_window` (the start and the
    path's axes (3, 3) traced, the size static). Traceable: the couplings' a-posteriori
    bound where ``data`` has them, else the energy estimate."""
    start, size, axes = window
    if size == 0:
        return _only(data, jnp.zeros(()), jnp.zeros(()))
    arrays = [
        jax.lax.dynamic_slice_in_dim(x, start, size + 1)
        for x in (omega_rad_s, alpha_rad_s2, states, force)
    ]
    valid = start + jnp.arange(size) < n_steps
    terms = _energy_terms if data.gyroscopic is None else _coupled_terms
    return terms(data, *arrays, valid, axes)
