"""The reduced-model methods the bench compares, each at its own native step.

Every method turns a modal model, acceleration samples ``acc`` ((n+1, 3), m/s^2, linear
between samples) and the sample step ``dt_s`` into the deviation d(t_k) = max_p |u_p(t_k)|
(m) at the samples. :func:`prepare` returns a zero-argument callable that does exactly the
timed work; what a method may do once per model (move data to the device, build R1) is done
before, as it would be offline.

* ``scan64`` / ``scan32``: jaxflex's exact first-order-hold recursion (float64 / float32);
* ``convolution``: the preprint's direct convolution with the unit-response matrix R1
  (numpy, O(n^2 K)); R1 itself is offline data and not timed;
* ``newmark``: average-acceleration Newmark on the modal equations with ``substeps`` steps per
  sample (the input upsampled exactly), output at the samples;
* ``central_difference``: explicit central difference, likewise; stable only for
  omega_max h < 2, see :func:`stable_substeps`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from jaxflex.errors import InputError
from jaxflex.model import ModalModel
from jaxflex.reference import (
    central_difference_modal,
    convolve_unit_response,
    deviation_from_displacement,
    newmark_modal,
    unit_response,
)
from jaxflex.response import (
    Move,
    deviation,
    move_deviation,
    on_device,
    upsample,
    with_acceleration,
)

METHODS = ("scan64", "scan32", "convolution", "newmark", "central_difference")
LABELS = {
    "scan64": "exact modal scan (float64)",
    "scan32": "exact modal scan (float32)",
    "convolution": "direct convolution of R1 (preprint)",
    "newmark": "Newmark on the modal equations",
    "central_difference": "central difference on the modal equations",
    "fe_newmark": "full-order FE transient (Newmark)",
}
CD_STABILITY_MARGIN = 0.9  # central difference runs at omega_max h <= 0.9 * 2


@jax.jit
def _scan_deviation(model, blocks, acc, dt_s):
    return move_deviation(model, blocks, acc, dt_s)


@partial(jax.jit, static_argnames=("integrator", "every"))
def _integrator_deviation(model, blocks, acc_fine, h, integrator: str, every: int):
    step = newmark_modal if integrator == "newmark" else central_difference_modal
    q = step(model, acc_fine, h)[::every]
    return deviation(blocks, with_acceleration(model, q, acc_fine[::every], jnp))


def stable_substeps(model: ModalModel, dt_s: float, margin: float = CD_STABILITY_MARGIN) -> int:
    """Fewest central-difference steps per sample interval with omega_max h <= 2 margin."""
    omega_max = float(np.max(model.omega_rad_s))
    return max(1, math.ceil(omega_max * dt_s / (2.0 * margin)))


def prepare(method: str, model: ModalModel, move: Move, substeps: int = 1) -> Callable[[], object]:
    """Zero-argument callable computing the deviation (n+1,) of ``method`` (see module doc)
    under ``move``; ``substeps`` only applies to the time integrators."""
    acc, dt_s = move.acc, move.dt_s
    if method in ("scan64", "scan32"):
        dtype = "float64" if method == "scan64" else "float32"
        dev_model, blocks = on_device(model, dtype)
        acc_j = jnp.asarray(acc, dev_model.freq_hz.dtype)
        dt_j = jnp.asarray(dt_s, dev_model.freq_hz.dtype)
        return lambda: _scan_deviation(dev_model, blocks, acc_j, dt_j)
    if method == "convolution":
        axes = tuple(int(a) for a in np.flatnonzero(np.any(acc != 0, axis=0))) or (2,)
        r1 = unit_response(model, dt_s, acc.shape[0] - 1)[list(axes)]
        return lambda: deviation_from_displacement(convolve_unit_response(r1, acc, axes=axes))
    if method in ("newmark", "central_difference"):
        if int(substeps) < 1:
            raise InputError(f"substeps: must be an integer >= 1, got {substeps}")
        dev_model, blocks = on_device(model)
        fine = jnp.asarray(upsample(acc, int(substeps)))
        h = jnp.asarray(dt_s / int(substeps))
        return lambda: _integrator_deviation(
            dev_model, blocks, fine, h, integrator=method, every=int(substeps)
        )
    raise InputError(f"method: must be one of {list(METHODS)}, got {method!r}")
