"""Model uncertainty for the robust mode: a range of frequency scales and damping ratios.

Frequencies from FE and the damping ratio are uncertain. The robust mode asks the profile to
work for every model in a range: all natural frequencies scaled by one factor s in
[s_min, s_max] (stiffness error at fixed mass; shapes and participation unchanged), and
every damping ratio set to zeta in [zeta_min, zeta_max] (or kept as in the model).
"The worst case" is the largest exact cycle time over a dense grid of that range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jaxflex.errors import InputError
from jaxflex.model import ModalModel
from jaxflex.response import grid_values
from optim.defaults import FREQ_SCALE, GRID, ZETA


@dataclass(frozen=True)
class RobustSpec:
    """Uncertainty range and its check grid.

    freq_scale: (min, max) factor on every natural frequency, 0 < min <= 1 <= max.
    zeta: (min, max) damping ratio for every mode, 0 < min <= max < 1, or None to keep
        the model's damping.
    n_freq, n_zeta: points of the check grid over each range (end points included).
    """

    freq_scale: tuple[float, float] = FREQ_SCALE
    zeta: tuple[float, float] | None = ZETA
    n_freq: int = GRID[0]
    n_zeta: int = GRID[1]

    def __post_init__(self) -> None:
        lo, hi = (float(v) for v in self.freq_scale)
        if not (0 < lo <= 1 <= hi and np.isfinite(hi)):
            raise InputError(
                f"freq_scale: expected (min, max) with 0 < min <= 1 <= max, got {self.freq_scale}"
            )
        object.__setattr__(self, "freq_scale", (lo, hi))
        if self.zeta is not None:
            zlo, zhi = (float(v) for v in self.zeta)
            if not 0 < zlo <= zhi < 1:
                raise InputError(
                    f"zeta: expected (min, max) with 0 < min <= max < 1, got {self.zeta} "
                    "(undamped modes never settle)"
                )
            object.__setattr__(self, "zeta", (zlo, zhi))
        for name in ("n_freq", "n_zeta"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise InputError(f"{name}: must be an integer >= 1, got {value!r}")
            object.__setattr__(self, name, int(value))

    @property
    def n_scenarios(self) -> int:
        """The number of models on the check grid (what :meth:`grid` lists, without
        building the list)."""
        n_scale = self.n_freq if self.freq_scale[1] > self.freq_scale[0] else 1
        n_zeta = 1 if self.zeta is None or self.zeta[1] <= self.zeta[0] else self.n_zeta
        return n_scale * n_zeta

    def grid(self) -> list[tuple[float, float | None]]:
        """(frequency scale, zeta or None) of every model on the check grid."""
        lo, hi = self.freq_scale
        scales = grid_values(lo, hi, self.n_freq) if hi > lo else [lo]
        if self.zeta is None:
            zetas: list[float | None] = [None]
        else:
            zlo, zhi = self.zeta
            zetas = list(grid_values(zlo, zhi, self.n_zeta)) if zhi > zlo else [zlo]
        return [(s, z) for z in zetas for s in scales]

    def as_dict(self) -> dict:
        return {
            "freq_scale": list(self.freq_scale),
            "zeta": None if self.zeta is None else list(self.zeta),
            "n_freq": self.n_freq,
            "n_zeta": self.n_zeta,
        }

    @classmethod
    def from_dict(cls, data: dict) -> RobustSpec:
        zeta = data.get("zeta")
        return cls(
            tuple(data["freq_scale"]),
            None if zeta is None else tuple(zeta),
            data.get("n_freq", 21),
            data.get("n_zeta", 3),
        )


def perturbed(
    model: ModalModel, scale: float, zeta: float | None, *, outputs: bool = False
) -> ModalModel:
    """``model`` with frequencies scaled by ``scale`` and damping ``zeta`` (if given); its
    cup and stress maps (scaled with it) only with ``outputs``: the response and the cycle
    time do not need them, and scaling large stress maps for every model of a grid costs
    more than the cycle times."""
    out = (model if outputs else model.without_outputs()).with_frequency_scale(scale)
    return out if zeta is None else out.with_damping(zeta)


def output_scales(
    model: ModalModel, scale: float, zeta: float | None
) -> tuple[np.ndarray, np.ndarray] | None:
    """(q_scale (M,), v_scale (M,)): the outputs of ``perturbed(model, scale, zeta,
    outputs=True)`` are ``model``'s with each mode's column of q_map multiplied by q_scale
    and of v_map by v_scale (their a_map and static response unchanged), so that a model of
    the grid can share the nominal maps (jaxflex._peaks' ``state_scale``): the stiffness
    share scales by scale^2, the damping share by scale and by the change of each mode's
    damping ratio (jaxflex.model.with_frequency_scale, with_damping). None where the damping
    is no column scale (a mode without damping gets a share of q_map)."""
    n_modes = model.n_modes
    v_scale = np.full(n_modes, float(scale))
    if zeta is not None:
        old = np.asarray(model.zeta, dtype=np.float64)
        if (old <= 0).any():
            return None
        v_scale = v_scale * (float(zeta) / old)
    return np.full(n_modes, float(scale) ** 2), v_scale
