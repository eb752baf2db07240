"""Grippers and supports: suction cups, point supports, clamped and simply supported edges.

Coordinates are in metres, in the part's coordinates: a cup at (x, y) acts on the part
surface above (or below) that footprint point, a cup at (x, y, z) on the surface point
nearest to it (its projection along the surface normal; the way to reach a flange that has
no footprint). A suction cup clamps every node of its disc region rigidly (the disc is the
set of surface points within ``radius`` of the cup centre, measured in 3-D on curved
parts), or, with a ``stiffness`` (fem.cups.CupStiffness), ties the disc to a rigid pad on
springs: a compliant rubber cup instead of a rigid clamp. A cup also states what it can hold
(:attr:`Support.cup_rating`), which the model records with its reactions (fem.outputs).
Edge supports are for validation cases; ``side`` names a side of the footprint's bounding
box ("x0": x = x_min, "x1": x = x_max, "y0", "y1") or "all" for the whole boundary.

Every support is a :class:`Support`: it states which degrees of freedom it holds on a
Kirchhoff plate (:meth:`Support.hold_plate`, asking a :class:`PlateDofs`) and on the
surface formulations, the thin solid and the shell (:meth:`Support.hold_solid`, asking a
:class:`SolidDofs`), how it is
described in the model's meta and drawn, and what the layout checks and the mesh refinement
need to know (:attr:`Support.anchor_xy`, :attr:`Support.contact_disc`,
:attr:`Support.prevents_rigid_motion`). A new gripper type is one subclass; the assembly,
the checks, the meta and the pictures ask it instead of testing its type.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, NamedTuple, Protocol

import numpy as np

from fem.cups import DEFAULT_FRICTION, DEFAULT_VACUUM_PA, CupStiffness
from fem.system import Constraints
from jaxflex.errors import InputError
from jaxflex.files import check_positive

SIDES = ("all", "x0", "x1", "y0", "y1")
# a point given in space lands on the surface to rounding: this x the part's size is "on it"
OFF_PART_RELATIVE = 1e-9


class Disc(NamedTuple):
    """A contact disc: centre (x, y) in the footprint, or (x, y, z) near the surface, and
    radius, m."""

    x: float
    y: float
    radius: float
    z: float | None = None

    @property
    def point(self) -> list[float]:
        """[x, y] or [x, y, z] as given, m."""
        return [self.x, self.y] if self.z is None else [self.x, self.y, self.z]


class PlateDofs(Protocol):
    """What a support may ask of a Kirchhoff plate (fem.elements.plate provides it)."""

    @property
    def centroids_xy(self) -> np.ndarray:
        """(E, 2) element centroids, m."""

    def nearest_vertex(self, x: float, y: float) -> int:
        """Index of the mesh vertex nearest to (x, y) m."""

    def clamp_elements(self, held: np.ndarray) -> Constraints:
        """Clamp the elements of the mask ``held`` (E,): deflection and slopes at their
        vertices, normal slopes on their edges."""

    def spring_elements(
        self, held: np.ndarray, centre_xy: tuple[float, float], axial_n_m: float, tilt_nm_rad: float
    ) -> Constraints:
        """Tie what :meth:`clamp_elements` holds to a rigid pad on an axial and two tilt
        springs about ``centre_xy``."""

    def pin_vertices(self, vertices) -> Constraints:
        """Hold the deflection (not the slopes) at ``vertices``."""

    def hold_side(self, side: str, *, clamped: bool) -> Constraints:
        """Simply support (deflection held) or clamp (slope across it too) a side in SIDES."""


class SolidDofs(Protocol):
    """What a support may ask of a surface formulation: the thin solid (fem.elements.solid) and the
    shell (fem.elements.shell) provide it."""

    @property
    def surface_points(self) -> np.ndarray:
        """(Ns, 3) mid-surface nodes, m (their footprint is the first two columns)."""

    def distance_m(self, x: float, y: float, z: float | None = None) -> np.ndarray:
        """(Ns,) 3-D distance of every mid-surface node from the surface point above (x, y),
        or nearest to (x, y, z)."""

    def nearest_vertex(self, x: float, y: float, z: float | None = None) -> int:
        """The mesh vertex (a mid-surface node) nearest to that surface point."""

    def disc_nodes(self, x: float, y: float, z: float | None, radius: float) -> np.ndarray:
        """The mid-surface nodes a clamped disc of ``radius`` (m) around that surface point
        holds (the thin solid: those within the radius; the shell: within the radius plus
        half the local element size, so that the held elements fill the disc on average)."""

    def clamp_nodes(self, surface_nodes) -> Constraints:
        """Hold every displacement component through the thickness at ``surface_nodes``
        (the shell: translations and rotations)."""

    def pin_nodes(self, surface_nodes) -> Constraints:
        """Hold the displacement at ``surface_nodes`` (the shell: translations only; the
        one-layer solid: through the thickness, as clamp_nodes)."""

    def spring_nodes(
        self, surface_nodes, x: float, y: float, stiffness, z: float | None = None
    ) -> Constraints:
        """Tie what :meth:`clamp_nodes` holds to a rigid pad at the surface point above
        (x, y) (nearest to (x, y, z)) on six springs (lateral, lateral, axial N/m; tilt,
        tilt, torsion N m/rad)."""

    def hold_side(self, side: str, *, clamped: bool) -> Constraints:
        """Clamp a side in SIDES, or simply support it (normal and along-edge displacement
        held, the slope across it free)."""


class Support(ABC):
    """A gripper or support of the part (module docstring).

    Subclasses implement :meth:`describe`, :meth:`hold_plate` and :meth:`hold_solid`; the
    other members have defaults for a support without a contact disc or anchor point.
    ``noun`` names the support in error messages.
    """

    noun: ClassVar[str] = "support"

    @abstractmethod
    def describe(self) -> dict:
        """JSON-serialisable description for the model's meta ("type" names the support)."""

    @abstractmethod
    def hold_plate(self, plate: PlateDofs, index: int) -> Constraints:
        """The plate DOFs this support holds; ``index`` is its position in the support list
        (for error messages)."""

    @abstractmethod
    def hold_solid(self, solid: SolidDofs, index: int) -> Constraints:
        """The thin-solid DOFs (or directions at nodes) this support holds."""

    @property
    def anchor_xy(self) -> tuple[float, float] | None:
        """Footprint point (m) the support holds the part at, or None (edges): checked to lie
        on the part and counted towards the three non-collinear holds."""
        return None

    @property
    def anchor_z(self) -> float | None:
        """z (m) of the anchor when it was given in space (the surface point nearest to
        (x, y, z) is held), None for the surface point above the footprint point."""
        return None

    def anchor_point(self) -> list[float] | None:
        """The anchor as given: [x, y] or [x, y, z] (m), or None."""
        if self.anchor_xy is None:
            return None
        z = self.anchor_z
        return [*self.anchor_xy] if z is None else [*self.anchor_xy, z]

    @property
    def contact_disc(self) -> Disc | None:
        """The footprint disc the support holds (None: none). The mesh is refined around it,
        it must lie on the part and must not overlap another support's disc."""
        return None

    @property
    def prevents_rigid_motion(self) -> bool:
        """True if this support alone removes every rigid-body mode (clamped or simply
        supported edges), so the layout needs no three non-collinear anchors."""
        return False

    @property
    def cup_rating(self) -> CupRating | None:
        """What the support can hold if it is a suction cup (its reactions are then recorded
        in the model, fem.outputs), else None."""
        return None

    def draw(self, ax) -> str | None:
        """Draw the support on the matplotlib axes of the footprint (m); return a caption for
        the title if it is not drawn (None if it is)."""
        return self.describe()["type"]

    def check_on_part(self, index: int, part) -> None:
        """Raise InputError if the support is not on ``part`` (a fem.parts.Part): its anchor
        off the part (saying how far, and in which unit it was read), or its disc
        overhanging an edge or reaching over a fold."""
        point = self.anchor_point()
        if point is not None:
            _, off = part.place([point])
            lo, hi = part.bounds_m()
            if off[0] > OFF_PART_RELATIVE * float(np.max(hi - lo)):
                raise InputError(
                    f"supports[{index}]: {self.noun} centre at {_show(point)} m is "
                    f"{off[0]:.4g} m off the part{_unit_hint(point, part)}"
                )
        disc = self.contact_disc
        if disc is not None:
            centre = part.place([disc.point])[0][0]
            problem = part.disc_problem(centre, disc.radius)
            if problem:
                raise InputError(
                    f"supports[{index}]: {self.noun} at {_show(disc.point)} m with radius "
                    f"{disc.radius:g} m {problem}; move it or use a smaller radius"
                )


def _show(point) -> str:
    return "(" + ", ".join(f"{v:g}" for v in point) + ")"


def _unit_hint(point, part) -> str:
    """Where the part is, in the unit the point was read in (m); and the millimetre slip
    if the point divided by 1000 lies on the part."""
    lo, hi = part.bounds_m()
    axes = "xyz"[: len(point)]
    box = ", ".join(f"{a} {lo[i]:.4g} ... {hi[i]:.4g}" for i, a in enumerate(axes))
    text = f" (coordinates are read in metres; the part spans {box} m)"
    scaled = [v * 1e-3 for v in point]
    if part.place([scaled])[1][0] == 0.0:
        text += f"; in millimetres it lies on the part: give {_show(scaled)} m"
    return text


def _finite(owner: str, name: str, value: float) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{owner}.{name}: must be a number (m), got {value!r}") from exc
    if not math.isfinite(x):
        raise InputError(f"{owner}.{name}: must be finite, got {value!r}")
    return x


class CupRating(NamedTuple):
    """What a suction cup holds: effective radius (m), holding force dp x A without safety
    factor (N), friction coefficient between cup and part (fem.cups)."""

    radius_m: float
    holding_force_n: float
    friction: float


@dataclass(frozen=True)
class SuctionCup(Support):
    """A vacuum suction cup at (x, y) m with contact radius ``radius`` m (default 40 mm); with
    ``z`` (m) it sits on the surface point nearest to (x, y, z) (e.g. on a flange).

    ``stiffness``: None (default) clamps the disc rigidly; a fem.cups.CupStiffness, a preset
    ("flat", "bellows") or four numbers (axial N/m, lateral N/m, tilt N m/rad, torsion
    N m/rad) make it compliant. ``vacuum_pa`` (pressure difference, default 60 kPa) and
    ``friction`` (default 0.5, dry metal) give its rating (fem.cups).
    """

    x: float
    y: float
    radius: float = 0.04
    z: float | None = None
    stiffness: CupStiffness | str | tuple | None = None
    vacuum_pa: float = DEFAULT_VACUUM_PA
    friction: float = DEFAULT_FRICTION
    noun: ClassVar[str] = "cup"

    def __post_init__(self) -> None:
        object.__setattr__(self, "x", _finite("SuctionCup", "x", self.x))
        object.__setattr__(self, "y", _finite("SuctionCup", "y", self.y))
        if self.z is not None:
            object.__setattr__(self, "z", _finite("SuctionCup", "z", self.z))
        r = _finite("SuctionCup", "radius", self.radius)
        if r <= 0:
            raise InputError(f"SuctionCup.radius: must be > 0 m, got {self.radius!r}")
        object.__setattr__(self, "radius", r)
        object.__setattr__(self, "stiffness", CupStiffness.resolve(self.stiffness, r))
        object.__setattr__(
            self, "vacuum_pa", check_positive("SuctionCup.vacuum_pa", self.vacuum_pa)
        )
        object.__setattr__(self, "friction", check_positive("SuctionCup.friction", self.friction))

    def describe(self) -> dict:
        out = {
            "type": "suction_cup",
            "x_m": self.x,
            "y_m": self.y,
            "radius_m": self.radius,
            "stiffness": None if self.stiffness is None else self.stiffness.as_dict(),
            "vacuum_pa": self.vacuum_pa,
            "friction": self.friction,
        }
        return out if self.z is None else {**out, "z_m": self.z}

    @property
    def cup_rating(self) -> CupRating:
        return CupRating(self.radius, self.vacuum_pa * math.pi * self.radius**2, self.friction)

    @property
    def anchor_xy(self) -> tuple[float, float]:
        return self.x, self.y

    @property
    def anchor_z(self) -> float | None:
        return self.z

    @property
    def contact_disc(self) -> Disc:
        return Disc(self.x, self.y, self.radius, self.z)

    def hold_plate(self, plate: PlateDofs, index: int) -> Constraints:
        # the disc is the union of the triangles whose centroid lies in it
        centroid = plate.centroids_xy
        held = np.hypot(centroid[:, 0] - self.x, centroid[:, 1] - self.y) <= self.radius
        if not held.any():
            raise InputError(
                f"supports[{index}]: the cup at ({self.x:g}, {self.y:g}) m covers no element "
                "centroid; use a smaller mesh_size"
            )
        if self.stiffness is None:
            return plate.clamp_elements(held)
        k = self.stiffness
        return plate.spring_elements(held, (self.x, self.y), k.axial_n_m, k.tilt_nm_rad)

    def hold_solid(self, solid: SolidDofs, index: int) -> Constraints:
        inside = solid.disc_nodes(self.x, self.y, self.z, self.radius)
        if inside.size == 0:
            raise InputError(
                f"supports[{index}]: the cup at ({self.x:g}, {self.y:g}) m contains no mesh "
                "node; use a smaller mesh_size"
            )
        if self.stiffness is None:
            return solid.clamp_nodes(inside)
        k = self.stiffness
        springs = [k.lateral_n_m, k.lateral_n_m, k.axial_n_m]
        springs += [k.tilt_nm_rad, k.tilt_nm_rad, k.torsion_nm_rad]
        return solid.spring_nodes(inside, self.x, self.y, springs, self.z)

    def draw(self, ax) -> None:
        angle = np.linspace(0, 2 * np.pi, 65)
        ax.fill(
            self.x + self.radius * np.cos(angle),
            self.y + self.radius * np.sin(angle),
            color="tab:red",
            alpha=0.6,
            lw=0,
        )


@dataclass(frozen=True)
class PointSupport(Support):
    """A pinned point at (x, y) m (or nearest to (x, y, z)): the displacement (not the
    rotation) is held at the mesh vertex nearest to it."""

    x: float
    y: float
    z: float | None = None
    noun: ClassVar[str] = "point support"

    def __post_init__(self) -> None:
        object.__setattr__(self, "x", _finite("PointSupport", "x", self.x))
        object.__setattr__(self, "y", _finite("PointSupport", "y", self.y))
        if self.z is not None:
            object.__setattr__(self, "z", _finite("PointSupport", "z", self.z))

    def describe(self) -> dict:
        out = {"type": "point_support", "x_m": self.x, "y_m": self.y}
        return out if self.z is None else {**out, "z_m": self.z}

    @property
    def anchor_xy(self) -> tuple[float, float]:
        return self.x, self.y

    @property
    def anchor_z(self) -> float | None:
        return self.z

    def hold_plate(self, plate: PlateDofs, index: int) -> Constraints:
        return plate.pin_vertices([plate.nearest_vertex(self.x, self.y)])

    def hold_solid(self, solid: SolidDofs, index: int) -> Constraints:
        return solid.pin_nodes([solid.nearest_vertex(self.x, self.y, self.z)])

    def draw(self, ax) -> None:
        ax.plot(self.x, self.y, "^", color="tab:red")


def _check_side(owner: str, side: str) -> str:
    aliases = {"left": "x0", "right": "x1", "bottom": "y0", "top": "y1"}
    s = aliases.get(str(side).lower(), str(side).lower())
    if s not in SIDES:
        raise InputError(f"{owner}.side: must be one of {list(SIDES)}, got {side!r}")
    return s


@dataclass(frozen=True)
class _Edge(Support):
    """A supported side of the part; ``clamped`` tells whether the slope across it is held."""

    side: str = "all"
    clamped: ClassVar[bool]

    def __post_init__(self) -> None:
        object.__setattr__(self, "side", _check_side(type(self).__name__, self.side))

    @property
    def prevents_rigid_motion(self) -> bool:
        return True

    def hold_plate(self, plate: PlateDofs, index: int) -> Constraints:
        return plate.hold_side(self.side, clamped=self.clamped)

    def hold_solid(self, solid: SolidDofs, index: int) -> Constraints:
        return solid.hold_side(self.side, clamped=self.clamped)

    def draw(self, ax) -> str:
        return f"{self.describe()['type']} {self.side}"


@dataclass(frozen=True)
class ClampedEdge(_Edge):
    """A fully clamped side of the part (displacement and slope held)."""

    clamped: ClassVar[bool] = True
    noun: ClassVar[str] = "clamped edge"

    def describe(self) -> dict:
        return {"type": "clamped_edge", "side": self.side}


@dataclass(frozen=True)
class SimplySupportedEdge(_Edge):
    """A simply supported (hinged) side: the deflection normal to the surface and the
    displacement along the edge are held, the slope across the edge is free (for thin solids
    this is the shear-diaphragm condition of shell theory)."""

    clamped: ClassVar[bool] = False
    noun: ClassVar[str] = "simply supported edge"

    def describe(self) -> dict:
        return {"type": "simply_supported_edge", "side": self.side}


def as_support_list(supports) -> list[Support]:
    """Normalise a single support or a sequence of supports to a list (type-checked)."""
    if isinstance(supports, Support):
        return [supports]
    if not isinstance(supports, Sequence):
        raise InputError(
            "supports: expected a sequence of fem.Support (SuctionCup, PointSupport, "
            f"ClampedEdge, SimplySupportedEdge, ...), got {type(supports).__name__}"
        )
    out = list(supports)
    for i, s in enumerate(out):
        if not isinstance(s, Support):
            raise InputError(
                f"supports[{i}]: expected a fem.Support (SuctionCup, PointSupport, ClampedEdge, "
                f"SimplySupportedEdge, ...), got {type(s).__name__}"
            )
    return out


def contact_discs(supports: Sequence[Support]) -> list[Disc]:
    """The contact discs of ``supports`` (those that have one), in order."""
    return [s.contact_disc for s in supports if s.contact_disc is not None]


def check_layout(supports: list[Support], part, *, allow_rigid_modes: bool = False) -> None:
    """Reject gripper layouts that cannot hold ``part`` (a fem.parts.Part).

    Raises InputError for a support off the part (its anchor or contact disc: how far off,
    in which unit), overlapping contact discs, and (unless ``allow_rigid_modes``) fewer than
    three non-collinear anchors (cups/points) when no support removes the rigid-body modes
    alone (an edge). Distances are measured between the surface points of the supports.
    """
    for i, s in enumerate(supports):
        s.check_on_part(i, part)
    discs = [(s, s.contact_disc) for s in supports if s.contact_disc is not None]
    centres = part.place([d.point for _, d in discs])[0] if discs else np.empty((0, 3))
    for i, (s, a) in enumerate(discs):
        for j in range(i + 1, len(discs)):
            t, b = discs[j]
            gap = float(np.linalg.norm(centres[i] - centres[j])) - a.radius - b.radius
            if gap < 0:
                raise InputError(
                    f"supports: {s.noun} at {_show(a.point)} m and {t.noun} at "
                    f"{_show(b.point)} m overlap by {-gap * 1e3:.3g} mm; every support "
                    "needs its own contact disc"
                )
    if allow_rigid_modes or any(s.prevents_rigid_motion for s in supports):
        return
    anchors = [s.anchor_point() for s in supports if s.anchor_xy is not None]
    hint = "; add supports or pass allow_rigid_modes=True (--allow-rigid-modes) to keep rigid modes"
    if len(anchors) < 3:
        raise InputError(
            f"supports: {len(anchors)} cup(s)/point(s) cannot hold the part without rigid-body "
            f"modes; at least 3 non-collinear cups are needed{hint}"
        )
    points = part.place(anchors)[0]
    centred = points - points.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    off_line = np.linalg.norm(centred - np.outer(centred @ vt[0], vt[0]), axis=1)
    tolerance = min((d.radius for _, d in discs), default=1e-3)
    if off_line.max() <= tolerance:
        raise InputError(
            f"supports: the {len(anchors)} cups/points are collinear (all within "
            f"{tolerance * 1e3:.3g} mm of one line), so the part can rotate about that line; "
            f"at least 3 non-collinear cups are needed{hint}"
        )
