"""Warnings for a user's mesh too coarse for its cups or for its modes (a given mesh is used
as it comes; built-in and CAD parts are meshed finely enough by construction).

* **Cups**: a rigid cup clamps the disc the mesh resolves; built-in and CAD parts are
  refined to ``CUP_FINE_FRACTION[element]`` x the cup radius inside it (r/4 plate, r/6
  shell, r/3 thin solid: first modes within ~1 % of the converged clamp, docs/fem.md). A
  given mesh whose elements at a cup are longer than ``CUP_MARGIN`` x that size is warned
  about (a curved panel meshed at 30 mm under 40 mm cups: first frequencies 5.2 % apart
  between a triangle and a quad mesh of the same surface; 0.19 % at 7.5 mm).
* **Modes**: the highest kept mode's bending half-wavelength pi / k, k^4 = rho h w^2 / D
  (flat plate; curved parts are stiffer, so their waves are longer and the rule errs on the
  safe side) needs ``ELEMENTS_PER_HALF_WAVE[element]`` elements for ~1 %: Morley's error at
  22 elements per half-wave is 0.37 % (SS square, default mesh), O(h^2), so 1 % at ~13.
"""

from __future__ import annotations

import numpy as np

from fem.parts import CUP_FINE_FRACTION
from fem.supports import SuctionCup

CUP_MARGIN = 1.5
ELEMENTS_PER_HALF_WAVE = {"morley": 13, "shell": 13, "hex2": 13, "argyris": 4}


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
        omega = 2 * np.pi * float(result.freq_hz.max())
        k = material.rho_kg_m3 * thickness * omega**2 / material.bending_stiffness_nm(thickness)
        half_wave = np.pi / k**0.25
        needed = half_wave / ELEMENTS_PER_HALF_WAVE[element]
        typical = float(np.median(lengths))
        if typical > needed:
            out.append(
                f"mode {result.n_modes} ({result.freq_hz.max():.4g} Hz) bends over half-waves "
                f"of about {half_wave * 1e3:.3g} mm; elements of {typical * 1e3:.3g} mm "
                f"(median) resolve it to worse than ~1 %: it needs about {needed * 1e3:.3g} mm "
                "(or fewer modes)"
            )
    return out
