"""Held drilling rotations that Nastran's shells do not feel.

Nastran's CQUAD4, CTRIA3, CQUAD8 and CTRIA6 have no stiffness for the rotation of a grid
about the shell's normal (the drilling rotation; MSC's K6ROT adds a penalty of 1e-4 G at
its default 100, too weak to matter), so decks hold it to remove the singularity: GRDSET or
GRID PS 6, SPC 6 on flat panels. Holding it changes nothing in Nastran. Our shell's
membrane (ANDES OPT) uses the drilling rotation to enrich its in-plane field: held, the
membrane stiffens (a coarse in-plane cantilever of pyNastran's trncomp12 deck: its first
in-plane mode 2.5 times higher). So a held rotation component of a grid is left free where
it can only be the drilling rotation of the shells there:

* its direction (in the grid's displacement system) lies within ``PARALLEL_DEG`` of the
  normal of every shell facet at the grid (the shells are coplanar there);
* those shells are all of the kinds without drilling stiffness (CQUAD4, CTRIA3, CQUAD8,
  CTRIA6; CQUADR and CTRIAR have one, and their holds are kept);
* nothing else reaches the grid's rotations: no beam, rod, spring or bushing, rigid element
  or MPC (a point mass does not matter).

The other holds are kept as given (a bending rotation, a grid where shells meet at an angle
or a beam ends).
"""

from __future__ import annotations

import numpy as np

from fem.elements.shell_element import local_frames

PARALLEL_DEG = 1.0  # a held rotation this close to the shells' normal is their drilling
NO_DRILLING = ("CQUAD4", "CTRIA3", "CQUAD8", "CTRIA6")


def free_drilling(held: dict, parts, nodes: np.ndarray, frames: np.ndarray, tied: set) -> dict:
    """The holds of ``held`` ((grid id, component) -> card) to leave free (module
    docstring); ``parts`` the fem.imports.nastran.model.DeckParts, ``nodes`` (N, 3) its grids in
    basic, ``frames`` (N, 3, 3) their displacement systems, ``tied`` the grids rigid elements and
    MPCs reach."""
    index = parts.index
    rotations = [(g, c) for (g, c) in held if c >= 4 and g in index and g not in tied]
    if not rotations:
        return {}
    f = parts.facets
    touched = {g for pair in parts.lines.grids for g in pair}
    for grids, k in zip(parts.points.grids, parts.points.stiffness, strict=True):
        if np.any(k):
            touched.update(grids)
    n = len(parts.grid_ids)
    normal = local_frames(nodes[f.triangles])[0][:, 2]
    owners = np.repeat(np.arange(len(f.triangles)), 3)
    grids_of_facets = f.triangles.ravel()
    kinds = np.array([f.elements[e].card.name in NO_DRILLING for e in f.element])
    plain = np.ones(n, dtype=bool)
    np.logical_and.at(plain, grids_of_facets, kinds[owners])
    has_facet = np.zeros(n, dtype=bool)
    has_facet[grids_of_facets] = True
    cos_min = np.cos(np.radians(PARALLEL_DEG))
    out = {}
    for g, c in rotations:
        node = index[g]
        if g in touched or not (has_facet[node] and plain[node]):
            continue
        direction = frames[node][c - 4]
        at_grid = owners[grids_of_facets == node]
        if np.all(np.abs(normal[at_grid] @ direction) >= cos_min):
            out[(g, c)] = held[(g, c)]
    return out
