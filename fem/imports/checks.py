"""Checks of a model read from another program's files, before it is written: what no
valid set of modes can be is refused with the figure, what is unusual is warned about.

Refused (InputError naming the mode, node or figure):

* values that are not finite (frequencies, shapes, participation factors, coordinates);
* a node id given twice (its coordinates and its shapes cannot be paired);
* all nodes at one point (a model without geometry);
* a mode whose shape is zero at every node (it moves nothing whatever its participation);
* participation factors that contradict the shapes (below).

The shapes and the participation factors of mass-normalised modes are tied by the rigid
translations R: the modes of a complete set sum to sum_m phi_m Gamma_m = R (every node moves
one unit with a unit base translation), so the response share c = max over nodes and
directions of |sum_m Gamma_m,d phi_m(node, d)| of a truncated set is of order 1 (a held
part; a free part's elastic modes carry no translation, c ~ 0). A c of 1000 or 1/1000 is a
unit slip between the shapes and the factors (millimetres against metres, grams against
kilograms) or factors of other modes; c beyond ``SHARE_REFUSED`` is refused, beyond
``SHARE_WARNED`` warned about. Where the mobile mass is known (a mass matrix), the modes may
not carry more than it: sum_m Gamma_m^2 <= m per direction.

Warned about (fem.sanity.ModelWarning, printed as ``warning: ...``): a share of nodes lying
on other nodes (``COINCIDENT_WARNED``), a response share outside ``SHARE_WARNED``.
"""

from __future__ import annotations

import warnings

import numpy as np

from fem.sanity import ModelWarning
from jaxflex.errors import InputError

SHARE_WARNED = (1e-3, 10.0)
SHARE_REFUSED = (1e-6, 1e3)
COINCIDENT_WARNED = 0.1  # share of nodes that lie on another node
MASS_RTOL = 1e-6  # sum of Gamma^2 may exceed the mobile mass by round-off only


def check_finite(name: str, values, source: str) -> None:
    """An InputError naming the first non-finite entry of ``values`` (if any)."""
    if values is None:
        return
    arr = np.asarray(values, dtype=float)
    bad = np.argwhere(~np.isfinite(arr))
    if bad.size:
        raise InputError(
            f"{source}: {name} holds {bad.shape[0]} value(s) that are not finite, e.g. "
            f"{arr[tuple(bad[0])]} at index {tuple(int(i) for i in bad[0])}"
        )


def check_nodes(node_ids: np.ndarray, nodes: np.ndarray | None, source: str) -> None:
    """Duplicated node ids and nodes that all lie at one point are refused; many nodes
    lying on others are warned about."""
    ids, counts = np.unique(np.asarray(node_ids), return_counts=True)
    if (counts > 1).any():
        twice = ids[counts > 1]
        raise InputError(
            f"{source}: node id {int(twice[0])} is given {int(counts[counts > 1][0])} times "
            f"({twice.size} such id(s)); its coordinates and shapes cannot be paired"
        )
    if nodes is None or len(nodes) < 2:
        return
    nodes = np.asarray(nodes, dtype=float)
    span = float(np.ptp(nodes, axis=0).max())
    if span == 0:
        raise InputError(
            f"{source}: all {len(nodes)} nodes lie at one point {nodes[0].tolist()}: the file "
            "holds no geometry for them"
        )
    _, first, counts = np.unique(
        np.round(nodes / (span * 1e-9)), axis=0, return_index=True, return_counts=True
    )
    shared = int(counts[counts > 1].sum())
    if shared > COINCIDENT_WARNED * len(nodes):
        warnings.warn(
            f"{source}: {shared} of {len(nodes)} nodes lie on another node (e.g. node "
            f"{int(np.asarray(node_ids)[first[counts > 1][0]])}): a mesh written twice or "
            "parts not connected",
            ModelWarning,
            stacklevel=2,
        )


def check_shapes(freq_hz: np.ndarray, shapes: np.ndarray, gamma, source: str) -> None:
    """A mode whose shape is zero at every node is refused, with its participation."""
    peak = np.abs(shapes).max(axis=(0, 1)) if shapes.size else np.zeros(0)
    zero = np.flatnonzero(peak == 0)
    if zero.size:
        k = int(zero[0])
        carried = "" if gamma is None else f" with participation factors {np.round(gamma[k], 6)}"
        raise InputError(
            f"{source}: mode {k + 1} ({freq_hz[k]:.6g} Hz) has a shape that is zero at every "
            f"node{carried} ({zero.size} such mode(s)): no mode moves nothing"
        )


def response_share(shapes: np.ndarray, gamma: np.ndarray) -> float:
    """max over nodes and directions of |sum_m Gamma_m,d phi_m(node, d)| (module)."""
    return float(np.abs(np.einsum("ndm,md->nd", shapes, gamma)).max(initial=0.0))


def check_participation(
    shapes: np.ndarray, gamma, mobile_mass_kg, rigid_count: int, source: str
) -> None:
    """Participation factors against the shapes and the mobile mass (module)."""
    if gamma is None:
        return
    gamma = np.asarray(gamma, dtype=float)
    if mobile_mass_kg is not None:
        carried = np.sum(gamma**2, axis=0)
        mass = np.asarray(mobile_mass_kg, dtype=float)
        over = np.flatnonzero(carried > mass * (1 + MASS_RTOL) + 1e-300)
        if over.size:
            d = int(over[0])
            raise InputError(
                f"{source}: the modes carry {carried[d]:.6g} kg along {'xyz'[d]}, more than the "
                f"part's mobile mass {mass[d]:.6g} kg: participation factors and mass disagree"
            )
    share = response_share(shapes, gamma)
    low_ok = rigid_count > 0  # a free part's elastic modes carry no translation
    where = "the participation factors and the shapes disagree (a unit slip between them?)"
    if share > SHARE_REFUSED[1] or (not low_ok and 0 < share < SHARE_REFUSED[0]):
        raise InputError(
            f"{source}: the modes' response to a unit base translation, sum Gamma phi, "
            f"reaches {share:.3g} (a complete set gives 1; truncated sets of order 1): {where}"
        )
    if share > SHARE_WARNED[1] or (not low_ok and share < SHARE_WARNED[0]):
        warnings.warn(
            f"{source}: the modes' response to a unit base translation, sum Gamma phi, "
            f"reaches {share:.3g} (a complete set gives 1): check the units of the "
            "participation factors and the shapes",
            ModelWarning,
            stacklevel=2,
        )
