"""Consistent unit systems of imported finite-element files, and their conversion to SI.

A consistent system fixes a length unit L and a mass unit m (time is the second in all of
them, force is m L / s^2). Mass-normalised mode shapes then carry L / m^0.5, participation
factors m^0.5, moduli m / (L s^2) and densities m / L^3; each converts to SI by one factor.
Names follow MAPDL's /UNITS (the header of an ANSYS result file states one of them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from jaxflex.errors import InputError

_LBF_N = 4.4482216152605


@dataclass(frozen=True)
class Units:
    """A consistent unit system: ``length_m`` metres per length unit, ``mass_kg`` kilograms
    per mass unit (seconds for time)."""

    name: str
    length_m: float
    mass_kg: float
    description: str

    @property
    def shape_to_si(self) -> float:
        """Factor from mass-normalised shapes (L / m^0.5) to m / kg^0.5."""
        return self.length_m / math.sqrt(self.mass_kg)

    @property
    def gamma_to_si(self) -> float:
        """Factor from participation factors (m^0.5) to kg^0.5."""
        return math.sqrt(self.mass_kg)

    @property
    def modulus_to_si(self) -> float:
        """Factor from moduli and stresses (m / (L s^2)) to Pa."""
        return self.mass_kg / self.length_m

    @property
    def density_to_si(self) -> float:
        """Factor from densities (m / L^3) to kg/m^3."""
        return self.mass_kg / self.length_m**3

    def describe(self) -> dict:
        return {
            "name": self.name,
            "length_m": self.length_m,
            "mass_kg": self.mass_kg,
            "description": self.description,
        }


UNIT_SYSTEMS: dict[str, Units] = {
    "SI": Units("SI", 1.0, 1.0, "m, kg, s, N, Pa"),
    "MPA": Units("MPA", 1e-3, 1e3, "mm, t (Mg), s, N, MPa"),
    "CGS": Units("CGS", 1e-2, 1e-3, "cm, g, s, dyn, dyn/cm^2"),
    "UMKS": Units("UMKS", 1e-6, 1.0, "um, kg, s, uN, MPa"),
    "BIN": Units("BIN", 0.0254, _LBF_N / 0.0254, "in, lbf s^2/in, s, lbf, psi"),
    "BFT": Units("BFT", 0.3048, _LBF_N / 0.3048, "ft, slug, s, lbf, lbf/ft^2"),
}
_ALIASES = {"MKS": "SI", "MMNS": "MPA", "MM": "MPA"}


def resolve_units(spec: str | Units | None, stated: str | None, source: str) -> Units:
    """The unit system of ``source``: ``spec`` (a name of UNIT_SYSTEMS or Units) when given,
    else the one the file states (``stated``, a UNIT_SYSTEMS name, or None for unknown)."""
    if isinstance(spec, Units):
        return spec
    if spec is None:
        if stated is None:
            raise InputError(
                f"units: {source} does not state its unit system; pass units= (--units) one of "
                f"{_choices()}"
            )
        return UNIT_SYSTEMS[stated]
    key = str(spec).strip().upper()
    key = _ALIASES.get(key, key)
    if key not in UNIT_SYSTEMS:
        raise InputError(f"units: unknown unit system {spec!r}; use one of {_choices()}")
    units = UNIT_SYSTEMS[key]
    if stated is not None and stated != units.name:
        raise InputError(
            f"units: {source} states {stated} ({UNIT_SYSTEMS[stated].description}), "
            f"units={spec!r} says otherwise; omit units to use the file's"
        )
    return units


def _choices() -> str:
    return ", ".join(f"{k} ({u.description})" for k, u in UNIT_SYSTEMS.items())
