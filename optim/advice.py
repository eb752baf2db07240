"""Advice on the robust check grid (jaxflex._advice has the threshold's): a range with width
checked at too few points. ``optim.optimize`` puts every advice on its result (report
``warnings``) and issues it as a jaxflex.errors.JaxflexWarning.
"""

from __future__ import annotations

from jaxflex.runtime import Advice
from optim.options import RobustSpec

# Fewest check-grid points over a range with width: the cycle time jumps with the frequency
# scale (a peak crosses the threshold), so its range needs its ends and its middle at least;
# it falls with the damping, so the damping range needs its ends.
MIN_GRID_POINTS = {"n_freq": 3, "n_zeta": 2}


def grid_advice(robust: RobustSpec | None) -> list[Advice]:
    """Advice on a robust check grid with too few points over a range that has width."""
    if robust is None:
        return []
    found = []
    lo, hi = robust.freq_scale
    ranges = [("n_freq", "frequency scale", lo, hi, robust.n_freq)]
    if robust.zeta is not None:
        ranges.append(("n_zeta", "damping ratio", *robust.zeta, robust.n_zeta))
    for name, what, low, high, count in ranges:
        if high > low and count < MIN_GRID_POINTS[name]:
            checked = f"{low:g} only" if count == 1 else f"{low:g} and {high:g} only"
            found.append(
                (
                    "sparse_robust_grid",
                    f"robust {name} = {count}: the {what} range {low:g}-{high:g} is checked at "
                    f"{checked}, so the worst case inside it is not; use at least "
                    f"{MIN_GRID_POINTS[name]} points (default 21 x 3)",
                )
            )
    return found
