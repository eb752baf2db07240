"""Warnings for a mesh too coarse for its cups or for its modes: a user's mesh file and a
Nastran deck are used as they come (built-in and CAD parts are meshed finely enough by
construction, and their discretisation error is estimated, fem.discretisation).

* **Cups**: a rigid cup clamps the disc the mesh resolves; built-in and CAD parts are
  refined to ``CUP_FINE_FRACTION[element]`` x the cup radius inside it (r/5 Morley, r/4
  Argyris, r/6 shell, r/3 thin solid). A given mesh whose elements at a cup are longer
  than ``CUP_MARGIN`` x that size is warned about (a curved panel meshed at 30 mm under
  40 mm cups: first frequencies 5.2 % apart between a triangle and a quad mesh of the same
  surface; 0.19 % at 7.5 mm).
* **Modes**: a mode's bending half-wavelength pi / k, k^4 = m w^2 / D (m the mass per area,
  D the bending stiffness; flat plate: curved parts are stiffer, so their waves are longer
  and the rule errs on the safe side) needs ``ELEMENTS_PER_HALF_WAVE[element]`` elements
  for ~1 %: Morley's error at 22 elements per half-wave is 0.37 % (SS square, default mesh),
  O(h^2), so 1 % at ~13. Every kept mode below that count is named with its figure (a
  Nastran deck of one shell element per panel: pyNastran's ``random_test_bar_plus_tri``,
  whose modes 3-5 come out 27-50 % above the solver's, has 4.4 elements per half-wave at
  mode 3).
"""

from __future__ import annotations

import numpy as np

from fem.deck_shells import facet_resultants
from fem.parts import CUP_FINE_FRACTION
from fem.supports import SuctionCup

CUP_MARGIN = 1.5
ELEMENTS_PER_HALF_WAVE = {"morley": 13, "shell": 13, "hex2": 13, "argyris": 4}
ERROR_AT_22 = 0.0037  # Morley's relative error at 22 elements per half-wave (O(h^2))


def _edges(system) -> tuple[np.ndarray, np.ndarray]:
    """Midpoints (E, 3) and lengths (E,) of the edges of the system's cells, m."""
    cells = system.cells
    corners = cells if cells.shape[1] <= 4 else cells[:, :4]
    ends = np.concatenate(
        [corners[:, [k, (k + 1) % corners.shape[1]]] for k in range(corners.shape[1])]
    )
    ends = np.unique(np.sort(ends, axis=1), axis=0)
    a, b = system.nodes[ends[:, 0]], system.nodes[ends[:, 1]]
    return (a + b) / 2, np.linalg.norm(b - a, axis=1)


def half_waves_per_element(freq_hz: np.ndarray, size_m, bending_nm, mass_kg_m2) -> np.ndarray:
    """(M,) elements per bending half-wave of modes ``freq_hz`` (M,) Hz: the median over
    the elements (sizes ``size_m``, bending stiffness ``bending_nm`` N m, mass per area
    ``mass_kg_m2``: scalars or one value per element) of pi / (k size), k^4 = m w^2 / D."""
    size, bending, mass = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(v, dtype=float)) for v in (size_m, bending_nm, mass_kg_m2))
    )
    # pi / (k size) = c / sqrt(f) with c = pi (D / m)^(1/4) / (sqrt(2 pi) size)
    c = np.median(np.pi * (bending / mass) ** 0.25 / (np.sqrt(2 * np.pi) * size))
    return c / np.sqrt(np.asarray(freq_hz, dtype=float))


def modes_warning(per_half_wave: np.ndarray, freq_hz: np.ndarray, size_m: float, element: str):
    """The warning for the modes ``freq_hz`` (M,) that ``per_half_wave`` (M,) elements per
    half-wave (elements of about ``size_m`` m) resolve to worse than ~1 %, or None."""
    needed = ELEMENTS_PER_HALF_WAVE[element]
    bad = np.flatnonzero(per_half_wave < needed)
    if not bad.size:
        return None
    first, last = int(bad[0]), len(freq_hz) - 1
    which = (
        f"mode {last + 1} ({freq_hz[last]:.4g} Hz) is"
        if first == last
        else f"modes {first + 1} ... {last + 1} ({freq_hz[first]:.4g} ... {freq_hz[last]:.4g} "
        "Hz) are"
    )
    figures = f"{per_half_wave[first]:.2g}" + (
        "" if first == last else f" ... {per_half_wave[last]:.2g}"
    )
    error = ERROR_AT_22 * (22 / per_half_wave[first]) ** 2
    return (
        f"{which} resolved by {figures} elements per bending half-wave (elements of "
        f"{size_m * 1e3:.3g} mm), fewer than the {needed} that give ~1 % (mode {first + 1}: "
        f"~{100 * error:.2g} % or more); mode {last + 1} needs elements of about "
        f"{size_m * per_half_wave[last] / needed * 1e3:.3g} mm (or keep fewer modes)"
    )


def coarse_mesh_warnings(result) -> list[str]:
    """The warnings for a fem.ModalResult of a part whose mesh was given (else none)."""
    part = result.part
    if not part.mesh_is_given:
        return []
    out = []
    middles, lengths = _edges(result.system)
    element = part.element
    for i, cup in enumerate(result.supports):
        if not isinstance(cup, SuctionCup) or cup.stiffness is not None:
            continue
        point = [cup.x, cup.y] if cup.z is None else [cup.x, cup.y, cup.z]
        centre = part.surface_point(np.array([point], dtype=float))[0]
        near = np.linalg.norm(middles - centre, axis=1) <= cup.radius
        local = float(lengths[near].max()) if near.any() else float(lengths.max())
        needed = CUP_FINE_FRACTION[element] * cup.radius
        if local > CUP_MARGIN * needed:
            out.append(
                f"cup {i} (radius {cup.radius * 1e3:.4g} mm): the mesh's elements there are "
                f"{local * 1e3:.3g} mm long; a rigid cup needs about {needed * 1e3:.3g} mm "
                "(radius x "
                f"{CUP_FINE_FRACTION[element]:.3g}) for ~1 % on the first modes: refine the "
                "mesh at the cups (or use --cad, which does)"
            )
    if result.n_modes:
        material, thickness = part.material, part.thickness_m
        typical = float(np.median(lengths))
        per = half_waves_per_element(
            result.freq_hz,
            typical,
            material.bending_stiffness_nm(thickness),
            material.rho_kg_m3 * thickness,
        )
        message = modes_warning(per, result.freq_hz, typical, element)
        if message:
            out.append(message)
    return out


def deck_mesh_warnings(result, parts, unit, wtmass: float) -> list[str]:
    """The modes warning of a Nastran deck model (fem.nastran, the deck model: its shells'
    own sections, ``parts`` a fem.deck_model.DeckParts in deck units ``unit``, masses times
    ``wtmass``), else none:
    per facet its size sqrt(2 x area) (a quad's side, 0.93 x an equilateral triangle's),
    bending stiffness and mass per area (WTMASS applied) from its section."""
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
