"""The part of a sweep as a fem part: a built-in shape, or the user's own mesh or CAD file
(``part.path``; layouts are then in the part's own coordinates, m)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import fem
from fem.mesh.mesh_io import CAD_SUFFIXES


def build_part(part: dict) -> fem.Part:
    """The fem part of a sweep's ``part`` section (optim.sweep.spec.PartSpec as a dict)."""
    if part.get("path"):
        if Path(part["path"]).suffix.lower() in CAD_SUFFIXES:
            return fem.read_cad(
                part["path"],
                part["thickness_m"],
                part["material"],
                part["mesh_size_m"],
                element=part["element"],
                scale=part["scale"],
            )
        return fem.read_mesh(
            part["path"],
            part["thickness_m"],
            part["material"],
            element=part["element"],
            scale=part["scale"],
        )
    make = fem.rectangular_plate if part["shape"] == "plate" else fem.curved_panel
    return make(
        part["width_m"], part["height_m"], part["thickness_m"], part["material"],
        part["mesh_size_m"],
    )  # fmt: skip


def footprint_box(part: fem.Part) -> tuple[float, float, float, float]:
    """(x_min, y_min, x_max, y_max) of the part's footprint, m."""
    lo, hi = part.bounds_m()
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


def monitor_points(part: fem.Part, grid) -> np.ndarray:
    """(K, 2) footprint points (m): the cell centres of an nx x ny grid over the footprint's
    bounding box that lie on the part. The same points for every layout, so every model of a
    sweep has the same size and points."""
    nx, ny = grid
    x0, y0, x1, y1 = footprint_box(part)
    x = x0 + (np.arange(nx) + 0.5) / nx * (x1 - x0)
    y = y0 + (np.arange(ny) + 0.5) / ny * (y1 - y0)
    xx, yy = np.meshgrid(x, y)
    points = np.column_stack([xx.ravel(), yy.ravel()])
    return points[part.contains_xy(points)]
