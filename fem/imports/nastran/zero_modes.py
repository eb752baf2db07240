"""What the lowest modes of a deck model are: rigid-body motions, mechanisms, or modes of a
part too soft for the rigid-mode cut-off.

An eigen solver returns a rigid-body mode and a mechanism alike as a frequency near zero;
a fixed cut-off (fem.modal: 0.01 Hz) also takes the modes of a very soft part for them. Two
properties tell them apart:

* **strain energy**: a zero-energy mode (K phi = 0: a rigid-body motion or a mechanism)
  has phi^T K phi at the round-off of K, while a deforming mode stores energy. The share
  phi^T K phi / phi^T diag(K) phi (invariant under the scaling of the DOFs, so under the
  unit system) is below ``ZERO_ENERGY`` for the former: round-off gives 1e-16 and less,
  the first modes of pyNastran's public decks 5e-10 and more (a finely meshed wing);
* **the motion**: the zero-energy modes span a space; the part of it that the rigid-body
  motions of the whole model (translation a and rotation theta: u = a + theta x (x - c) at
  every grid) cannot make (principal angles whose sine exceeds ``NOT_RIGID``) are
  mechanisms: a body or a chain of bodies that moves without deforming any element while
  the rest does not follow (a flap on a line of pins, grids a dropped mid-side node left
  loose, a frame of rods without a diagonal).

A deck whose model has mechanisms is refused naming the grids that move most in them, as is
one whose modes below the rigid cut-off deform the part (they are not rigid-body modes, and
a model without them would miss them).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from fem.elements.offsets import skew

ZERO_ENERGY = 1e-13  # strain-energy share below which a mode is a zero-energy mode
RIGID_TOL_HZ = 0.01  # fem.modal.solve_modes' frequency cut-off of rigid-body modes
NOT_RIGID = 1e-2  # sine of the angle to the rigid motions beyond which a direction is not one


@dataclass
class ZeroModes:
    """The lowest modes sorted out: ``rigid`` rigid-body modes, ``mechanisms`` their count
    and ``moving`` (grid ids moving most in them), ``soft_hz`` the frequencies of modes below
    the rigid cut-off that deform the part, ``energy`` (R + M,) the strain-energy share of
    the modes examined (those called rigid, then the elastic ones)."""

    rigid: int
    mechanisms: int
    moving: list[int]
    soft_hz: np.ndarray
    energy: np.ndarray


def energy_share(stiffness: sp.spmatrix, vectors: np.ndarray) -> np.ndarray:
    """(R,) phi^T K phi / phi^T diag(K) phi of the columns of ``vectors`` (f, R)."""
    if not vectors.shape[1]:
        return np.zeros(0)
    stored = np.einsum("im,im->m", vectors, stiffness @ vectors)
    diagonal = np.einsum("im,i->m", vectors**2, np.abs(stiffness.diagonal()))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.abs(stored) / np.where(diagonal > 0, diagonal, np.inf)


def rigid_motions(nodes: np.ndarray, length: float) -> np.ndarray:
    """(6 N, 6) the rigid-body motions of grids at ``nodes`` (N, 3) (six DOFs each, the
    rotations times ``length`` so translations and rotations weigh alike): translations
    along x, y, z and rotations (times ``length``) about x, y, z at the grids' centre."""
    rel = (nodes - nodes.mean(axis=0)) / length
    out = np.zeros((len(nodes), 6, 6))
    out[:, :3, :3] = np.eye(3)
    out[:, :3, 3:] = -skew(rel)
    out[:, 3:, 3:] = np.eye(3)
    return out.reshape(-1, 6)


def sort_zero_modes(
    stiffness: sp.spmatrix,
    basis: sp.spmatrix,
    grids: tuple[np.ndarray, np.ndarray, np.ndarray],
    unconnected: np.ndarray,
    rigid_vectors: np.ndarray,
    rigid_freq_hz: np.ndarray,
    vectors: np.ndarray,
) -> ZeroModes:
    """Sort out the modes the solver called rigid (``rigid_vectors`` (f, R) at
    ``rigid_freq_hz``) and the elastic ones (``vectors`` (f, M)) of the free coordinates z
    (``stiffness`` (f, f), u = ``basis`` z with six DOFs per grid in basic axes); ``grids``
    = (positions (N, 3), ids (N,), displacement systems (N, 3, 3): rows the directions of
    components 1-3 and 4-6). The rigid motions are compared on the components of the grids'
    displacement systems but the ``unconnected`` ones (indices 6 grid + component - 1: those
    AUTOSPC held, which nothing reaches, such as the loose direction of a point mass): a
    component the deck holds stays while a rigid motion would move it."""
    nodes, grid_ids, frames = grids
    examined = np.hstack([rigid_vectors, vectors])
    energy = energy_share(stiffness, examined)
    zero = energy < ZERO_ENERGY
    soft = rigid_freq_hz[~zero[: len(rigid_freq_hz)] & (np.abs(rigid_freq_hz) < RIGID_TOL_HZ)]
    if not zero.any():
        return ZeroModes(0, 0, [], soft, energy)
    length = float(np.ptp(nodes, axis=0).max()) or 1.0
    turn = sp.block_diag([np.kron(np.eye(2), f) for f in frames], format="csr")
    weight = sp.diags(np.tile(np.r_[np.ones(3), np.full(3, length)], len(nodes)))
    to_components = weight @ turn  # basic u -> weighted components in the CD systems
    free = np.ones(6 * len(nodes), dtype=bool)
    free[unconnected] = False
    motion = (to_components @ (basis @ examined[:, zero]))[free]
    q, _ = np.linalg.qr(motion)
    rigid = (turn @ rigid_motions(nodes, length))[free]
    fit, *_ = np.linalg.lstsq(rigid, q, rcond=None)
    _, sines, turn_q = np.linalg.svd(q - rigid @ fit, full_matrices=False)
    loose = sines > NOT_RIGID
    if not loose.any():
        return ZeroModes(len(sines), 0, [], soft, energy)
    motion = np.zeros((6 * len(nodes), int(loose.sum())))
    motion[free] = q @ turn_q[loose].T  # the mechanisms' own motion
    per_grid = np.linalg.norm(motion.reshape(len(nodes), -1), axis=1)
    moving = [int(grid_ids[g]) for g in np.argsort(per_grid)[::-1][:3]]
    return ZeroModes(int((~loose).sum()), int(loose.sum()), moving, soft, energy)


def mechanism_message(found: ZeroModes) -> str:
    """The refusal of a model with mechanisms."""
    grids = ", ".join(str(g) for g in found.moving)
    return (
        f"deck: the model has {found.mechanisms} mechanism(s) beside {found.rigid} rigid-body "
        f"mode(s): zero-energy modes that no rigid-body motion of the whole part makes (a part "
        f"of the model not connected to the rest, a flap on pins, a frame of rods without a "
        f"diagonal); grids {grids} move most in them. Connect or hold them"
    )


def soft_message(found: ZeroModes) -> str:
    """The refusal of a model whose modes below the rigid cut-off deform the part."""
    hz = found.soft_hz
    span = f"{hz.min():.3g} Hz" if hz.size == 1 else f"{hz.min():.3g} ... {hz.max():.3g} Hz"
    return (
        f"deck: {hz.size} mode(s) below {RIGID_TOL_HZ:g} Hz ({span}) deform the part: they are "
        "no rigid-body modes (they store strain energy), and jaxflex keeps no mode this low; "
        "the deck describes a part this soft (check the unit system and PARAM WTMASS: a mass "
        "density given as a weight density makes it 386 times too heavy in inch units)"
    )


def regroup(modes, deforming: np.ndarray, rigid: np.ndarray, count: int | None = None):
    """``modes`` (a fem.modal.ModeSolution) with the rigid-labelled modes ``deforming`` (R,)
    bool among the elastic ones (they store strain energy: a frequency gap called them
    rigid) and the elastic modes ``rigid`` (M,) bool among the rigid ones (zero energy above
    the frequency cut-off), the elastic modes in ascending order, the first ``count``."""
    if not deforming.any() and not rigid.any() and (count is None or modes.freq_hz.size <= count):
        return modes
    to_elastic, keep_rigid = np.flatnonzero(deforming), np.flatnonzero(~deforming)
    freq = np.concatenate([modes.freq_hz[~rigid], modes.rigid_freq_hz[to_elastic]])
    vectors = np.hstack([modes.vectors[:, ~rigid], modes.rigid_vectors[:, to_elastic]])
    gamma = np.concatenate([modes.gamma[~rigid], modes.rigid_gamma[to_elastic]])
    order = np.argsort(freq, kind="stable")[:count]
    return replace(
        modes,
        freq_hz=freq[order],
        vectors=vectors[:, order],
        gamma=gamma[order],
        rigid_freq_hz=np.concatenate([modes.rigid_freq_hz[keep_rigid], modes.freq_hz[rigid]]),
        rigid_gamma=np.concatenate([modes.rigid_gamma[keep_rigid], modes.gamma[rigid]]),
        rigid_vectors=np.hstack([modes.rigid_vectors[:, keep_rigid], modes.vectors[:, rigid]]),
    )
