"""Independent references, for the benchmarks and checks above the core: closed forms
(analytic: a simply supported plate, a cylindrical panel) and other ways to compute the same
response (convolution with a unit response, the Newmark and central-difference integrators),
each by a different method than the core's exact modal recursion. Public: these names are
kept stable; the modules they come from are private.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # imported on first use (jaxflex.lazy): each name loads only its module
    from jaxflex._analytic import cylindrical_panel_frequencies_hz, simply_supported_plate
    from jaxflex._convolution import (
        convolve_unit_response,
        deviation_from_displacement,
        unit_response,
    )
    from jaxflex._integrators import central_difference_modal, newmark_modal

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "central_difference_modal",
    "convolve_unit_response",
    "cylindrical_panel_frequencies_hz",
    "deviation_from_displacement",
    "newmark_modal",
    "simply_supported_plate",
    "unit_response",
]
