"""Verification of a turning part's FMU with its embedded move of poses: validated with fmpy,
replayed by ``fmpy.simulate_fmu`` (``use_embedded_trajectory = true``, the output interval
the sample step) and compared with jaxflex.simulate_turning of the same model and move (the
forcing linear between the samples in both: equal to rounding)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fmu.verify import DEFAULT_RTOL, VerifyReport, replay, replay_report
from jaxflex.model import ModalModel
from jaxflex.response import Turn, simulate_turning


def after_move_s(case: dict) -> float:
    """The time after the embedded move (s) that its FMU's stop time covers (a quarter more
    than the move or its cycle, whichever is longer): how long to replay past the move.
    ``case``: the exported case (ExportResult.case: ``duration_s``, ``cycle_time_s``)."""
    duration = case["duration_s"]
    return 1.25 * max(duration, case["cycle_time_s"]) - duration


def verify_turning(
    path: str | os.PathLike,
    model: ModalModel,
    turn: Turn,
    *,
    extend_s: float = 0.0,
    rtol: float = DEFAULT_RTOL,
) -> VerifyReport:
    """Replay the FMU at ``path`` (exported from ``model`` with the turning move ``turn``, a
    jaxflex.response.Turn: its pose path, the pivot's world acceleration, the pivot and
    gravity) for the move and ``extend_s`` s after it (whole steps) and compare its
    deviation, at every sample, with jaxflex.simulate_turning's."""
    path = Path(path)
    dt_s = turn.dt_s
    reference = simulate_turning(model, turn, extend_s=extend_s)
    n_steps = len(reference.t_s) - 1
    stop = n_steps * dt_s
    result = replay(
        path,
        stop,
        dt_s,
        ["deviation", "settle_time"],
        start_values={"use_embedded_trajectory": True},
    )
    ref = reference.deviation_m
    dev = np.asarray(result["deviation"])
    if dev.shape != ref.shape:
        raise ValueError(f"the FMU returned {dev.size} samples, jaxflex {ref.size}")
    return replay_report(
        path,
        "embedded",
        "jaxflex.simulate_turning (first-order hold of the forcing)",
        dt_s,
        result,
        ref,
        reference.t_s,
        rtol=rtol,
        notes=["a turning part: the deviation about the sag of the current pose"],
    )
