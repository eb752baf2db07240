"""What a finite-element modal analysis will cost, from the part before any meshing.

Cells: a given mesh has them; a built-in part is meshed on a tensor grid whose lines are
counted from its spacing (fem.mesh.meshing.graded_count), plus the rings that follow each cup's
rim (fem.mesh.rim.ring_cells); a CAD part is meshed by gmsh at its
element size h, so a surface of area A gets about ``CELLS_PER_H2 x A / h^2`` triangles
(equilateral, of side h; ``A / h^2`` quadrilaterals for the thin solid) plus the refinement
around each cup: a disc of radius r at the fine size f and a ring in which the size grows
back to h by GROWTH of the distance (the integral of 1 / size^2 over it). DOFs per cell
follow from the element (a triangulation has about V = T / 2 vertices and E = 3 T / 2
edges): Morley V + E = 2 T, Argyris 6 V + E = 4.5 T, the shell 6 V = 3 T, the one-layer
27-node solid 3 layers x (2 n + 1)^2 nodes x 3 ~ 36 Q.

Memory and time of the whole analysis (meshing, assembly, the gripper's reduction, the
shift-invert eigen solve with its sparse LU factor, the residual solve) against the DOFs n
and modes M, fitted to ``python -m fem.bench.budget`` on the project's 2-core machine (see
docs/fem.md, Budget): memory ``a n^p`` (p 1.0 ... 1.2: the factor's fill-in) plus the
Lanczos vectors, ``16 n (2 M + 1)`` bytes; time ``b n^1.5`` (a sparse factorisation of a 2-D
mesh) plus the Lanczos iterations ``c n M (1 + M / 100)``. The figures come within a factor
of two of the measured runs: they tell a minute from an hour before any work. The
discretisation estimate (fem.discretisation) adds the same analysis of the part meshed twice
as coarsely (its cells counted alike).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from fem.eigen import DENSE_SHARE
from fem.mesh.meshing import GROWTH, cup_bands, graded_count
from fem.mesh.rim import ring_cells
from fem.supports import contact_discs
from jaxflex.runtime import Need

CELLS_PER_H2 = 2.31  # equilateral triangles of side h per h^2: 4 / sqrt(3)
DOF_PER_CELL = {"morley": 2.0, "argyris": 4.5, "shell": 3.0, "hex2": 36.0}
# (a, p) of the memory a n^p in bytes and b of the time b n^1.5 in s, per formulation
# (python -m fem.bench.budget, 2-core machine under load; docs/fem.md, Budget)
MEMORY_FIT = {"morley": (2.33e3, 1.04), "argyris": (1.45e4, 1.02), "shell": (490.0, 1.21),
              "hex2": (4.77e3, 1.09)}  # fmt: skip
TIME_PER_DOF15 = {"morley": 1.55e-7, "argyris": 1.96e-6, "shell": 2.2e-7, "hex2": 5.0e-7}
LANCZOS_S = 0.8e-6  # per DOF and mode, times (1 + M / 100)
FLOOR_S = 0.3  # the smallest analysis
DENSE_S = 5e-10  # a dense generalized eigen decomposition, per DOF^3 (n = 2500: 4.4e-10)
# gmsh meshing a CAD sheet and the checks of its cells (fem.mesh.mesh_io), per triangle: 444 204
# triangles took 44 s and 522 MB on the 2-core machine
CAD_S_PER_CELL = 1.0e-4
CAD_BYTES_PER_CELL = 1.5e3


@dataclass(frozen=True)
class FePlan:
    """The estimated size and cost of a modal analysis: ``cells`` (linear triangles, or
    quadrilaterals for the thin solid), ``n_dof``, ``memory_bytes`` at the peak, ``time_s``
    of wall time; ``element``, ``size_m`` (None for a given mesh), ``n_modes``;
    ``estimate_cells`` those of the discretisation estimate's coarser mesh (its memory and
    time included), None without one."""

    cells: int
    n_dof: int
    memory_bytes: float
    time_s: float
    element: str
    size_m: float | None
    n_modes: int
    estimate_cells: int | None = None

    def need(self, what: str = "the modal analysis") -> Need:
        """This plan as a jaxflex.runtime.Need, with what makes it smaller."""
        size = "" if self.size_m is None else f" at {self.size_m:.3g} m elements"
        cells = "quadrilaterals" if self.element == "hex2" else "cells"
        if self.estimate_cells is not None:
            size += f"; its discretisation estimate on {self.estimate_cells:,} coarser {cells}"
        advice = (
            "use a coarser mesh (--mesh-size, part.mesh_size_m) or fewer modes"
            if self.size_m is not None
            else "give a coarser mesh (the file's mesh is used as is) or fewer modes"
        )
        return Need(
            f"{what} ({self.cells:,} {cells}{size}, about {self.n_dof:,} DOFs "
            f"'{self.element}', {self.n_modes} modes)",
            self.memory_bytes,
            self.time_s,
            advice,
        )


def refined_cells(area_m2: float, size_m: float, discs, quads: bool = False) -> float:
    """Cells of a surface of ``area_m2`` meshed at ``size_m`` m and refined in ``discs``
    ((radius m, fine size m) each; module docstring): per unit area 1 / size^2, the size
    being the fine one in the disc and growing by GROWTH of the distance outside it."""
    per_h2 = 1.0 if quads else CELLS_PER_H2
    cells = area_m2 / size_m**2
    for radius, fine in discs:
        fine = min(fine, size_m)
        reach = (size_m - fine) / GROWTH  # ring width until the size is back to size_m
        # the integral over the disc and the ring of (1 / s^2 - 1 / size_m^2) dA, with
        # s(d) = fine + GROWTH d at the distance d from the rim
        disc = math.pi * radius**2 * (1 / fine**2 - 1 / size_m**2)
        ring = (2 * math.pi / GROWTH) * (
            (radius - fine / GROWTH) * (1 / fine - 1 / size_m) + math.log(size_m / fine) / GROWTH
        ) - math.pi * ((radius + reach) ** 2 - radius**2) / size_m**2
        cells += disc + max(ring, 0.0)
    return per_h2 * cells


def cost(element: str, n_dof: float, n_modes: int) -> tuple[float, float]:
    """(bytes, seconds) of a modal analysis of ``n_dof`` DOFs and ``n_modes`` modes (module
    docstring)."""
    n = max(float(n_dof), 1.0)
    a, p = MEMORY_FIT[element]
    memory = a * n**p + 16.0 * n * (2 * n_modes + 1)
    seconds = FLOOR_S + TIME_PER_DOF15[element] * n**1.5
    if n_modes > DENSE_SHARE * n:  # fem.eigen solves densely: K and M dense, their factors
        return memory + 3 * 8.0 * n**2, seconds + DENSE_S * n**3
    return memory, seconds + LANCZOS_S * n * n_modes * (1 + n_modes / 100)


def _cells(part, supports) -> float:
    """Cells of the analysis mesh of ``part`` (module docstring)."""
    quads = part.element == "hex2"
    if part.mesh_is_given:
        sheet = part.geometry.sheet
        return len(sheet.quads) if quads else len(sheet.triangles) + 2 * len(sheet.quads)
    size = part.element_size_m
    fraction = part.fine_fraction
    geometry = part.geometry
    if hasattr(geometry, "width_m"):  # a built-in part: a tensor grid and the cups' rings
        discs = contact_discs(supports)
        bands_x, bands_y, fine = cup_bands(discs, size, fraction)
        nx = graded_count(geometry.width_m, size, bands_x, fine)
        ny = graded_count(geometry.height_m, size, bands_y, fine)
        # a disc larger than the part (a layout the analysis refuses) rings it at most
        span = math.hypot(geometry.width_m, geometry.height_m)
        rings = sum(ring_cells(min(d.radius, span), size, fine) for d in discs)
        return (nx * ny + rings) * (1 if quads else 2)
    discs = [(d.radius, min(size, fraction * d.radius)) for d in contact_discs(supports)]
    return refined_cells(part.area_m2, size, discs, quads=quads)


def plan_of_cells(
    element: str, cells: float, n_modes: int | str | None, size_m: float | None
) -> FePlan:
    """The plan of an analysis of ``cells`` cells of ``element`` (meshed at ``size_m``, None
    for a given mesh) with ``n_modes`` modes ("all": every one, by a dense solve; None:
    20)."""
    n_dof = DOF_PER_CELL[element] * cells
    if n_modes == "all":
        memory = 3 * 8.0 * n_dof**2  # K and M dense, and the eigenvectors
        seconds = FLOOR_S + DENSE_S * n_dof**3
        modes = int(n_dof)
    else:
        modes = min(20 if n_modes is None else int(n_modes), max(int(n_dof), 1))
        memory, seconds = cost(element, n_dof, modes)
    return FePlan(int(cells), int(n_dof), memory, seconds, element, size_m, modes)


def fe_plan(part, n_modes: int | str | None, supports=(), *, estimate: bool = True) -> FePlan:
    """The plan of analysing ``part`` (a fem.Part) with ``n_modes`` modes (see
    :func:`plan_of_cells`) held by ``supports`` (their contact discs refine a meshed
    part); with ``estimate`` the discretisation estimate's second analysis on a coarser
    mesh (fem.discretisation) is part of it."""
    # imported here: fem.discretisation loads JAX (through fem.outputs), which the mesh
    # readers' child interpreters (jaxflex.isolated, through fem.mesh.mesh_io) do not need
    from fem.discretisation import coarse_part

    size = None if part.mesh_is_given else part.element_size_m
    plan = plan_of_cells(part.element, _cells(part, supports), n_modes, size)
    coarse = coarse_part(part) if estimate and n_modes != "all" else None
    if coarse is None:
        return plan
    other = plan_of_cells(part.element, _cells(coarse, supports), n_modes, coarse.element_size_m)
    return replace(
        plan,
        memory_bytes=plan.memory_bytes + other.memory_bytes,
        time_s=plan.time_s + other.time_s,
        estimate_cells=other.cells,
    )


# nodes per DOF of each formulation (shapes are reported at the nodes: vertices, or the
# mid-surface of the thin solid); the model holds (K, 3, M) shapes, copied ~4 times while made
NODES_PER_DOF = {"morley": 0.25, "argyris": 1 / 9, "shell": 1 / 6, "hex2": 1 / 9}
MODEL_COPIES = 4


def points_need(plan: FePlan, points: int | str | None) -> Need:
    """What the model at ``points`` monitored points (None or "all": every node; a count:
    voxel reduced to about that many) of an analysis of ``plan`` holds: per point the mode
    shapes (3 per mode), the static response (3 x 3), the rest position and the mesh's
    coordinates."""
    nodes = NODES_PER_DOF[plan.element] * plan.n_dof
    count = nodes if points in (None, "all") else min(nodes, int(points))
    return Need(
        f"the model at {count:,.0f} points and {plan.n_modes} modes",
        MODEL_COPIES * 8.0 * count * (3 * plan.n_modes + 15),
        0.0,
        "monitor fewer points (--points N; every node by default)",
    )


def cad_mesh_need(path, area_m2: float, size_m: float, quads: bool = False) -> Need:
    """What meshing a CAD sheet of ``area_m2`` at ``size_m`` m takes (gmsh and the mesh's
    checks; python -m fem.bench.budget's CAD figures)."""
    cells = refined_cells(area_m2, size_m, (), quads)
    return Need(
        f"meshing {str(path)!r} ({area_m2:.4g} m^2 at {size_m:.3g} m: about {cells:,.0f} cells)",
        CAD_BYTES_PER_CELL * cells,
        FLOOR_S + CAD_S_PER_CELL * cells,
        "use a coarser --mesh-size (part.mesh_size_m), or check the file's unit (--scale)",
    )
