"""Verification of a turning part's FMU with its embedded move of poses: validated with fmpy,
replayed by ``fmpy.simulate_fmu`` (``use_embedded_trajectory = true``, the output interval
the sample step) and compared with jaxflex.simulate_turning of the same model and move (the
forcing linear between the samples in both: equal to rounding)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

from fmu.verify import DEFAULT_RTOL, VerifyReport, relative_difference, settle_time_at_points
from jaxflex.model import ModalModel
from jaxflex.response import PosePath, simulate_turning


def verify_turning(
    path: str | os.PathLike,
    model: ModalModel,
    pose: PosePath,
    acc,
    *,
    pivot_m,
    gravity_m_s2,
    extend_s: float = 0.0,
    rtol: float = DEFAULT_RTOL,
) -> VerifyReport:
    """Replay the FMU at ``path`` (exported from ``model`` with the move ``pose``, ``acc``
    ((n+1, 3) m/s^2, the pivot's world acceleration) about ``pivot_m`` under ``gravity_m_s2``)
    for the move and ``extend_s`` s after it (whole steps) and compare its deviation, at
    every sample, with jaxflex.simulate_turning's."""
    path = Path(path)
    md = read_model_description(str(path))
    dt_s = pose.dt_s
    reference = simulate_turning(
        model, pose, acc, gravity_m_s2=gravity_m_s2, pivot_m=pivot_m, extend_s=extend_s
    )
    n_steps = len(reference.t_s) - 1
    stop = n_steps * dt_s
    result = simulate_fmu(
        str(path),
        validate=False,
        start_time=0.0,
        stop_time=stop,
        output_interval=dt_s,
        output=["deviation", "settle_time"],
        start_values={"use_embedded_trajectory": True},
    )
    dev, ref = np.asarray(result["deviation"]), reference.deviation_m
    if dev.shape != ref.shape:
        raise ValueError(f"the FMU returned {dev.size} samples, jaxflex {ref.size}")
    diff = float(np.max(np.abs(dev - ref)))
    threshold_m = next(float(v.start) for v in md.modelVariables if v.name == "threshold")
    return VerifyReport(
        path=str(path),
        fmi_version=int(md.fmiVersion[0]),
        mode="embedded",
        reference="jaxflex.simulate_turning (first-order hold of the forcing)",
        validation=list(validate_fmu(str(path))),
        n_steps=n_steps,
        dt_s=dt_s,
        stop_time_s=stop,
        max_abs_diff_m=diff,
        max_rel_diff=relative_difference(diff, float(np.max(np.abs(ref)))),
        max_abs_diff_points_m=None,
        max_rel_diff_points=None,
        settle_time_fmu_s=float(result["settle_time"][-1]),
        settle_time_reference_s=settle_time_at_points(reference.t_s, ref, threshold_m),
        rtol=rtol,
        notes=["a turning part: the deviation about the sag of the current pose"],
    )
