"""The robot cell's geometry and the certified clearance, for the layers above the core: the
obstacles (Box, HalfSpace, TriangleMesh), the cell (the part's pose, the path's via points,
gravity) and the minimum distance of the part to the obstacles over a move and its settling
(turning_min_distance: of a part that turns, its move a jaxflex.response.Turn), and the
exact positions of the part's points that the clearance's search evaluates (positions_at,
turning_positions_at: pictures and animations draw them).
Coordinates are the cell's, in m. Reading a cell file is optim.cell_file's job. Public:
these names are kept stable; the modules they come from (cell, collision,
turning_collision) are private.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): each name loads only its module
    from jaxflex._cell import (
        DEFAULT_GRAVITY_M_S2,
        Box,
        Cell,
        HalfSpace,
        Obstacle,
        TriangleMesh,
        Via,
        rotation_from_degrees,
    )
    from jaxflex._collision import (
        BLOCK_POINTS,
        Approaches,
        Clearance,
        close_approaches,
        distances,
        gravity_offset,
        min_distance,
        nearest_distances,
        part_half_thickness,
        positions_at,
    )
    from jaxflex._turning_collision import (
        rotations_between,
        turning_min_distance,
        turning_positions_at,
    )

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "BLOCK_POINTS",
    "DEFAULT_GRAVITY_M_S2",
    "Approaches",
    "Box",
    "Cell",
    "Clearance",
    "HalfSpace",
    "Obstacle",
    "TriangleMesh",
    "Via",
    "close_approaches",
    "distances",
    "gravity_offset",
    "min_distance",
    "nearest_distances",
    "part_half_thickness",
    "positions_at",
    "rotation_from_degrees",
    "rotations_between",
    "turning_min_distance",
    "turning_positions_at",
]
