"""How far Nastran's default lumped mass would move a deck model's modes.

The deck model uses consistent mass (our shell's, the beams'), as a converged model would:
right for the part. Nastran, unless the deck says PARAM,COUPMASS,1 (or more), lumps the
mass: a shell element's mass in equal shares on its corner grids, a beam's in halves on its
ends, translations only (no rotary inertia); point masses as given. On a fine mesh both give
the same modes; on a coarse one the solver's own modes differ from ours by the mass
formulation alone (pyNastran's rigid wing on plunge and pitch springs, one shell element
across a bay: Nastran's pitch mode 10 % below ours, ours the closed form).

The estimate: the modes' Rayleigh quotient with the lumped mass instead of the consistent
one, f_lumped = f / sqrt(phi^T M_lumped phi) for mass-normalised phi (first order in the
change of the mode shapes, exact for a mode whose shape the lumping does not change, such
as a rigid body on springs).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from fem.elements.shell_element import local_frames

NOTE_ABOVE = 0.01  # warned when a kept mode would move by more than 1 %


def lumped_mass(parts, nodes: np.ndarray) -> sp.csr_matrix:
    """(6 N, 6 N) Nastran's lumped mass of the deck model (deck units, before WTMASS),
    basic axes: shells and beams (module docstring), the point elements' own mass and the
    solids' (fem.imports.nastran.model.assemble_deck keeps it on ``parts``)."""
    n = len(parts.grid_ids)
    translational = np.zeros(n)
    f = parts.facets
    if len(f.triangles):
        _, _, area = local_frames(nodes[f.triangles])
        facet_mass = np.zeros(len(f.triangles))
        for pid in np.unique(f.pid):
            rows = np.flatnonzero(f.pid == pid)
            section = parts.shell_sections.read[int(pid)]
            per_area = section.resultants(f.t_mean[rows], f.t3_mean[rows])[3]
            facet_mass[rows] = per_area * area[rows]
        element_mass = np.bincount(f.element, facet_mass, minlength=len(f.elements))
        for e, element in enumerate(f.elements):
            if not element.quadratic:  # equal shares on the corners
                grids = [parts.index[g] for g in element.corners]
                translational[grids] += element_mass[e] / len(grids)
        quadratic = np.array([f.elements[e].quadratic for e in f.element], dtype=bool)
        thirds = np.repeat(facet_mass[quadratic] / 3, 3)  # per facet: its grids' thirds
        np.add.at(translational, f.triangles[quadratic].ravel(), thirds)
    _, m_lines = parts.lines.matrices()
    for (a, b), m in zip(parts.lines.grids, m_lines, strict=True):
        half = m[0, 0] + m[0, 6]  # the beam's translational mass row: its half
        translational[[parts.index[a], parts.index[b]]] += half
    diagonal = np.zeros((n, 6))
    diagonal[:, :3] = translational[:, None]
    out = sp.diags(diagonal.ravel()).tolil()
    if parts.solid_mass is not None:
        out = (out.tocsr() + parts.solid_mass).tolil()
    for grids, m in zip(parts.points.grids, parts.points.mass, strict=True):
        if np.any(m):
            dofs = np.concatenate([6 * parts.index[g] + np.arange(6) for g in grids])
            out[np.ix_(dofs, dofs)] += m
    return out.tocsr()


def lumped_shift(modes_hz: np.ndarray, vectors_u: np.ndarray, lumped_si: sp.spmatrix):
    """(M,) f_lumped / f - 1 of modes ``modes_hz`` whose shapes ``vectors_u`` (6 N, M) are
    mass-normalised with the consistent mass (module docstring)."""
    if not len(modes_hz):
        return np.zeros(0)
    generalized = np.einsum("im,im->m", vectors_u, lumped_si @ vectors_u)
    return 1 / np.sqrt(generalized) - 1


def lumped_note(shift: np.ndarray) -> str | None:
    """The warning for modes that Nastran's lumped mass would move by more than 1 %."""
    big = np.flatnonzero(np.abs(shift) > NOTE_ABOVE)
    if not big.size:
        return None
    worst = int(big[np.argmax(np.abs(shift[big]))])
    return (
        f"the mesh is coarse for its modes' mass: Nastran's default lumped mass (no PARAM,"
        f"COUPMASS,1 in the deck) would move {big.size} of the first {shift.size} modes by more "
        f"than 1 % (mode {worst + 1}: {100 * shift[worst]:+.2g} %, an estimate from the modes' "
        "Rayleigh quotient); this model's consistent mass is the converged mesh's, so compare "
        "with the solver's own modes accordingly"
    )
