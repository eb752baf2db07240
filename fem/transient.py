"""Full-order transient reference: direct time integration of the whole FE model.

M u'' + C u' + K u = -(M R)_free a(t), C = alpha M + beta K (Rayleigh), u(0) = u'(0) = 0,
a(t) piecewise linear through the samples a_k at t_k = k dt. Newmark's average-acceleration
rule (gamma = 1/2, beta_N = 1/4: unconditionally stable, second order, no numerical
damping, relative period error (omega h)^2 / 12) with a fine step h = dt / substeps and one
sparse LU of K + (2/h) C + (4/h^2) M. The modal model with zeta_i = alpha/(2 w_i) +
beta w_i/2 solves the same equations in modal coordinates, so this is the ground truth that
the reduced model is checked against (our stand-in for a commercial transient FE run).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from fem.damping import Rayleigh
from fem.eigen import factorize
from fem.modal import ModalResult
from jaxflex.errors import InputError
from jaxflex.response import Move, as_move
from jaxflex.runtime import progress_bar

DEFAULT_OMEGA_H = 0.05  # omega h at the reference mode: Newmark period error ~ 2e-4
REFERENCE_MODE = 10  # the default step resolves the 10th mode (higher modes respond
# quasi-statically to smooth profiles, which the trapezoidal rule reproduces at any step)


@dataclass(eq=False)
class TransientResult:
    """Displacements of the full-order model at monitored points.

    t_s: (T,) output times in s; displacement_m: (T, K, 3) in m; points: (K, 3) m;
    node_indices: (K,) reporting-node indices; dt_fine_s: integration step in s;
    outputs: the requested fem.outputs.PhysicalOutputs at the output times, {name: (T, Y)}.
    """

    t_s: np.ndarray
    displacement_m: np.ndarray
    points: np.ndarray
    node_indices: np.ndarray
    dt_fine_s: float
    n_steps: int
    damping: Rayleigh
    timings_s: dict = field(default_factory=dict)
    outputs: dict = field(default_factory=dict)

    @property
    def deviation_m(self) -> np.ndarray:
        """(T,) max over points of |u_p(t)| in m."""
        return np.linalg.norm(self.displacement_m, axis=2).max(axis=1)


def transient_reference(
    result: ModalResult,
    move: Move,
    *,
    damping: Rayleigh | None = None,
    points=None,
    key_points=None,
    substeps: int | None = None,
    extend_s: float = 0.0,
    output_substeps: int = 1,
    outputs: dict | None = None,
    progress: bool | None = None,
) -> TransientResult:
    """Integrate the full FE model of ``result`` under the base acceleration of ``move`` (a
    jaxflex.Move: samples (n+1, 3) m/s^2 and their step dt_s, s; then ``extend_s`` s at rest)
    and report displacements at
    ``points`` (same meaning as ModalResult.to_modal_model) ``output_substeps`` times per
    sample interval, and the ``outputs`` ({name: fem.outputs.PhysicalOutputs}: cup
    reactions, stresses) from the full state (z, z', z'', a).

    ``damping`` must be Rayleigh (default: the analysis' damping if it is one). ``substeps``
    (fine steps per dt) defaults to omega h <= 0.05 for the 10th mode of ``result``.
    """
    start = time.perf_counter()
    move = as_move(move, name="move")
    acc, dt_s = move.acc, move.dt_s
    damping = damping if damping is not None else result.damping
    if not isinstance(damping, Rayleigh):
        raise InputError(
            "damping: the full-order transient needs Rayleigh damping (fem.Rayleigh, e.g. "
            "Rayleigh.from_zeta(0.02, f1_hz, f2_hz)) so that it matches the modal model"
        )
    if extend_s < 0 or not math.isfinite(extend_s):
        raise InputError(f"extend_s: must be a finite number >= 0 s, got {extend_s!r}")
    n_extra = math.ceil(extend_s / dt_s - 1e-9)
    acc = np.concatenate([acc, np.zeros((n_extra, 3))])
    if substeps is None:
        f_ref = result.freq_hz[min(REFERENCE_MODE, result.n_modes) - 1] if result.n_modes else 1.0
        substeps = max(1, math.ceil(2 * np.pi * f_ref * dt_s / DEFAULT_OMEGA_H))
        substeps = int(output_substeps) * math.ceil(substeps / int(output_substeps))
    if int(substeps) < 1 or int(output_substeps) < 1 or substeps % output_substeps:
        raise InputError(
            f"substeps ({substeps}) and output_substeps ({output_substeps}) must be >= 1 and "
            "substeps a multiple of output_substeps"
        )
    substeps = int(substeps)
    h = dt_s / substeps
    n_fine = (len(acc) - 1) * substeps
    t_fine = np.arange(n_fine + 1) * h
    t_coarse = np.arange(len(acc)) * dt_s
    acc_fine = np.column_stack([np.interp(t_fine, t_coarse, acc[:, d]) for d in range(3)])

    idx = result.select_nodes(points, key_points)
    rows = (3 * idx[:, None] + np.arange(3)).ravel()
    observe = result.observation[rows]
    K, M, load = result.K_free, result.M_free, result.load
    alpha, beta = damping.alpha_per_s, damping.beta_s
    a0, a1 = 4.0 / h**2, 2.0 / h
    lu = factorize((1.0 + a1 * beta) * K + (a0 + a1 * alpha) * M)
    u = np.zeros(K.shape[0])
    v = np.zeros_like(u)
    at_rest = not np.any(acc_fine[0])
    a = np.zeros_like(u) if at_rest else factorize(M).solve(-load @ acc_fine[0])
    every = substeps // int(output_substeps)
    out = [observe @ u]
    outputs = dict(outputs or {})
    recorded = {name: [] for name in outputs}

    def record(k: int) -> None:
        for name, spec in outputs.items():
            recorded[name].append(
                spec.full_order(u[None], v[None], a[None], acc_fine[k][None], damping)[0]
            )

    record(0)
    setup_s = time.perf_counter() - start
    tick = time.perf_counter()
    with progress_bar(
        n_fine, f"Newmark ({K.shape[0]} DOFs, h={h:.3g} s)", progress, unit="step"
    ) as bar:
        for k in range(1, n_fine + 1):
            mass_part = a0 * u + (4.0 / h) * v + a
            damp_part = a1 * u + v  # gamma/(beta h) u + (gamma/beta - 1) v, gamma/beta = 2
            rhs = -load @ acc_fine[k] + M @ (mass_part + alpha * damp_part) + beta * (K @ damp_part)
            u_new = lu.solve(rhs)
            a_new = a0 * (u_new - u) - (4.0 / h) * v - a
            v = v + 0.5 * h * (a + a_new)
            u, a = u_new, a_new
            if k % every == 0:
                out.append(observe @ u)
                record(k)
            if k % 256 == 0 or k == n_fine:
                bar.update(k - bar.n)
    displacement = np.array(out).reshape(len(out), len(idx), 3)
    t_out = np.arange(len(out)) * h * every
    recorded = {name: np.array(values) for name, values in recorded.items()}
    return TransientResult(
        t_s=t_out,
        displacement_m=displacement,
        points=result.system.nodes[idx],
        node_indices=idx,
        dt_fine_s=h,
        n_steps=n_fine,
        damping=damping,
        timings_s={"setup_s": setup_s, "integration_s": time.perf_counter() - tick},
        outputs=recorded,
    )


def agreement(reference_m, model_m) -> dict[str, float]:
    """How well displacements (T, K, 3) of a model match a reference: R^2 over all samples and
    components, and the largest point-wise error |u_ref - u| relative to the reference peak
    max |u_ref| (both dimensionless)."""
    ref = np.asarray(reference_m, dtype=float)
    mod = np.asarray(model_m, dtype=float)
    if ref.shape != mod.shape:
        raise InputError(f"agreement: shapes differ, {ref.shape} vs {mod.shape}")
    err = mod - ref
    r2 = 1.0 - np.sum(err**2) / np.sum((ref - ref.mean(axis=0)) ** 2)
    peak = np.linalg.norm(ref, axis=-1).max()
    return {
        "r2": float(r2),
        "max_error_rel_peak": float(np.linalg.norm(err, axis=-1).max() / peak),
        "peak_m": float(peak),
    }
