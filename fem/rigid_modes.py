"""Rigid-body modes recognised by what they are, not by a fixed frequency.

A part that is not held (or held so that it can still move as a body) has rigid-body modes:
K phi = 0, frequency zero. An eigen solver returns them as small but not zero frequencies,
and how small depends on the model's conditioning: a free sheet part meshed from CAD gave
0.036-0.09 Hz, above a fixed cut-off of 0.01 Hz, so they were kept as "elastic" modes
carrying most of the part's mass. Two properties recognise them:

* **the spectral gap**: K's null space has at most six dimensions (a body's rigid motions);
  its numerical eigenvalues sit far below the first true elastic one (by Rayleigh's
  principle, a vector with a deformation share delta has omega^2 >= delta^2 omega_1^2, so a
  mode whose frequency is a small fraction of the next one's is mostly rigid motion).
  The lowest modes up to a frequency ratio of at least ``RIGID_GAP`` to the next mode, below
  ``RIGID_CEILING_HZ``, are rigid (at most ``MAX_RIGID`` of them);
* **the motion itself** (where node coordinates and shapes are known): a rigid-body mode
  moves the nodes as a rigid body, u = a + theta x (x - c); :func:`rigid_fit_residual` is
  the part of a mode that is not such a motion (its deformation share). A low mode of the
  gap rule that deforms by more than ``RIGID_FIT_MAX`` is not a rigid mode (a mechanism or a
  very soft part), and is left as it is.

Modes below the fixed ``rigid_tol_hz`` stay rigid as before.
"""

from __future__ import annotations

import numpy as np

RIGID_GAP = 10.0  # frequency ratio between the last rigid and the first elastic mode
RIGID_CEILING_HZ = 1.0  # no sheet part carried by a robot has a real mode this low
MAX_RIGID = 6  # a body's rigid motions
RIGID_FIT_MAX = 0.2  # deformation share above which a low mode is no rigid motion


def rigid_fit_residual(nodes: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """(M,) the share of each mode's node translations (N, 3, M) that is not a rigid-body
    motion a + theta x (x - c) of the nodes (N, 3): ||u - best fit|| / ||u|| (NaN for a zero
    shape)."""
    nodes = np.asarray(nodes, dtype=float)
    rel = nodes - nodes.mean(axis=0)
    scale = float(np.abs(rel).max()) or 1.0
    rel = rel / scale
    n = len(nodes)
    basis = np.zeros((n, 3, 6))
    basis[:, [0, 1, 2], [0, 1, 2]] = 1.0
    x, y, z = rel.T  # theta x r: columns theta_x, theta_y, theta_z
    basis[:, 1, 3], basis[:, 2, 3] = -z, y
    basis[:, 0, 4], basis[:, 2, 4] = z, -x
    basis[:, 0, 5], basis[:, 1, 5] = -y, x
    a = basis.reshape(3 * n, 6)
    u = np.asarray(shapes, dtype=float).reshape(3 * n, -1)
    coef, *_ = np.linalg.lstsq(a, u, rcond=None)
    norm = np.linalg.norm(u, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.linalg.norm(u - a @ coef, axis=0) / np.where(norm > 0, norm, np.nan)


def rigid_by_gap(freq_hz: np.ndarray, rigid_tol_hz: float) -> np.ndarray:
    """(M,) True for the modes below ``rigid_tol_hz`` and for the lowest modes that a
    frequency gap of ``RIGID_GAP`` separates from the rest below ``RIGID_CEILING_HZ`` (at
    most ``MAX_RIGID``); ``freq_hz`` in any order."""
    freq = np.abs(np.asarray(freq_hz, dtype=float))
    rigid = freq < rigid_tol_hz
    order = np.argsort(freq)
    ranked = freq[order]
    count = 0
    for k in range(min(MAX_RIGID, ranked.size)):
        if ranked[k] >= RIGID_CEILING_HZ:
            break
        following = ranked[k + 1] if k + 1 < ranked.size else np.inf
        if following >= RIGID_GAP * max(ranked[k], 1e-300):
            count = k + 1
    rigid[order[:count]] = True
    return rigid


def rigid_modes(
    freq_hz: np.ndarray,
    rigid_tol_hz: float,
    nodes: np.ndarray | None = None,
    shapes: np.ndarray | None = None,
) -> np.ndarray:
    """(M,) True for the rigid-body modes (module docstring); ``nodes`` (N, 3) and
    ``shapes`` (N, 3, M) where known confirm the gap rule's modes by their motion."""
    freq = np.asarray(freq_hz, dtype=float)
    rigid = rigid_by_gap(freq, rigid_tol_hz)
    by_gap = rigid & (np.abs(freq) >= rigid_tol_hz)
    if by_gap.any() and nodes is not None and shapes is not None and len(nodes) > 2:
        deformation = rigid_fit_residual(nodes, np.asarray(shapes)[:, :, by_gap])
        rigid[np.flatnonzero(by_gap)[~(deformation <= RIGID_FIT_MAX)]] = False
    return rigid
