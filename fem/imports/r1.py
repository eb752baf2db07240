"""The preprint's unit response R1 -> a modal model, by system identification.

R1 is the response of K points (x, y, z) at t_j = j dt to a unit hat of acceleration at t_1
along one axis (jaxflex._convolution). For a part with real modes, each channel c is

    R1_c(t_j) = sum_i rho_ic g_i(t_j),    rho_ic = phi_i(c) Gamma_i,a,

where g_i is the exact response of mode i (omega_i, zeta_i, unit participation) to the hat
(first-order hold, jaxflex._discretize). The identification:

1. Compression and model order: the data matrix D (channels x samples) has rank M, one
   per mode, plus noise. Its singular values are cut at the optimal hard threshold of
   Gavish and Donoho (2014) for unknown noise, tau = omega(beta) * median(s): the number of
   singular values above it is the number of modes M. Channel counts far above the number
   of samples go through the Gram matrix D^T D, whose floor is sqrt(eps) * s_max.
2. Poles: the eigensystem realisation algorithm (ERA) on the M compressed signals from t_2
   on, where the input is over and the response is a free decay: a block Hankel matrix, its
   SVD truncated to order 2M, the realised A and its eigenvalues lambda = exp(s dt).
3. Refinement: nonlinear least squares of the compressed data over (omega_i, zeta_i) with
   the known hat input and the residues eliminated (variable projection), from the ERA
   poles; every sample from t_1 on is fitted.
4. Residues: rho = D G^+ over every channel; the fit report gives the residual, each mode's
   share and the order-selection figures.

The scale of the shapes cannot be separated from the participation without the mass matrix:
along each excited axis the participation is set to 1 kg^0.5 (one R1) or to a unit vector
over the given axes (several R1, one per axis, from the rank-one split of the residues);
the shapes carry the rest, so shape x participation, all the response depends on, is as
identified. Axes without an R1 get participation 0: the model knows nothing about them.

Two things R1 alone cannot tell. A wrong time step: R1 sampled every dt from a part with
frequencies f is the same sequence as R1 sampled every c dt from a part with frequencies f/c
and shapes x c^2, so dt is checked only against the times a header states. Modes above the
Nyquist frequency 1/(2 dt): their samples are those of an alias below it; the model then
reproduces R1 and every response at the sample times, not in between.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.optimize

from fem.imports.imported import ImportedModes, file_digest
from fem.imports.numeric_csv import load_numeric_csv
from fem.imports.r1_layout import detect_layout, steps_from_zero
from fem.imports.solver_modes import rigid_mask, rigid_meta
from jaxflex.errors import InputError
from jaxflex.files import check_positive, check_text_file, read_unit_response_csv
from jaxflex.model import ModalModel
from jaxflex.response import modal_states

AXES = ("x", "y", "z")
GRAM_RATIO = 4  # channels / samples above which the SVD goes through the Gram matrix
FREE_FROM = 2  # the first sample after the hat (at t_1) is over: the modes alone from here


def hat_responses(freq_hz, zeta, dt_s: float, n_steps: int) -> np.ndarray:
    """g_i(t_j), (n_steps + 1, M): displacement of unit-participation modes (q'' + 2 zeta w
    q' + w^2 q = -h_1(t)) for the unit hat h_1 at t_1, sampled at t_j = j dt_s (the exact
    recursion of jaxflex._engine)."""
    n_modes = np.size(freq_hz)
    probe = ModalModel(
        freq_hz,
        zeta,
        np.tile([0.0, 0.0, 1.0], (n_modes, 1)),
        np.zeros((1, 3, n_modes)),
        np.zeros((1, 3)),
    )
    hat = np.zeros((n_steps + 1, 3))
    hat[1, 2] = 1.0
    return modal_states(probe, hat, dt_s, xp=np)[..., 0]


def rigid_hat_response(dt_s: float, n_steps: int) -> np.ndarray:
    """q(t_j), (n_steps + 1,): displacement of a unit-participation rigid-body mode (q'' =
    -h_1(t), no stiffness) for the unit hat h_1 at t_1: -dt^2/6 at t_1, and -dt (t - dt) from
    t_2 on (the hat's impulse dt acting from its centre t_1); the drift of a free part's R1."""
    times = dt_s * np.arange(n_steps + 1)
    drift = np.where(times >= 2 * dt_s, -dt_s * (times - dt_s), 0.0)
    drift[1] = -(dt_s**2) / 6
    return drift


def gavish_donoho_threshold(singular_values: np.ndarray, shape: tuple[int, int]) -> float:
    """Optimal hard threshold for singular values of a low-rank matrix in white noise of
    unknown level: omega(beta) median(s), beta = aspect ratio <= 1 (Gavish & Donoho 2014,
    their polynomial approximation of omega)."""
    beta = min(shape) / max(shape)
    omega = 0.56 * beta**3 - 0.95 * beta**2 + 1.82 * beta + 1.43
    return float(omega * np.median(singular_values))


@dataclass
class R1Fit:
    """The fit report of an R1 identification (SI units).

    n_modes: modes identified; order_reason: why this many.
    singular_values: leading singular values of the data (relative to the largest).
    threshold: the order cut, relative to the largest singular value.
    freq_hz, zeta: (M,) identified; contribution_peak: (M,) peak of each mode's part of R1
    relative to R1's peak; contribution_energy: (M,) its share of R1's energy.
    residual_peak: max |R1 - fit| / max |R1|; residual_rms: rms(R1 - fit) / rms(R1).
    rank_one_residual: (M,) with several axes, how far each mode's residues are from one
    shape times one participation vector (0 = exactly).
    dropped: poles the realisation gave that are no modes, and why.
    nyquist_hz: 1 / (2 dt). timings_s.
    """

    n_modes: int
    order_reason: str
    singular_values: list[float]
    threshold: float
    freq_hz: np.ndarray
    zeta: np.ndarray
    contribution_peak: np.ndarray
    contribution_energy: np.ndarray
    residual_peak: float
    residual_rms: float
    rank_one_residual: np.ndarray
    dropped: list[str]
    nyquist_hz: float
    axes: tuple[str, ...]
    n_steps: int
    n_points: int
    dt_s: float
    timings_s: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {
            "method": "SVD order selection (Gavish-Donoho threshold), ERA poles, variable "
            "projection least squares with the known hat input",
            "axes": list(self.axes),
            "dt_s": self.dt_s,
            "n_steps": self.n_steps,
            "n_points": self.n_points,
            "n_modes": self.n_modes,
            "order_reason": self.order_reason,
            "singular_values_relative": self.singular_values,
            "threshold_relative": self.threshold,
            "freq_hz": self.freq_hz.tolist(),
            "zeta": self.zeta.tolist(),
            "contribution_peak": self.contribution_peak.tolist(),
            "contribution_energy": self.contribution_energy.tolist(),
            "residual_peak_fraction": self.residual_peak,
            "residual_rms_fraction": self.residual_rms,
            "rank_one_residual": self.rank_one_residual.tolist(),
            "dropped_poles": self.dropped,
            "nyquist_hz": self.nyquist_hz,
            "timings_s": {k: round(v, 3) for k, v in self.timings_s.items()},
        }

    def summary(self) -> str:
        lines = [
            f"R1 identification ({', '.join(self.axes)}): {self.n_points} points, "
            f"{self.n_steps} steps of {self.dt_s:g} s (Nyquist {self.nyquist_hz:.4g} Hz)",
            f"modes: {self.n_modes} ({self.order_reason})",
            " mode   freq [Hz]     zeta   peak share  energy share",
        ]
        for i in range(self.n_modes):
            lines.append(
                f"{i + 1:5d} {self.freq_hz[i]:11.5f} {self.zeta[i]:8.5f}   "
                f"{self.contribution_peak[i]:9.3e}   {self.contribution_energy[i]:9.3e}"
            )
        lines.append(
            f"fit residual: max {100 * self.residual_peak:.3g} % of the peak of R1, rms "
            f"{100 * self.residual_rms:.3g} % of its rms"
        )
        if len(self.axes) > 1:
            lines.append(
                f"largest departure from one shape per mode across the axes: "
                f"{self.rank_one_residual.max():.2e}"
            )
        for note in self.dropped:
            lines.append(f"not a mode: {note}")
        steps = ", ".join(f"{k.removesuffix('_s')} {v:.2f} s" for k, v in self.timings_s.items())
        lines.append(f"timings: {steps}")
        return "\n".join(lines)


@dataclass(eq=False)
class R1Identification(ImportedModes):
    """ImportedModes identified from R1, with the fit report ``fit``."""

    fit: R1Fit | None = None
    layouts: list[str] = field(default_factory=list)

    def summary(self) -> str:
        text = self.fit.summary() if self.fit is not None else super().summary()
        return "\n".join([*(f"read {line}" for line in self.layouts), text])


def _data_matrix(r1: np.ndarray) -> np.ndarray:
    """(A, N+1, K, 3) -> (A K 3, N+1) channels x samples."""
    n_axes, n_t, n_points, _ = r1.shape
    return np.ascontiguousarray(np.transpose(r1, (0, 2, 3, 1)).reshape(n_axes * n_points * 3, n_t))


def significant_digits(values: np.ndarray, sample: int = 100_000, seed: int = 0) -> int:
    """How many significant decimal digits the (non-zero) ``values`` were written with:
    the smallest d <= 17 that reproduces every value of a random sample of them."""
    flat = values.ravel()
    nonzero = flat[flat != 0]
    if nonzero.size > sample:
        nonzero = np.random.default_rng(seed).choice(nonzero, sample, replace=False)
    for digits in range(1, 17):
        if np.all(np.abs(round_significant(nonzero, digits) - nonzero) <= 4e-16 * np.abs(nonzero)):
            return digits
    return 17


def round_significant(values: np.ndarray, digits: int) -> np.ndarray:
    """``values`` rounded to ``digits`` significant decimal digits (zeros stay zero)."""
    out = np.array(values, dtype=float)
    nonzero = out != 0
    scale = 10.0 ** (digits - 1 - np.floor(np.log10(np.abs(out[nonzero]))))
    out[nonzero] = np.round(out[nonzero] * scale) / scale
    return out


def rounding_noise_edge(data: np.ndarray, digits: int) -> float:
    """Bound on the largest singular value of the rounding error of ``data`` written with
    ``digits`` significant digits: entry (i, j) carries uniform noise of standard deviation
    u_ij / sqrt(12), u_ij the unit of its last digit, and the spectral norm of such a matrix
    is about max_i |sigma_i.| + max_j |sigma_.j| (Bandeira & van Handel 2016); the factor
    2 / sqrt(3) is the Gavish-Donoho margin over the noise edge (4 / sqrt(3) vs 2)."""
    if digits >= 16:
        return 0.0
    row_sq = np.zeros(data.shape[0])
    col_sq = np.zeros(data.shape[1])
    for chunk in np.array_split(np.arange(data.shape[0]), max(1, data.shape[0] // 20000)):
        block = data[chunk]
        nonzero = block != 0
        unit = np.zeros_like(block)
        unit[nonzero] = 10.0 ** (np.floor(np.log10(np.abs(block[nonzero]))) - digits + 1)
        var = unit**2 / 12
        row_sq[chunk] = var.sum(axis=1)
        col_sq += var.sum(axis=0)
    return 2 / math.sqrt(3) * (math.sqrt(row_sq.max()) + math.sqrt(col_sq.max()))


def _compress(data: np.ndarray, max_modes: int | None):
    """Singular values (relative), the chosen rank, its reason and the compressed signals
    (rank, N+1) spanning the data's time behaviour."""
    n_ch, n_t = data.shape
    if n_ch > GRAM_RATIO * n_t:
        gram = data.T @ data
        values, vectors = np.linalg.eigh(gram)
        order = np.argsort(values)[::-1]
        s = np.sqrt(np.clip(values[order], 0.0, None))
        vt = vectors[:, order].T
        floor = math.sqrt(np.finfo(float).eps) * s[0]
    else:
        _, s, vt = np.linalg.svd(data, full_matrices=False)
        floor = np.finfo(float).eps * max(data.shape) * s[0]
    digits = significant_digits(data)
    limits = {
        "Gavish-Donoho threshold for white noise": gavish_donoho_threshold(s, data.shape),
        f"rounding noise of {digits} significant digits": rounding_noise_edge(data, digits),
        "numerical floor of the SVD": floor,
    }
    cause = max(limits, key=limits.get)
    tau = limits[cause]
    rank = int(np.sum(s > tau))
    reason = (
        f"{rank} singular values of the data above {tau / s[0]:.2e} of the largest, the "
        f"{cause} (next: {s[rank] / s[0]:.2e})"
        if rank < s.size
        else f"all {rank} singular values above the {cause}"
    )
    if max_modes is not None and rank > max_modes:
        reason += f"; limited to max_modes={max_modes}"
        rank = max_modes
    if rank == 0:
        raise InputError("R1: no response above the noise; is the file all zeros?")
    if 4 * rank + 8 > n_t:
        raise InputError(
            f"R1: {n_t - 1} steps cannot identify {rank} modes (about 4 steps per mode and 8 "
            "more are needed); give a longer R1 or set max_modes"
        )
    compressed = s[:rank, None] * vt[:rank]
    return s / s[0], tau / s[0], rank, reason, compressed


def _era_poles(signals: np.ndarray, order: int) -> np.ndarray:
    """Discrete poles of the free decay ``signals`` (channels, samples) by ERA of ``order``."""
    n_ch, n_s = signals.shape
    rows = max(2, math.ceil(max(2 * order, 40) / n_ch))
    rows = min(rows, (n_s - 1) // 2)
    cols = n_s - rows
    h0 = np.concatenate([signals[:, i : i + cols - 1] for i in range(rows)], axis=0)
    h1 = np.concatenate([signals[:, i + 1 : i + cols] for i in range(rows)], axis=0)
    u, s, vt = np.linalg.svd(h0, full_matrices=False)
    order = min(order, int(np.sum(s > s[0] * 1e-14)))
    root = 1 / np.sqrt(s[:order])
    a = (u[:, :order].T * root[:, None]) @ h1 @ (vt[:order].T * root[None, :])
    return np.linalg.eigvals(a)


def _poles_to_modes(poles: np.ndarray, dt_s: float):
    s = np.log(poles.astype(complex)) / dt_s
    freq, zeta, dropped = [], [], []
    for lam, si in zip(poles, s, strict=True):
        if abs(lam) >= 1:
            dropped.append(f"pole {lam:.6g}: not decaying (|lambda| >= 1)")
        elif abs(lam.imag) <= 1e-9 * abs(lam):
            dropped.append(f"pole {lam.real:.6g}: real (no oscillation, or at 0 / Nyquist)")
        elif lam.imag > 0:
            omega = abs(si)
            freq.append(omega / (2 * np.pi))
            zeta.append(-si.real / omega)
    order = np.argsort(freq)
    return np.asarray(freq)[order], np.asarray(zeta)[order], dropped


def _refine(signals: np.ndarray, freq_hz, zeta, dt_s: float, drift: np.ndarray, floor_hz: float):
    """Least squares of ``signals`` (r, N + 1 - FREE_FROM: the samples from t_2 on) by
    residues x hat responses over (f, zeta), f above ``floor_hz`` (the rigid cut-off); the
    columns ``drift`` (N + 1 - FREE_FROM, d: a free part's rigid-body drift) are fitted
    alongside, so that no elastic mode is pulled towards 0 Hz to take the drift."""
    n_steps = signals.shape[1] - 1 + FREE_FROM
    m = freq_hz.size

    def residual(params):
        modes = hat_responses(np.exp(params[:m]), params[m:], dt_s, n_steps)[FREE_FROM:]
        basis = np.hstack([modes, drift])
        coef, *_ = np.linalg.lstsq(basis, signals.T, rcond=None)
        return (signals.T - basis @ coef).ravel()

    start = np.concatenate([np.log(freq_hz), zeta])
    lower = np.concatenate([np.full(m, np.log(floor_hz)), np.zeros(m)])
    upper = np.concatenate([np.full(m, np.log(0.5 / dt_s)), np.full(m, 0.99)])
    fit = scipy.optimize.least_squares(
        residual,
        np.clip(start, lower + 1e-12, upper - 1e-12),
        bounds=(lower, upper),
        x_scale="jac",
        xtol=1e-12,
        ftol=1e-12,
        max_nfev=50 * (2 * m + 1),
    )
    return np.exp(fit.x[:m]), fit.x[m:]


def identify_r1(
    r1,
    dt_s: float,
    axes: Sequence[str] | str = "z",
    *,
    nodes=None,
    node_ids=None,
    max_modes: int | None = None,
    allow_rigid_modes: bool = False,
    rigid_tol_hz: float = 0.01,
) -> R1Identification:
    """Identify a modal model from unit responses ``r1`` ((A, N+1, K, 3) or (N+1, K, 3) for
    one axis) in m per m/s^2, sampled every ``dt_s`` s, for the acceleration ``axes``
    ("x", "y", "z"; one per R1). ``nodes`` (K, 3) m are the coordinates of the R1 rows
    (None: unknown; needed for a model file). ``max_modes`` caps the order. A free part's
    rigid-body drift (poles of the realisation within ``rigid_tol_hz`` of z = 1, two per
    rigid-body mode) is refused unless ``allow_rigid_modes``, then left out and reported."""
    started = time.perf_counter()
    dt_s = check_positive("dt", dt_s)
    axes = (axes,) if isinstance(axes, str) else tuple(axes)
    if not axes or len(set(axes)) != len(axes) or any(a not in AXES for a in axes):
        raise InputError(f"axis: distinct values among x, y, z required, got {list(axes)}")
    r1 = np.asarray(r1, dtype=float)
    if r1.ndim == 3:
        r1 = r1[None]
    if r1.ndim != 4 or r1.shape[0] != len(axes) or r1.shape[3] != 3:
        raise InputError(
            f"R1: expected shape ({len(axes)} axes, N+1, K, 3) for axes {list(axes)}, got "
            f"{r1.shape}"
        )
    n_axes, n_t, n_points, _ = r1.shape
    if not np.isfinite(r1).all():
        raise InputError("R1: contains non-finite values")
    peak = float(np.max(np.abs(r1)))
    if peak == 0:
        raise InputError("R1: all values are zero")
    if np.max(np.abs(r1[:, 0])) > 1e-6 * peak:
        raise InputError(
            "R1: the first time step (t_0) must be zero: the response to the hat at t_1 starts "
            "at rest; check that the file has no time or node column and starts at t_0"
        )
    if nodes is not None:
        nodes = np.asarray(nodes, dtype=float)
        if nodes.shape != (n_points, 3) or not np.isfinite(nodes).all():
            raise InputError(
                f"nodes: expected {n_points} rows x, y, z in m (one per R1 row), got {nodes.shape}"
            )
    if max_modes is not None and int(max_modes) < 1:
        raise InputError(f"max_modes: must be >= 1, got {max_modes}")
    timings: dict[str, float] = {}

    tick = time.perf_counter()
    data = _data_matrix(r1)
    active = np.flatnonzero(np.any(data != 0, axis=1))
    data_active = data[active]
    # the modes from t_2 on, where the hat is over (at t_1 the quasi-static share of modes
    # beyond the fit adds to them: fitted with the residues below)
    rel_s, threshold, rank, reason, signals = _compress(data_active[:, FREE_FROM:], max_modes)
    timings["order_s"] = time.perf_counter() - tick

    tick = time.perf_counter()
    poles = _era_poles(signals, 2 * rank)
    drift = np.abs(np.log(poles.astype(complex))) / dt_s < 2 * np.pi * rigid_tol_hz
    rigid_mask(np.zeros(math.ceil(drift.sum() / 2)), 1.0, allow_rigid_modes, "R1")
    freq0, zeta0, dropped = _poles_to_modes(poles[~drift], dt_s)
    if drift.any():
        dropped.append(f"{int(drift.sum())} pole(s) at z = 1: rigid-body drift, left out")
    if freq0.size == 0:
        raise InputError("R1: no oscillating mode found; " + "; ".join(dropped))
    timings["era_s"] = time.perf_counter() - tick

    tick = time.perf_counter()
    # a free part's rigid-body drift: the rigid modes' hat response, fitted beside the modes
    rigid = rigid_hat_response(dt_s, n_t - 1)[:, None][:, : int(drift.any())]
    freq, zeta = _refine(signals, freq0, zeta0, dt_s, rigid[FREE_FROM:], rigid_tol_hz)
    order = np.argsort(freq)
    freq, zeta = freq[order], zeta[order]
    timings["refine_s"] = time.perf_counter() - tick

    tick = time.perf_counter()
    # the modes' hat responses, and the quasi-static share D a(t) of the modes beyond the fit
    # (their response to the hat is the hat itself: at its sample t_1 only), and the drift
    basis = np.hstack([hat_responses(freq, zeta, dt_s, n_t - 1), np.eye(n_t)[:, 1:2], rigid])
    pinv = np.linalg.pinv(basis)  # (M + 1 + d, N+1)
    residues = np.zeros((data.shape[0], basis.shape[1]))
    residues[active] = data_active @ pinv.T
    fitted_peak, sq_res, sq_data = 0.0, 0.0, 0.0
    for chunk in np.array_split(np.arange(active.size), max(1, active.size // 20000)):
        block = data_active[chunk]
        diff = block - residues[active[chunk]] @ basis.T
        fitted_peak = max(fitted_peak, float(np.max(np.abs(diff))))
        sq_res += float(np.sum(diff**2))
        sq_data += float(np.sum(block**2))
    part_peak = np.max(np.abs(residues), axis=0) * np.max(np.abs(basis), axis=0) / peak
    energy = np.sum(residues**2, axis=0) * np.sum(basis**2, axis=0) / sq_data
    timings["residues_s"] = time.perf_counter() - tick

    m = freq.size
    residues, direct = residues[:, :m], residues[:, m].reshape(n_axes, n_points, 3)
    basis = basis[:, :m]
    part_peak, energy = part_peak[:m], energy[:m]
    gamma, shapes, rank_one = _split(residues.reshape(n_axes, n_points, 3, -1), axes)
    static = -shapes @ (gamma / (2 * np.pi * freq[:, None]) ** 2)  # (K, 3, 3): the modes'
    for a, axis in enumerate(axes):
        static[:, :, AXES.index(axis)] += direct[a]  # ... plus the quasi-static residual
    timings["total_s"] = time.perf_counter() - started
    fit = R1Fit(
        n_modes=int(freq.size),
        order_reason=reason,
        singular_values=rel_s[: min(rel_s.size, rank + 5)].tolist(),
        threshold=threshold,
        freq_hz=freq,
        zeta=zeta,
        contribution_peak=part_peak,
        contribution_energy=energy,
        residual_peak=fitted_peak / peak,
        residual_rms=math.sqrt(sq_res / sq_data),
        rank_one_residual=rank_one,
        dropped=dropped,
        nyquist_hz=0.5 / dt_s,
        axes=axes,
        n_steps=n_t - 1,
        n_points=n_points,
        dt_s=dt_s,
        timings_s=timings,
    )
    provenance = {
        "source": "fem.from_r1 (system identification of the unit response R1)",
        "rigid_modes": rigid_meta(np.zeros(math.ceil(drift.sum() / 2))),
        "derived": {
            "identification": fit.as_dict(),
            "gamma": "1 kg^0.5 along the one excited axis"
            if n_axes == 1
            else "unit vector over the excited axes (rank-one split of the residues)",
            "gamma_unknown_axes": [a for a in AXES if a not in axes],
            "rigid_body_poles": int(drift.sum()),
            "shapes": "residues (shape x participation) over the participation; the mass "
            "normalisation cannot be known from R1",
            "static_response": f"along {', '.join(axes)}: the modes' static response plus the "
            "quasi-static share of the modes beyond the fit (R1 at the hat's sample); along "
            "the other axes unknown (zero participation)",
        },
    }
    return R1Identification(
        freq_hz=freq,
        shapes=shapes,
        gamma=gamma,
        nodes=nodes,
        node_ids=np.arange(1, n_points + 1) if node_ids is None else np.asarray(node_ids),
        zeta=zeta,
        static_shapes=static,
        static_note=provenance["derived"]["static_response"],
        nodes_missing="R1 holds none; pass nodes= (--nodes) with a CSV of the R1 rows' x, y, z "
        "in m (or node, x, y, z)",
        provenance=provenance,
        fit=fit,
    )


def _split(residues: np.ndarray, axes: tuple[str, ...]):
    """(A, K, 3, M) residues -> gamma (M, 3), shapes (K, 3, M), rank-one residual (M,)."""
    n_axes, n_points, _, n_modes = residues.shape
    gamma = np.zeros((n_modes, 3))
    shapes = np.zeros((n_points, 3, n_modes))
    rank_one = np.zeros(n_modes)
    columns = [AXES.index(a) for a in axes]
    for i in range(n_modes):
        block = residues[:, :, :, i].reshape(n_axes, -1)
        u, s, _ = np.linalg.svd(block, full_matrices=False)
        lead = u[:, 0] * np.sign(u[np.argmax(np.abs(u[:, 0])), 0])
        gamma[i, columns] = lead
        shapes[:, :, i] = (lead @ block).reshape(n_points, 3)
        rank_one[i] = math.sqrt(float(np.sum(s[1:] ** 2))) / float(s[0]) if s[0] > 0 else 0.0
    return gamma, shapes, rank_one


def _read_nodes(path) -> tuple[np.ndarray, np.ndarray | None]:
    path = check_text_file("nodes", path)
    table = load_numeric_csv(path, "nodes")
    if table.shape[1] == 3:
        return table, None
    if table.shape[1] == 4:
        return table[:, 1:], table[:, 0].astype(np.int64)
    raise InputError(
        f"nodes: {str(path)!r} needs 3 columns x, y, z (m) or 4 node, x, y, z; got {table.shape[1]}"
    )


def from_r1(
    paths: str | os.PathLike | Sequence[str | os.PathLike],
    dt_s: float,
    axes: Sequence[str] | str = "z",
    *,
    nodes=None,
    max_modes: int | None = None,
    allow_rigid_modes: bool = False,
) -> R1Identification:
    """Identify a modal model from R1 CSV files in the preprint's Table 2 layout (one per
    acceleration axis in ``axes``), sampled every ``dt_s`` s. ``nodes``: a CSV (x, y, z or
    node, x, y, z in m, one row per R1 row) or an array (K, 3) m. See :func:`identify_r1`;
    ``.fit`` is the fit report, ``.to_modal_model(points)`` the model."""
    dt_s = check_positive("dt", dt_s)
    paths = [paths] if isinstance(paths, str | os.PathLike) else list(paths)
    axes = (axes,) if isinstance(axes, str) else tuple(axes)
    if len(paths) != len(axes):
        raise InputError(f"axis: {len(paths)} R1 file(s) need {len(paths)} axes, got {axes}")
    arrays, layouts = [], []
    for path in paths:
        steps = read_unit_response_csv(path)
        layout = detect_layout(path, steps, dt_s)
        arrays.append(steps_from_zero(steps, layout))
        layouts.append(layout)
    shapes = {a.shape for a in arrays}
    if len(shapes) != 1:
        raise InputError(f"R1 files differ in shape (steps, points, 3): {sorted(shapes)}")
    node_ids = None
    node_info: dict[str, Any] = {}
    if isinstance(nodes, str | os.PathLike):
        node_info = {"nodes": file_digest(nodes)}
        nodes, node_ids = _read_nodes(nodes)
    result = identify_r1(
        np.stack(arrays),
        dt_s,
        axes,
        nodes=nodes,
        node_ids=node_ids,
        max_modes=max_modes,
        allow_rigid_modes=allow_rigid_modes,
    )
    result.provenance["input"] = {
        "r1": [dict(file_digest(p), axis=a) for p, a in zip(paths, axes, strict=True)],
        **node_info,
    }
    result.provenance["derived"]["dt_s"] = (
        "given; checked against the file's header times"
        if any(layout.times_s is not None for layout in layouts)
        else "given; the file states no times, so it could not be checked"
    )
    result.layouts = [
        f"{Path(p).name}: {layout.describe()}" for p, layout in zip(paths, layouts, strict=True)
    ]
    result.provenance["derived"]["layout"] = result.layouts
    return result
