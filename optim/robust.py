"""Model uncertainty for the robust mode: a range of frequency scales and damping ratios.

Frequencies from FE and the damping ratio are uncertain. The robust mode asks the profile to
work for every model in a range: all natural frequencies scaled by one factor s in
[s_min, s_max] (stiffness error at fixed mass; shapes and participation unchanged), and
every damping ratio set to zeta in [zeta_min, zeta_max] (or kept as in the model).
"The worst case" is the largest exact cycle time over a dense grid of that range
(optim.options.RobustSpec); the models of that grid, and how their outputs scale.
"""

from __future__ import annotations

import numpy as np

from jaxflex.model import ModalModel


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
