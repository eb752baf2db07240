"""The obstacle records of the FMU resource: ONE table of kinds for the Python writer and the
C reader.

Every obstacle of a jaxflex.geometry.Cell is written as records of :data:`RECORD_VALUES` f64
values: the kind's code, then its values (:attr:`ObstacleKind.layout`, padded with 0). The C
reader (``fmu/c/jxf_cell.c``) sees the same table as macros of the generated ``jxf_config.h``
(:func:`config_lines`: ``JXF_OBSTACLE_<NAME>`` codes and the list of codes); it refuses a
resource with a code outside the table when the FMU is instantiated, and does not compile if
the table names a kind it does not implement. An obstacle of a kind outside the table is
refused here (:class:`InputError`), never written as something else.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from jaxflex.errors import InputError
from jaxflex.geometry import Box, HalfSpace, TriangleMesh

RECORD_VALUES = 16


@dataclass(frozen=True)
class ObstacleKind:
    """One kind of record: ``name`` (in messages; C macro ``JXF_OBSTACLE_<NAME>``), ``code``
    (the record's first value), the jaxflex._cell class written as it, the function giving that
    obstacle's records (rows of values after the code, m) and the layout of those values."""

    name: str
    code: int
    obstacle: type
    values: Callable[[object], list[list[float]]]
    layout: str


OBSTACLE_KINDS: tuple[ObstacleKind, ...] = (
    ObstacleKind(
        "box", 1, Box,
        lambda o: [[*o.centre_m, *(o.size_m / 2), *o.rotation.ravel()]],
        "centre (3), half edges (3), rotation (9, row-major; its columns are the box axes)",
    ),
    ObstacleKind(
        "half_space", 2, HalfSpace,
        lambda o: [[*o.normal, o.offset_m]],
        "unit normal (3), offset (1): the solid is normal . x <= offset",
    ),
    ObstacleKind(
        "triangle", 3, TriangleMesh,
        lambda o: [list(corners.ravel()) for corners in o.vertices[o.triangles]],
        "corners (3 x 3); a triangle mesh is one record per triangle",
    ),
)  # fmt: skip


def allowed_kinds() -> str:
    """The kinds of the table as a message lists them."""
    return ", ".join(f"{k.name} ({k.obstacle.__name__}, code {k.code})" for k in OBSTACLE_KINDS)


def obstacle_records(obstacles: Iterable) -> np.ndarray:
    """(O, RECORD_VALUES) records of jaxflex._cell obstacles (a mesh gives one per triangle);
    InputError naming an obstacle whose kind is not in :data:`OBSTACLE_KINDS`."""
    by_class = {kind.obstacle: kind for kind in OBSTACLE_KINDS}
    rows = []
    for index, obstacle in enumerate(obstacles):
        kind = by_class.get(type(obstacle))
        if kind is None:
            raise InputError(
                f"cell.obstacles[{index}]: obstacle kind {type(obstacle).__name__!r} cannot be "
                f"written into an FMU; allowed: {allowed_kinds()}"
            )
        for values in kind.values(obstacle):
            rows.append([kind.code, *values] + [0.0] * (RECORD_VALUES - 1 - len(values)))
    return np.array(rows, dtype=np.float64).reshape(-1, RECORD_VALUES)


def unknown_codes(records: np.ndarray) -> list[float]:
    """The kind codes in ``records`` (O, RECORD_VALUES) that the table does not have."""
    known = {float(kind.code) for kind in OBSTACLE_KINDS}
    return sorted({float(c) for c in np.asarray(records)[:, 0]} - known, key=repr)


def config_lines() -> list[str]:
    """The table as C macros for ``jxf_config.h``."""
    codes = ", ".join(str(kind.code) for kind in OBSTACLE_KINDS)
    allowed = ", ".join(f"{kind.name} ({kind.code})" for kind in OBSTACLE_KINDS)
    return [
        f"#define JXF_OBSTACLE_VALUES {RECORD_VALUES}",
        *(f"#define JXF_OBSTACLE_{kind.name.upper()} {kind.code}" for kind in OBSTACLE_KINDS),
        f"#define JXF_OBSTACLE_KIND_COUNT {len(OBSTACLE_KINDS)}",
        f"#define JXF_OBSTACLE_CODES {{{codes}}}",
        f'#define JXF_OBSTACLE_ALLOWED "{allowed}"',
    ]
