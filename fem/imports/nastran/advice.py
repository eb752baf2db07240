"""The coarse-mesh warning of a Nastran deck's modes (fem.mesh_advice's rule of elements per
bending half-wave) from the deck's own shell sections: the deck's part of the mesh advice,
kept here so the finite elements' advice imports no reader."""

from __future__ import annotations

import numpy as np

from fem.imports.nastran.shells import facet_resultants
from fem.mesh_advice import half_waves_per_element, modes_warning


def deck_mesh_warnings(result, parts, unit, wtmass: float) -> list[str]:
    """The modes warning of a Nastran deck model (fem.imports.nastran.door, the deck model: its
    shells' own sections, ``parts`` a fem.imports.nastran.model.DeckParts in deck units ``unit``,
    masses times ``wtmass``), else none: per facet its size sqrt(2 x area) (a quad's side, 0.93 x an
    equilateral triangle's), bending stiffness and mass per area (WTMASS applied) from its
    section."""
    facets = parts.facets
    if not result.n_modes or not len(facets.triangles):
        return []
    _, _, d, _, mass, _ = facet_resultants(
        facets, parts.shell_sections, np.arange(len(facets.triangles))
    )
    nodes = result.system.nodes  # the shell grids first, in SI
    corners = nodes[facets.triangles]
    area = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    size_m = np.sqrt(2 * area)
    bending = 0.5 * (d[:, 0, 0] + d[:, 1, 1]) * unit.mass_kg * unit.length_m**2
    mass_kg_m2 = mass * wtmass * unit.mass_kg / unit.length_m**2
    held = (bending > 0) & (mass_kg_m2 > 0) & (size_m > 0)
    if not held.any():
        return []
    per = half_waves_per_element(result.freq_hz, size_m[held], bending[held], mass_kg_m2[held])
    message = modes_warning(per, result.freq_hz, float(np.median(size_m[held])), "shell")
    return [message] if message else []
