"""Grippers and supports: suction cups, point supports, clamped and simply supported edges.

Coordinates are in metres in the xy footprint of the part; a cup acts on the part surface
above (x, y). A suction cup clamps every node of its disc region rigidly (the disc is the set
of surface points within ``radius`` of the cup centre, measured in 3-D on curved parts).
Edge supports are for validation cases; ``side`` names a side of the footprint's bounding
box ("x0": x = x_min, "x1": x = x_max, "y0", "y1") or "all" for the whole boundary.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from jaxflex.errors import InputError

SIDES = ("all", "x0", "x1", "y0", "y1")


def _finite(owner: str, name: str, value: float) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{owner}.{name}: must be a number (m), got {value!r}") from exc
    if not math.isfinite(x):
        raise InputError(f"{owner}.{name}: must be finite, got {value!r}")
    return x


@dataclass(frozen=True)
class SuctionCup:
    """A vacuum suction cup at (x, y) m with contact radius ``radius`` m (default 40 mm)."""

    x: float
    y: float
    radius: float = 0.04

    def __post_init__(self) -> None:
        object.__setattr__(self, "x", _finite("SuctionCup", "x", self.x))
        object.__setattr__(self, "y", _finite("SuctionCup", "y", self.y))
        r = _finite("SuctionCup", "radius", self.radius)
        if r <= 0:
            raise InputError(f"SuctionCup.radius: must be > 0 m, got {self.radius!r}")
        object.__setattr__(self, "radius", r)

    def describe(self) -> dict:
        return {"type": "suction_cup", "x_m": self.x, "y_m": self.y, "radius_m": self.radius}


@dataclass(frozen=True)
class PointSupport:
    """A pinned point at (x, y) m: the displacement (not the rotation) is held there."""

    x: float
    y: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "x", _finite("PointSupport", "x", self.x))
        object.__setattr__(self, "y", _finite("PointSupport", "y", self.y))

    def describe(self) -> dict:
        return {"type": "point_support", "x_m": self.x, "y_m": self.y}


def _check_side(owner: str, side: str) -> str:
    aliases = {"left": "x0", "right": "x1", "bottom": "y0", "top": "y1"}
    s = aliases.get(str(side).lower(), str(side).lower())
    if s not in SIDES:
        raise InputError(f"{owner}.side: must be one of {list(SIDES)}, got {side!r}")
    return s


@dataclass(frozen=True)
class ClampedEdge:
    """A fully clamped side of the part (displacement and slope held)."""

    side: str = "all"

    def __post_init__(self) -> None:
        object.__setattr__(self, "side", _check_side("ClampedEdge", self.side))

    def describe(self) -> dict:
        return {"type": "clamped_edge", "side": self.side}


@dataclass(frozen=True)
class SimplySupportedEdge:
    """A simply supported (hinged) side: the deflection normal to the surface and the
    displacement along the edge are held, the slope across the edge is free (for thin solids
    this is the shear-diaphragm condition of shell theory)."""

    side: str = "all"

    def __post_init__(self) -> None:
        object.__setattr__(self, "side", _check_side("SimplySupportedEdge", self.side))

    def describe(self) -> dict:
        return {"type": "simply_supported_edge", "side": self.side}


Support = SuctionCup | PointSupport | ClampedEdge | SimplySupportedEdge


def as_support_list(supports) -> list:
    """Normalise a single support or a sequence of supports to a list (type-checked)."""
    if isinstance(supports, SuctionCup | PointSupport | ClampedEdge | SimplySupportedEdge):
        return [supports]
    if not isinstance(supports, Sequence):
        raise InputError(
            "supports: expected a sequence of fem.SuctionCup / PointSupport / ClampedEdge / "
            f"SimplySupportedEdge, got {type(supports).__name__}"
        )
    out = list(supports)
    for i, s in enumerate(out):
        if not isinstance(s, SuctionCup | PointSupport | ClampedEdge | SimplySupportedEdge):
            raise InputError(
                f"supports[{i}]: expected fem.SuctionCup, PointSupport, ClampedEdge or "
                f"SimplySupportedEdge, got {type(s).__name__}"
            )
    return out


def check_layout(supports: list, contains_xy, *, allow_rigid_modes: bool = False) -> None:
    """Reject gripper layouts that cannot hold the part.

    ``contains_xy(xy (N, 2)) -> bool (N,)`` tells whether footprint points lie on the part.
    Raises InputError for a cup or point off the part, a cup overhanging the edge, overlapping
    cups, and (unless ``allow_rigid_modes``) fewer than three non-collinear cups/points when no
    edge is supported.
    """
    cups = [s for s in supports if isinstance(s, SuctionCup)]
    points = [s for s in supports if isinstance(s, PointSupport)]
    edges = [s for s in supports if isinstance(s, ClampedEdge | SimplySupportedEdge)]
    for i, s in enumerate(supports):
        if isinstance(s, SuctionCup | PointSupport):
            kind = "cup" if isinstance(s, SuctionCup) else "point support"
            if not contains_xy(np.array([[s.x, s.y]]))[0]:
                raise InputError(
                    f"supports[{i}]: {kind} centre at ({s.x:g}, {s.y:g}) m is off the part"
                )
        if isinstance(s, SuctionCup):
            angle = np.linspace(0, 2 * np.pi, 48, endpoint=False)
            rim = np.column_stack([s.x + s.radius * np.cos(angle), s.y + s.radius * np.sin(angle)])
            if not contains_xy(rim).all():
                raise InputError(
                    f"supports[{i}]: cup at ({s.x:g}, {s.y:g}) m with radius {s.radius:g} m "
                    "overhangs the edge of the part; move it inwards or use a smaller radius"
                )
    for i in range(len(cups)):
        for j in range(i + 1, len(cups)):
            a, b = cups[i], cups[j]
            gap = math.hypot(a.x - b.x, a.y - b.y) - a.radius - b.radius
            if gap < 0:
                raise InputError(
                    f"supports: cups at ({a.x:g}, {a.y:g}) m and ({b.x:g}, {b.y:g}) m overlap "
                    f"by {-gap * 1e3:.3g} mm; every cup needs its own contact disc"
                )
    if edges or allow_rigid_modes:
        return
    held = cups + points
    hint = "; add supports or pass allow_rigid_modes=True (--allow-rigid-modes) to keep rigid modes"
    if len(held) < 3:
        raise InputError(
            f"supports: {len(held)} cup(s)/point(s) cannot hold the part without rigid-body "
            f"modes; at least 3 non-collinear cups are needed{hint}"
        )
    centres = np.array([[s.x, s.y] for s in held])
    centred = centres - centres.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    off_line = np.abs(centred @ vt[1])
    tolerance = min((s.radius for s in cups), default=1e-3)
    if off_line.max() <= tolerance:
        raise InputError(
            f"supports: the {len(held)} cups/points are collinear (all within "
            f"{tolerance * 1e3:.3g} mm of one line), so the part can rotate about that line; "
            f"at least 3 non-collinear cups are needed{hint}"
        )
