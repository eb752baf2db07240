"""Unit sanity of a part: warnings (not errors) for values that look like a unit slip.

A sheet-metal part is thin (thickness / span between 1/5000 and 1/20), weighs between 10 g
and a tonne, and is at most a few metres long; values outside those ranges are usually a
thickness given in millimetres (``--thickness 1``) or coordinates read as metres that were
millimetres. The part is still built: the warning says what was read and what to check.
"""

from __future__ import annotations

import sys
import warnings
from contextlib import contextmanager

THICKNESS_PER_SPAN = (1 / 5000, 1 / 20)
MASS_KG = (0.01, 1000.0)
LARGEST_LIKELY_M = 5.0  # a sheet part longer than this is probably in millimetres


class PartWarning(UserWarning):
    """A part's thickness, mass or size looks like a unit slip."""


class ModelWarning(PartWarning):
    """A model read from another program's files looks wrong in a way that is not
    impossible (fem.imports.checks); printed as PartWarnings are."""


def unit_warnings(part, hint: str | None = None) -> list[str]:
    """The warnings for ``part`` (a fem.parts.Part), each naming the value and its unit;
    ``hint`` replaces the advice on the units (a mesh's: metres and --scale)."""
    out = []
    ratio = part.thickness_m / part.span_m
    lo, hi = THICKNESS_PER_SPAN
    if not lo <= ratio <= hi:
        out.append(
            f"thickness {part.thickness_m:g} m is 1/{1 / ratio:.4g} of the part's span "
            f"{part.span_m:.4g} m (sheet metal: 1/{1 / hi:g} ... 1/{1 / lo:g}); "
            + (hint or "thickness is read in metres (1 mm = 1e-3)")
        )
    mass = part.mass_kg
    if not MASS_KG[0] <= mass <= MASS_KG[1]:
        out.append(
            f"the part weighs {mass:.4g} kg (expected {MASS_KG[0]:g} ... {MASS_KG[1]:g} kg); "
            + (
                hint
                or "check the thickness (m), the coordinates' unit (m; scale=1e-3 / --scale "
                "1e-3 for millimetres) and the material"
            )
        )
    lo_m, hi_m = part.bounds_m()
    extent = float(max(hi_m - lo_m))
    if extent > LARGEST_LIKELY_M:
        out.append(
            f"the part spans {extent:.4g} m; "
            + (hint or "coordinates are read in metres: for a mesh in millimetres pass "
               "scale=1e-3 (--scale 1e-3)")
        )  # fmt: skip
    return out


def warn_units(part) -> None:
    """Issue every :func:`unit_warnings` of ``part`` as a PartWarning."""
    for message in unit_warnings(part):
        warnings.warn(f"{part.name}: {message}", PartWarning, stacklevel=3)


@contextmanager
def printed_part_warnings():
    """Run the block and print each PartWarning it issued as ``warning: ...`` on stderr
    (other warnings as Python shows them)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PartWarning)
        yield
    for warning in caught:
        if issubclass(warning.category, PartWarning):
            print(f"warning: {warning.message}", file=sys.stderr)
        else:
            warnings.showwarning(
                warning.message, warning.category, warning.filename, warning.lineno
            )
