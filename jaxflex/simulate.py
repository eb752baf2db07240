"""Response of a modal model to a piecewise-linear base acceleration: an exact recursion.

Each mode is advanced with the exact first-order-hold step (jaxflex.discretize) inside one
jitted ``jax.lax.scan``; the point displacements u(t_k) = shapes @ q(t_k) follow from a single
matrix product over all time steps, and the deviation d_k = max_p |u_p(t_k)|.
After the last sample the base is at rest and the part vibrates freely; that continuation is
evaluated in closed form (no scan over zeros).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxflex.discretize import foh_coefficients, propagators
from jaxflex.model import ModalModel
from jaxflex.validation import check_acc, check_positive, is_traced

_DTYPES = {"float64": jnp.float64, "float32": jnp.float32}


@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True)
class Response:
    """Result of :func:`simulate`. T = n + 1 + n_free samples at t_k = k dt.

    t: (T,) s.   q, qd: (T, M) modal coordinates and velocities (kg^0.5 m, kg^0.5 m/s).
    deviation: (T,) d_k = max_p |u_p(t_k)| in m.
    displacement: (T, K, 3) in m, or None unless requested.
    n_steps: number of motion steps n (the move ends at t[n_steps]).
    """

    t: Any
    q: Any
    qd: Any
    deviation: Any
    displacement: Any
    n_steps: int

    def tree_flatten(self):
        return (self.t, self.q, self.qd, self.deviation, self.displacement), self.n_steps

    @classmethod
    def tree_unflatten(cls, n_steps, children):
        return cls(*children, n_steps)

    @property
    def end_state(self):
        """(M, 2) modal state (q, qd) at the end of the motion."""
        return jnp.stack([self.q[self.n_steps], self.qd[self.n_steps]], axis=-1)


def upsample(acc, factor: int):
    """The same piecewise-linear profile sampled ``factor`` times finer: (n factor + 1, 3).

    Simulating it at dt / factor gives the exact response at the finer times."""
    acc = jnp.asarray(acc)
    factor = int(factor)
    if factor < 1:
        raise ValueError(f"factor: must be an integer >= 1, got {factor}")
    frac = jnp.arange(factor, dtype=acc.dtype)[:, None, None] / factor  # (f, 1, 1)
    fine = (1.0 - frac) * acc[None, :-1] + frac * acc[None, 1:]  # (f, n, 3)
    return jnp.concatenate([jnp.transpose(fine, (1, 0, 2)).reshape(-1, 3), acc[-1:]], axis=0)


def modal_forces(gamma, acc):
    """f_k = -Gamma . a_k: (n+1, M) modal forces in kg^0.5 m/s^2 for (n+1, 3) samples."""
    return -acc @ gamma.T


def _step_inputs(model: ModalModel, acc, dt):
    omega = 2.0 * jnp.pi * model.freq_hz
    phi, g0, g1 = foh_coefficients(omega, model.zeta, dt)
    force = modal_forces(model.gamma, acc)
    drive = g0[None] * force[:-1, :, None] + g1[None] * force[1:, :, None]  # (n, M, 2)
    return phi, drive


def modal_states(model: ModalModel, acc, dt, x0=None):
    """Modal states at every sample: (n+1, M, 2) with [..., 0] = q and [..., 1] = qd.

    ``x0`` (M, 2) is the state at t_0 (default: at rest). Traceable (jit/grad/vmap).
    """
    phi, drive = _step_inputs(model, acc, dt)
    p11, p12, p21, p22 = phi[:, 0, 0], phi[:, 0, 1], phi[:, 1, 0], phi[:, 1, 1]
    if x0 is None:
        x0 = jnp.zeros((drive.shape[1], 2), drive.dtype)

    def step(x, b):
        q, v = x[:, 0], x[:, 1]
        x_next = jnp.stack([p11 * q + p12 * v + b[:, 0], p21 * q + p22 * v + b[:, 1]], axis=-1)
        return x_next, x_next

    _, xs = jax.lax.scan(step, x0, drive)
    return jnp.concatenate([x0[None], xs], axis=0)


def end_state(model: ModalModel, acc, dt, x0=None):
    """(M, 2) modal state at t_n; linear in ``acc`` (and in ``x0``). Traceable."""
    return modal_states(model, acc, dt, x0)[-1]


def free_states(model: ModalModel, x_start, tau):
    """Free vibration from state ``x_start`` (M, 2) after times ``tau`` (T,) s: (T, M, 2)."""
    omega = 2.0 * jnp.pi * model.freq_hz
    prop = propagators(omega[None, :], model.zeta[None, :], jnp.asarray(tau)[:, None])
    return jnp.einsum("tmij,mj->tmi", prop.phi, x_start)


def shapes_by_component(shapes):
    """(K, 3, M) mode shapes -> (M, 3K) with all x rows, then all y, then all z: the layout
    in which one matrix product gives every point's displacement for every time step."""
    n_points, _, n_modes = shapes.shape
    return jnp.transpose(shapes, (2, 1, 0)).reshape(n_modes, 3 * n_points)


def _squared_norms(shapes_c, q):
    n_points = shapes_c.shape[1] // 3
    u = (q @ shapes_c).reshape(q.shape[0], 3, n_points)
    return jnp.sum(u * u, axis=1)  # (T, K)


@jax.custom_vjp
def deviation(shapes_c, q):
    """d_t = max_p |u_p(t)| (m) for modal coordinates q (T, M); shapes_c from
    :func:`shapes_by_component`. The gradient flows through the maximising point only
    (zero where d = 0), which costs O(T M) instead of a second full matrix product."""
    return _safe_sqrt(jnp.max(_squared_norms(shapes_c, q), axis=1))


def _safe_sqrt(x):
    positive = x > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, x, 1.0)), 0.0)


def _deviation_fwd(shapes_c, q):
    sq = _squared_norms(shapes_c, q)
    arg = jnp.argmax(sq, axis=1)
    d = _safe_sqrt(jnp.take_along_axis(sq, arg[:, None], axis=1)[:, 0])
    return d, (shapes_c, q, arg, d)


def _deviation_bwd(residuals, d_bar):
    shapes_c, q, arg, d = residuals
    n_modes, n_points = shapes_c.shape[0], shapes_c.shape[1] // 3
    by_point = shapes_c.reshape(n_modes, 3, n_points)
    selected = jnp.take(by_point, arg, axis=2)  # (M, 3, T)
    u_sel = jnp.einsum("mct,tm->tc", selected, q)
    coef = jnp.where(d > 0, d_bar / jnp.where(d > 0, d, 1.0), 0.0)
    weighted = coef[:, None] * u_sel  # (T, 3): d(d_t)/d(u_p*)
    q_bar = jnp.einsum("tc,mct->tm", weighted, selected)
    shapes_bar = (
        jnp.zeros_like(by_point)
        .at[:, :, arg]
        .add(jnp.einsum("tc,tm->mct", weighted, q))
        .reshape(shapes_c.shape)
    )
    return shapes_bar, q_bar


deviation.defvjp(_deviation_fwd, _deviation_bwd)


@partial(jax.jit, static_argnames=("n_free", "want_displacement"))
def _simulate(model, shapes_c, acc, dt, x0, n_free: int, want_displacement: bool):
    states = modal_states(model, acc, dt, x0)
    if n_free > 0:
        tau = dt * jnp.arange(1, n_free + 1, dtype=acc.dtype)
        states = jnp.concatenate([states, free_states(model, states[-1], tau)], axis=0)
    q, qd = states[..., 0], states[..., 1]
    t = dt * jnp.arange(q.shape[0], dtype=acc.dtype)
    deviation_m = deviation(shapes_c, q)
    displacement = jnp.einsum("kcm,tm->tkc", model.shapes, q) if want_displacement else None
    return t, q, qd, deviation_m, displacement


def on_device(model: ModalModel, dtype: str = "float64") -> tuple[ModalModel, Any]:
    """``model`` as JAX arrays of ``dtype`` plus its shapes in the (M, 3K) product layout.

    For a concrete model the result is cached on the model, so repeated calls transfer and
    transpose nothing; traced models (inside jit/vmap) are converted on the fly.
    """
    if dtype not in _DTYPES:
        raise ValueError(f"dtype: must be one of {sorted(_DTYPES)}, got {dtype!r}")
    jdtype = _DTYPES[dtype]
    traced = is_traced(model)
    cache = None if traced else model.__dict__.setdefault("_device_cache", {})
    if cache is not None and dtype in cache:
        return cache[dtype]
    cast = jax.tree_util.tree_map(lambda x: jnp.asarray(x, jdtype), model)
    entry = (cast, shapes_by_component(cast.shapes))
    if cache is not None:
        cache[dtype] = entry
    return entry


def simulate(
    model: ModalModel,
    acc,
    dt,
    *,
    displacement: bool = False,
    extend_s: float = 0.0,
    x0=None,
    dtype: str = "float64",
) -> Response:
    """Response of ``model`` to acceleration samples ``acc`` ((n+1, 3), m/s^2) at t_k = k dt.

    The acceleration is linear between samples (first-order hold); the response at the
    samples is exact for any ``dt`` (s). With ``extend_s`` > 0 the response continues as
    free vibration (base at rest) for that many seconds, rounded up to whole steps.
    ``displacement=True`` also returns every point's displacement (T, K, 3), m.
    ``dtype`` is "float64" (default) or "float32". Works under jax.jit, jax.grad and
    jax.vmap (over ``acc`` and over models of equal size).
    """
    model, shapes_c = on_device(model, dtype)
    if not is_traced(acc):
        check_acc(acc)
    if not is_traced(dt):
        check_positive("dt", dt)
    if extend_s:
        if is_traced(dt):
            raise ValueError("extend_s needs a concrete dt (not traced)")
        n_free = int(np.ceil(check_positive("extend_s", extend_s) / float(dt) - 1e-9))
    else:
        n_free = 0
    jdtype = _DTYPES[dtype]
    acc = jnp.asarray(acc, jdtype)
    x0 = None if x0 is None else jnp.asarray(x0, jdtype)
    t, q, qd, dev, disp = _simulate(
        model, shapes_c, acc, jnp.asarray(dt, jdtype), x0, n_free, bool(displacement)
    )
    return Response(t=t, q=q, qd=qd, deviation=dev, displacement=disp, n_steps=acc.shape[0] - 1)
