"""Linear elastic isotropic materials: presets and user values (SI units: Pa, kg/m^3)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

from jaxflex.errors import InputError


@dataclass(frozen=True)
class Material:
    """Isotropic linear elastic material.

    Attributes:
        name: label stored in the model metadata.
        E_pa: Young's modulus in Pa (> 0).
        nu: Poisson ratio, 0 <= nu < 0.5.
        rho_kg_m3: density in kg/m^3 (> 0).
        yield_pa: yield strength in Pa (> 0) or None (unknown): the default stress limit of
            the optimiser is yield / 1.5 (jaxflex._loads).
    """

    name: str
    E_pa: float
    nu: float
    rho_kg_m3: float
    yield_pa: float | None = None

    def __post_init__(self) -> None:
        for field_name in ("E_pa", "rho_kg_m3"):
            value = getattr(self, field_name)
            if not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
                raise InputError(
                    f"material.{field_name}: must be a finite number > 0, got {value!r}"
                )
        if not isinstance(self.nu, int | float) or not 0 <= self.nu < 0.5:
            raise InputError(f"material.nu: Poisson ratio must lie in [0, 0.5), got {self.nu!r}")
        if self.yield_pa is not None and not (
            isinstance(self.yield_pa, int | float)
            and math.isfinite(self.yield_pa)
            and self.yield_pa > 0
        ):
            raise InputError(
                f"material.yield_pa: must be a finite number > 0, got {self.yield_pa!r}"
            )

    @property
    def lame_lambda_pa(self) -> float:
        """First Lame parameter in Pa."""
        return self.E_pa * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))

    @property
    def shear_modulus_pa(self) -> float:
        """Shear modulus (second Lame parameter) in Pa."""
        return self.E_pa / (2 * (1 + self.nu))

    def bending_stiffness_nm(self, thickness_m: float) -> float:
        """Kirchhoff plate bending stiffness D = E h^3 / (12 (1 - nu^2)) in N m."""
        return self.E_pa * thickness_m**3 / (12 * (1 - self.nu**2))

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


# Yield strengths: the lower bound of deep-drawing sheet grades, DC04 steel (EN 10130:
# 140-210 MPa) and EN AW-6016 T4 aluminium (EN 485-2: 80-140 MPa).
PRESETS: dict[str, Material] = {
    "steel": Material("steel", 210e9, 0.3, 7850.0, 140e6),
    "aluminium": Material("aluminium", 70e9, 0.33, 2700.0, 80e6),
}
_ALIASES = {"aluminum": "aluminium", "al": "aluminium", "st": "steel"}


def resolve_material(spec: str | Material | Mapping[str, Any]) -> Material:
    """A Material from a preset name ("steel", "aluminium"), a Material, or a mapping with
    ``E_pa``, ``nu``, ``rho_kg_m3`` (``E``/``rho`` accepted as short names) in SI units."""
    if isinstance(spec, Material):
        return spec
    if isinstance(spec, str):
        key = _ALIASES.get(spec.strip().lower(), spec.strip().lower())
        if key not in PRESETS:
            raise InputError(
                f"material: unknown preset {spec!r}; use one of {sorted(PRESETS)} or give "
                "E_pa, nu, rho_kg_m3"
            )
        return PRESETS[key]
    if isinstance(spec, Mapping):
        values = dict(spec)
        renamed = {"E": "E_pa", "rho": "rho_kg_m3"}
        values = {renamed.get(k, k): v for k, v in values.items()}
        missing = {"E_pa", "nu", "rho_kg_m3"} - set(values)
        unknown = set(values) - {"E_pa", "nu", "rho_kg_m3", "name", "yield_pa"}
        if missing or unknown:
            raise InputError(
                f"material: a mapping needs exactly E_pa (Pa), nu, rho_kg_m3 (kg/m^3) "
                f"[and optional name, yield_pa (Pa)]; missing {sorted(missing)}, unknown "
                f"{sorted(unknown)}"
            )
        try:
            numbers = {
                k: float(values[k]) for k in ("E_pa", "nu", "rho_kg_m3", "yield_pa") if k in values
            }
        except (TypeError, ValueError) as exc:
            raise InputError(f"material: E_pa, nu, rho_kg_m3 must be numbers ({exc})") from exc
        return Material(name=str(values.get("name", "custom")), **numbers)
    raise InputError(
        f"material: expected a preset name, a fem.Material or a mapping, got {type(spec).__name__}"
    )
