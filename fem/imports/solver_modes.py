"""Modes as another solver's result file holds them (Nastran OP2 and punch, Universal File
Format), in the file's units: what each reader returns and fem.imports.from_modes turns into a
model. What a file does not hold stays None, with the reason."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from fem.imports.units import Units
from fem.rigid_modes import rigid_modes
from jaxflex.errors import InputError, JaxflexWarning


@dataclass(eq=False)
class SolverModes:
    """Real normal modes read from a result file (file units).

    Attributes:
        kind: what was read, e.g. "Nastran OP2 (LAMA, OUGV1)".
        path: the file.
        mode_ids: (M,) the solver's mode numbers.
        freq_hz: (M,) natural frequencies, Hz.
        node_ids: (N,) grid / node numbers.
        shapes: (N, 3, M) translations x, y, z per mode in the basic (global) frame.
        nodes: (N, 3) coordinates in the basic frame, or None (``nodes_missing`` says why).
        generalized_mass: (M,) phi^T M phi as the file states it (1: mass-normalised), or
            None where it states none.
        gamma: (M, 3) participation factors phi^T M R / (phi^T M phi) along x, y, z as the
            file states them, or None (``gamma_missing`` says why).
        gamma_source: where ``gamma`` came from.
        units: the unit system the file states (Units), or None.
        notes: what else was found (tables skipped, ...), for the model's meta.
    """

    kind: str
    path: str
    mode_ids: np.ndarray
    freq_hz: np.ndarray
    node_ids: np.ndarray
    shapes: np.ndarray
    nodes: np.ndarray | None = None
    generalized_mass: np.ndarray | None = None
    gamma: np.ndarray | None = None
    gamma_source: str = ""
    gamma_missing: str = ""
    nodes_missing: str = ""
    units: Units | None = None
    notes: list[str] = field(default_factory=list)


def rigid_mask(
    freq_hz: np.ndarray,
    rigid_tol_hz: float,
    allow: bool,
    source: str,
    nodes: np.ndarray | None = None,
    shapes: np.ndarray | None = None,
) -> np.ndarray:
    """(M,) True for the rigid-body modes among ``freq_hz`` (fem.rigid_modes: below
    ``rigid_tol_hz``, or the lowest modes a frequency gap separates from the elastic ones,
    confirmed by their motion where ``nodes`` (N, 3) and ``shapes`` (N, 3, M) are known);
    the same rule on every door: refused unless ``allow`` (allow_rigid_modes,
    --allow-rigid-modes), then left out of the model and reported."""
    rigid = rigid_modes(freq_hz, rigid_tol_hz, nodes, shapes)
    if rigid.any() and not allow:
        freq = np.asarray(freq_hz, dtype=float)[rigid]
        shown = ", ".join(f"{f:.3g}" for f in freq[:6])
        raise InputError(
            f"{source}: {int(rigid.sum())} rigid-body mode(s) ({shown} Hz: below "
            f"{rigid_tol_hz:g} Hz, or far below the first elastic mode): the part is not held; "
            "pass allow_rigid_modes=True (--allow-rigid-modes) to leave them out of the model"
        )
    return rigid


def kept_modes(keep: np.ndarray, n_modes, source: str, max_freq_hz: float | None) -> np.ndarray:
    """The indices of the modes a model keeps: the first ``n_modes`` (an int; None or "all":
    every one) of those ``keep`` (M,) bool marks (elastic, up to ``max_freq_hz``). Asking for
    more than the file holds keeps what it holds, with a JaxflexWarning saying so (the
    count a user asked for is not quietly cut)."""
    kept = np.flatnonzero(keep)
    if n_modes is None or isinstance(n_modes, str):
        return kept
    count = int(n_modes)
    if count > kept.size:
        cap = "" if max_freq_hz is None else f" up to {max_freq_hz:g} Hz"
        warnings.warn(
            f"n_modes (--n-modes): {count:,} modes asked, {source} holds {kept.size} elastic "
            f"mode(s){cap} (of its {keep.size}): all {kept.size} kept",
            JaxflexWarning,
            stacklevel=3,
        )
    return kept[:count]


def rigid_meta(freq_hz: np.ndarray) -> dict:
    """The model meta's ``rigid_modes`` entry, as fem.modal_analysis writes it."""
    return {"count": int(np.size(freq_hz)), "freq_hz": [float(f) for f in np.ravel(freq_hz)]}


def user_gamma(gamma, n_modes: int) -> np.ndarray:
    """Participation factors given by the user, checked: (n_modes, 3) finite, kg^0.5."""
    try:
        arr = np.asarray(gamma, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"gamma: expected numbers, (M, 3) in kg^0.5 ({exc})") from exc
    if arr.shape != (n_modes, 3) or not np.isfinite(arr).all():
        raise InputError(
            f"gamma: expected finite values of shape ({n_modes}, 3) in kg^0.5 (one row per "
            f"kept mode, x y z), got {arr.shape}"
        )
    return arr
