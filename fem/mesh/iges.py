"""The length unit an IGES file states, read from its global section (IGES 5.3, section 2.2.4).

The global section (lines marked ``G`` in column 73, columns 1-72 joined) is a list of
parameters separated by the parameter delimiter (parameter 1, default ``,``) and ended by
the record delimiter (parameter 2, default ``;``); strings are Hollerith constants ``nH...``
(which may contain either delimiter). Parameter 13 is the model space scale (model space /
real world), 14 the units flag, 15 the units name (used when the flag is 3), 20 the largest
coordinate value in the file.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

from jaxflex.errors import InputError

# units flag -> (name, metres per unit); flag 3: the name of parameter 15 decides
UNIT_FLAGS = {
    1: ("IN", 0.0254),
    2: ("MM", 1e-3),
    4: ("FT", 0.3048),
    5: ("MI", 1609.344),
    6: ("M", 1.0),
    7: ("KM", 1e3),
    8: ("MIL", 2.54e-5),
    9: ("UM", 1e-6),
    10: ("CM", 1e-2),
    11: ("UIN", 2.54e-8),
}
UNIT_NAMES = dict(UNIT_FLAGS.values()) | {"INCH": 0.0254}
_HOLLERITH = re.compile(r"\s*(\d+)H")


@dataclass(frozen=True)
class IgesUnits:
    """What an IGES file says about its coordinates: ``unit`` name, ``metres_per_unit``,
    ``flag`` (parameter 14), ``model_scale`` (parameter 13: model space / real world),
    ``max_coordinate`` (parameter 20, file units; 0 if not stated) and ``resolution``
    (parameter 19, the smallest distance the file resolves, file units)."""

    unit: str
    metres_per_unit: float
    flag: int
    model_scale: float
    max_coordinate: float = 0.0
    resolution: float = 0.0

    def describe(self) -> str:
        scale = "" if self.model_scale == 1 else f", model space scale {self.model_scale:g}"
        return f"IGES unit {self.unit} (units flag {self.flag}){scale}"


def _delimiter(text: str, pos: int, default: str) -> tuple[str, int]:
    """Parameter 1 or 2 at ``pos``: a one-character Hollerith string, or empty (default)."""
    match = re.compile(r"\s*1H(.)").match(text, pos)
    return (match.group(1), match.end()) if match else (default, pos)


def global_parameters(text: str) -> list[str]:
    """The parameters of a global section ``text`` (columns 1-72 of its lines, joined)."""
    field_end, pos = _delimiter(text, 0, ",")
    record_end, pos = _delimiter(text, text.index(field_end, pos) + 1, ";")
    pos = text.index(field_end, pos) + 1
    fields = [field_end, record_end]
    while pos < len(text):
        match = _HOLLERITH.match(text, pos)
        if match:
            start = match.end()
            value = text[start : start + int(match.group(1))]
            pos = start + len(value)
        else:
            ends = [i for i in (text.find(field_end, pos), text.find(record_end, pos)) if i >= 0]
            stop = min(ends, default=len(text))
            value, pos = text[pos:stop].strip(), stop
        fields.append(value)
        if pos >= len(text) or text[pos] == record_end:
            break
        pos += 1
    return fields


def iges_units(path: str | os.PathLike) -> IgesUnits:
    """The unit of an IGES file's coordinates, from its global section."""
    try:
        with open(path, encoding="latin-1") as handle:
            text = "".join(line[:72] for line in handle if line[72:73] == "G")
    except OSError as exc:
        raise InputError(f"cad: cannot read {str(path)!r} ({exc})") from exc
    params = global_parameters(text)
    if len(params) < 15:
        raise InputError(
            f"cad: {str(path)!r} has no IGES global section with a units flag (parameter 14)"
        )

    def real(index: int, default: float) -> float:
        value = params[index] if index < len(params) else ""
        return float(value.upper().replace("D", "E")) if value else default

    try:
        flag = int(params[13] or 1)  # IGES default: inches
        model_scale = real(12, 1.0)
        extent = (real(19, 0.0), real(18, 0.0))
    except ValueError as exc:
        raise InputError(
            f"cad: {str(path)!r}: IGES global section: units flag, model space scale, "
            f"resolution or largest coordinate is not a number ({exc})"
        ) from exc
    if model_scale <= 0:
        raise InputError(f"cad: {str(path)!r}: IGES model space scale {model_scale:g} <= 0")
    name = params[14].strip().upper()
    if flag == 3:
        if name not in UNIT_NAMES:
            raise InputError(
                f"cad: {str(path)!r} states the unit {name!r} (IGES units flag 3); known: "
                f"{sorted(UNIT_NAMES)}"
            )
        return IgesUnits(name, UNIT_NAMES[name], flag, model_scale, *extent)
    if flag not in UNIT_FLAGS:
        raise InputError(
            f"cad: {str(path)!r}: IGES units flag {flag} is none of {sorted(UNIT_FLAGS)} or 3"
        )
    return IgesUnits(*UNIT_FLAGS[flag], flag, model_scale, *extent)
