"""Suction cups as machine elements: their stiffness and what they can hold (SI units).

**Holding capacity** (as vacuum-gripper makers state it; Schmalz, "Theoretical holding force
of a suction cup" and the glossary entry "holding force"): F_hold = dp x A, the vacuum
(pressure difference, Pa) times the effective suction area (m^2), stated at 60 % relative
vacuum (dp = 60 kPa) without a safety factor; friction coefficient mu = 0.5 for dry metal
(0.1 - 0.3 for oiled sheet); safety factor S >= 1.5 for smooth, dense parts (2 or more for
oiled, rough or porous ones). The utilisation of a cup under a general load is
jaxflex.cups.CupUtilisation.

**Stiffness** (:class:`CupStiffness`): springs between the gripper and a rigid pad that
carries the part over the cup's contact disc (fem.supports.SuctionCup): axial (along the
surface normal), lateral (each tangent direction), tilt (about each tangent) and torsion
(about the normal). Use the maker's data or a measurement when you have them. The presets
are *models*, not measurements; they state their assumptions:

* the rubber's Young's modulus from its Shore A hardness S by Gent's relation (A. N. Gent,
  "On the relation between indentation hardness and Young's modulus", Trans. Inst. Rubber
  Ind. 34 (1958) 46-57): E = 0.0981 (56 + 7.62336 S) / (0.137505 (254 - 2.54 S)) MPa;
  incompressible (nu = 0.5, G = E / 3);
* ``flat``: the lip is a short rubber ring (mean radius r, width 0.15 r, height 0.1 r)
  bonded between cup body and sheet; compression with the shape-factor rule for bonded
  blocks, E_c = E (1 + 2 k s^2), s = width / (2 height), k = 0.64 (Gent and Lindley 1959;
  P. B. Lindley, "Engineering design with natural rubber"); axial E_c A / h, lateral G A / h,
  tilt E_c I / h with I = pi r^3 w, torsion G J / h with J = 2 pi r^3 w;
* ``bellows``: every fold has two walls, annular rubber plates (outer radius r, inner
  0.6 r, thickness 0.1 r) clamped at the outer and guided at the inner edge, loaded at the
  inner edge (Kirchhoff plate, closed form); the walls act in series (axial). Lateral, tilt
  and torsion follow from the bellows as a short tube of length (folds x 0.25 r) and mean
  radius 0.8 r with that axial stiffness per length (beam analogy with guided ends).

For a 40 mm cup (Shore 60) this gives axial 2.3e6 N/m (flat) and 5.1e3 N/m (1.5-fold
bellows): a flat cup is close to a rigid clamp, a bellows cup lets a 10 kg sheet bounce at
a few Hz.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from jaxflex.errors import InputError
from jaxflex.files import check_positive

DEFAULT_VACUUM_PA = 60e3  # 60 % relative vacuum, the makers' reference for holding forces
DEFAULT_FRICTION = 0.5  # dry metal (Schmalz reference values)
PRESETS = ("flat", "bellows")


def shore_a_modulus_pa(shore_a: float) -> float:
    """Young's modulus (Pa) of a rubber of Shore A hardness ``shore_a`` (Gent 1958)."""
    if not 20 <= shore_a <= 90:
        raise InputError(f"shore_a: Gent's relation holds for 20 ... 90 Shore A, got {shore_a}")
    return 1e6 * 0.0981 * (56 + 7.62336 * shore_a) / (0.137505 * (254 - 2.54 * shore_a))


def annular_wall_stiffness(outer_m: float, inner_m: float, bending_nm: float) -> float:
    """Axial stiffness (N/m) of an annular plate clamped at ``outer_m``, guided (slope 0) at
    ``inner_m`` and loaded there: w = C1 + C2 r^2 + C3 ln r + C4 r^2 ln r with w(a) = w'(a) =
    w'(b) = 0 and the shear of the load P, C4 = P / (8 pi D)."""

    def w(r):
        return np.array([1.0, r * r, math.log(r), r * r * math.log(r)])

    def slope(r):
        return np.array([0.0, 2 * r, 1 / r, 2 * r * math.log(r) + r])

    matrix = np.array([w(outer_m), slope(outer_m), slope(inner_m), [0.0, 0.0, 0.0, 1.0]])
    coef = np.linalg.solve(matrix, [0.0, 0.0, 0.0, 1.0 / (8 * math.pi * bending_nm)])
    return 1.0 / abs(float(w(inner_m) @ coef))


@dataclass(frozen=True)
class CupStiffness:
    """Springs of a suction cup (module docstring): axial_n_m and lateral_n_m in N/m,
    tilt_nm_rad and torsion_nm_rad in N m/rad, each finite and > 0."""

    axial_n_m: float
    lateral_n_m: float
    tilt_nm_rad: float
    torsion_nm_rad: float
    source: str = "given"

    def __post_init__(self) -> None:
        for name in ("axial_n_m", "lateral_n_m", "tilt_nm_rad", "torsion_nm_rad"):
            object.__setattr__(self, name, check_positive(f"stiffness.{name}", getattr(self, name)))

    @classmethod
    def flat(cls, radius_m: float, shore_a: float = 60.0) -> CupStiffness:
        """A flat cup of contact radius ``radius_m`` (module docstring)."""
        r = check_positive("radius_m", radius_m)
        e = shore_a_modulus_pa(shore_a)
        width, height = 0.15 * r, 0.1 * r
        shape_factor = width / (2 * height)
        e_c = e * (1 + 2 * 0.64 * shape_factor**2)
        area = 2 * math.pi * r * width
        return cls(
            axial_n_m=e_c * area / height,
            lateral_n_m=(e / 3) * area / height,
            tilt_nm_rad=e_c * math.pi * r**3 * width / height,
            torsion_nm_rad=(e / 3) * 2 * math.pi * r**3 * width / height,
            source=f"flat cup model, Shore {shore_a:g} A (fem.cups)",
        )

    @classmethod
    def bellows(cls, radius_m: float, folds: float = 1.5, shore_a: float = 60.0) -> CupStiffness:
        """A bellows cup of contact radius ``radius_m`` with ``folds`` folds (module
        docstring)."""
        r = check_positive("radius_m", radius_m)
        folds = check_positive("folds", folds)
        e = shore_a_modulus_pa(shore_a)
        wall = 0.1 * r
        bending = e * wall**3 / (12 * (1 - 0.5**2))
        walls = max(1, round(2 * folds))
        axial = annular_wall_stiffness(r, 0.6 * r, bending) / walls
        length, mean = folds * 0.25 * r, 0.8 * r
        return cls(
            axial_n_m=axial,
            lateral_n_m=6 * axial * mean**2 / length**2,
            tilt_nm_rad=axial * mean**2 / 2,
            torsion_nm_rad=(e / 3) * 2 * math.pi * mean**3 * wall / (walls * 0.4 * r),
            source=f"{folds:g}-fold bellows cup model, Shore {shore_a:g} A (fem.cups)",
        )

    @classmethod
    def resolve(cls, spec, radius_m: float) -> CupStiffness | None:
        """None (rigid clamp), a CupStiffness, a preset name in PRESETS, or four numbers
        (axial N/m, lateral N/m, tilt N m/rad, torsion N m/rad)."""
        if spec is None or isinstance(spec, CupStiffness):
            return spec
        if isinstance(spec, str):
            if spec == "flat":
                return cls.flat(radius_m)
            if spec == "bellows":
                return cls.bellows(radius_m)
            raise InputError(
                f"stiffness: a preset {list(PRESETS)}, four numbers or a CupStiffness, got {spec!r}"
            )
        try:
            values = [float(v) for v in spec]
        except (TypeError, ValueError) as exc:
            raise InputError(
                f"stiffness: a preset {list(PRESETS)}, four numbers (axial N/m, lateral N/m, "
                f"tilt N m/rad, torsion N m/rad) or a CupStiffness, got {spec!r}"
            ) from exc
        if len(values) != 4:
            raise InputError(f"stiffness: expected four numbers, got {len(values)}")
        return cls(*values)

    def as_dict(self) -> dict:
        return asdict(self)
