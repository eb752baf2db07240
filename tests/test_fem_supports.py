"""A gripper type defined here, outside fem, works on the plate and the thin solid.

``RectangularPad`` is a clamped rectangular pad (half sides ``half_m``): it only talks to
fem through fem.Support and the PlateDofs / SolidDofs it is handed. Its held region lies
between the discs of radius half_m (inscribed) and sqrt(2) half_m (circumscribed), so by
the min-max principle (Courant-Fischer: holding more degrees of freedom of the same mesh
cannot lower any eigenvalue) every frequency of the pads lies between those of cups of the
two radii, provided the meshes are the same. The pad reports the cup's disc as its contact
disc, so the mesh is refined alike for the pad and the cup it is compared with.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import pytest

import fem
from fem.supports import Disc, PlateDofs, SolidDofs
from fem.system import Constraints
from jaxflex.errors import InputError

# the eigen solver converges each frequency to ~1e-8 relative from run to run (ARPACK
# start vector); the min-max inequalities are exact, so this is the only slack needed
EIGEN_RTOL = 1e-7
CENTRES = [(0.15, 0.1), (0.45, 0.1), (0.15, 0.3), (0.45, 0.3)]
HALF_M = 0.03


@dataclass(frozen=True)
class RectangularPad(fem.Support):
    """A clamped square pad centred at (x, y) m with half side ``half_m``; the mesh is
    refined around the disc of radius ``refine_radius_m`` (test device, see module)."""

    x: float
    y: float
    half_m: float
    refine_radius_m: float
    noun = "pad"

    def describe(self) -> dict:
        return {"type": "rectangular_pad", "x_m": self.x, "y_m": self.y, "half_m": self.half_m}

    @property
    def anchor_xy(self) -> tuple[float, float]:
        return self.x, self.y

    @property
    def contact_disc(self) -> Disc:
        return Disc(self.x, self.y, self.refine_radius_m)

    def _inside(self, xy: np.ndarray) -> np.ndarray:
        reach = self.half_m * (1 + 1e-9)  # as SuctionCup.hold_solid allows for rounding
        return (np.abs(xy[:, 0] - self.x) <= reach) & (np.abs(xy[:, 1] - self.y) <= reach)

    def hold_plate(self, plate: PlateDofs, index: int) -> Constraints:
        return plate.clamp_elements(self._inside(plate.centroids_xy))

    def hold_solid(self, solid: SolidDofs, index: int) -> Constraints:
        inside = np.flatnonzero(self._inside(solid.surface_points[:, :2]))
        if inside.size == 0:
            raise InputError(f"supports[{index}]: the pad holds no mesh node")
        return solid.clamp_nodes(inside)

    def draw(self, ax) -> None:
        h = self.half_m
        ax.fill(
            self.x + h * np.array([-1, 1, 1, -1]),
            self.y + h * np.array([-1, -1, 1, 1]),
            color="tab:green",
        )


def _frequencies(part, supports) -> np.ndarray:
    return fem.modal_analysis(part, supports, n_modes=6, progress=False).freq_hz


def _bounds(part):
    """Frequencies of cups of the inscribed radius, pads (meshed alike), pads meshed like
    the circumscribed cups, and those cups."""
    outer = math.sqrt(2) * HALF_M
    cups_in = [fem.SuctionCup(x, y, HALF_M) for x, y in CENTRES]
    pads_in = [RectangularPad(x, y, HALF_M, HALF_M) for x, y in CENTRES]
    pads_out = [RectangularPad(x, y, HALF_M, outer) for x, y in CENTRES]
    cups_out = [fem.SuctionCup(x, y, outer) for x, y in CENTRES]
    return [_frequencies(part, s) for s in (cups_in, pads_in, pads_out, cups_out)]


@pytest.mark.parametrize(
    ("element", "size_m", "cup_fine_fraction"),
    [("morley", 0.02, None), ("argyris", 0.05, 0.5), ("hex2", 0.05, 0.5)],
)
def test_a_pad_defined_outside_fem_lies_between_its_inscribed_and_circumscribed_cups(
    element, size_m, cup_fine_fraction
):
    # coarse cup refinement for Argyris and the solid: fine enough that the pad's corners hold
    # elements (or nodes) the cups do not, and a few seconds per case
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, element=element, mesh_size=size_m)
    part = dataclasses.replace(part, cup_fine_fraction=cup_fine_fraction)
    cups_in, pads_in, pads_out, cups_out = _bounds(part)
    assert np.all(cups_in <= pads_in * (1 + EIGEN_RTOL))
    assert np.all(pads_out <= cups_out * (1 + EIGEN_RTOL))
    # the pad holds strictly more than the inscribed cup and less than the circumscribed one
    assert pads_in[0] > cups_in[0] * (1 + 1e-4)
    assert pads_out[0] < cups_out[0] * (1 - 1e-4)


def test_the_pad_is_described_checked_and_drawn_like_any_support(tmp_path):
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, mesh_size=0.04)
    pads = [RectangularPad(x, y, HALF_M, HALF_M) for x, y in CENTRES]
    result = fem.modal_analysis(part, pads, n_modes=4, progress=False)
    meta = result.to_modal_model(points=20).meta
    assert meta["gripper"][0] == {
        "type": "rectangular_pad",
        "x_m": 0.15,
        "y_m": 0.1,
        "half_m": 0.03,
    }
    fem.plot_part(result, tmp_path / "pads.png", n_modes=2)
    assert (tmp_path / "pads.png").stat().st_size > 0
    with pytest.raises(InputError, match=r"supports\[0\]: pad centre .* off the part"):
        fem.modal_analysis(part, [RectangularPad(0.7, 0.1, HALF_M, HALF_M), *pads[1:]])
    with pytest.raises(InputError, match=r"pad at .* and pad at .* overlap"):
        fem.modal_analysis(part, [*pads, RectangularPad(0.16, 0.11, HALF_M, HALF_M)])
    with pytest.raises(InputError, match="at least 3 non-collinear"):
        fem.modal_analysis(part, pads[:2])
