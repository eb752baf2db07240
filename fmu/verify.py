"""Built-in verification: validate an FMU with fmpy, simulate it, compare with jaxflex.

Three ways to drive the FMU, each with the reference that describes it exactly:

- "embedded": ``use_embedded_trajectory = true``; the FMU replays its own trajectory (linear
  between samples). Reference: the exact recursion (jaxflex._engine) of the same samples.
- "linear" (FMI 2.0): inputs set with their time derivatives (fmi2SetRealInputDerivatives),
  so the acceleration is linear over each step; driven by :class:`fmu.master.Session` (fmpy's
  FMU2Slave). Reference: the same.
- "held": inputs only (FMI 3.0, or FMI 2.0 on request), constant over each step. Reference:
  the exact zero-order-hold recursion (jaxflex._engine, ``hold="zero"``).
"""

from __future__ import annotations

import math
import os
import zipfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

from fmu.master import Session, run_linear
from fmu.resource import decode_resource
from fmu.variables import INPUT_COLUMNS, RESOURCE_FILE
from jaxflex.errors import InputError, ModelFileError
from jaxflex.model import ModalModel
from jaxflex.response import (
    Move,
    as_move,
    modal_states,
    point_displacements,
    response_shapes,
    rest_padded,
    with_acceleration,
)

DEFAULT_RTOL = 1e-9
MODES = ("embedded", "linear", "held")


@dataclass
class VerifyReport:
    """Result of :func:`verify`. Differences are max over all communication points (and for
    FMI 3.0 over all displaced coordinates); relative ones are divided by the reference's
    largest absolute value."""

    path: str
    fmi_version: int
    mode: str
    reference: str
    validation: list[str]
    n_steps: int
    dt_s: float
    stop_time_s: float
    max_abs_diff_m: float
    max_rel_diff: float
    max_abs_diff_points_m: float | None
    max_rel_diff_points: float | None
    settle_time_fmu_s: float
    settle_time_reference_s: float
    rtol: float = DEFAULT_RTOL
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Validation clean, outputs within ``rtol`` and the same settle time."""
        rel = [self.max_rel_diff, self.max_rel_diff_points or 0.0]
        return (
            not self.validation
            and max(rel) <= self.rtol
            and math.isclose(
                self.settle_time_fmu_s, self.settle_time_reference_s, abs_tol=1e-9 * self.dt_s
            )
        )

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "ok": self.ok}

    def summary(self) -> str:
        lines = [
            f"{self.path}: FMI {self.fmi_version}.0, {self.mode} input, {self.n_steps} steps of "
            f"{self.dt_s:g} s to {self.stop_time_s:g} s",
            "fmpy validation: " + ("clean" if not self.validation else "; ".join(self.validation)),
            f"deviation vs {self.reference}: max abs {self.max_abs_diff_m:.3e} m, "
            f"relative {self.max_rel_diff:.3e}",
        ]
        if self.max_abs_diff_points_m is not None:
            lines.append(
                f"displaced points: max abs {self.max_abs_diff_points_m:.3e} m, relative "
                f"{self.max_rel_diff_points:.3e}"
            )
        lines.append(
            f"settle time at communication points: FMU {self.settle_time_fmu_s:.6g} s, "
            f"reference {self.settle_time_reference_s:.6g} s"
        )
        lines += self.notes
        lines.append("OK" if self.ok else f"FAILED (tolerance {self.rtol:g} relative)")
        return "\n".join(lines)


def input_signal(move: Move) -> np.ndarray:
    """Input for ``fmpy.simulate_fmu``: a structured array with fields time, ax, ay, az (the
    columns of the ``<name>_input.csv`` written beside an exported FMU) of ``move``'s samples."""
    signal = np.zeros(move.acc.shape[0], dtype=[(name, np.float64) for name in INPUT_COLUMNS])
    signal["time"] = move.dt_s * np.arange(move.acc.shape[0])
    for i, name in enumerate(INPUT_COLUMNS[1:]):
        signal[name] = move.acc[:, i]
    return signal


def reference_response(
    model: ModalModel, move: Move, n_steps: int, *, hold: str = "linear", points=False
):
    """Exact response at the communication points t_k = k dt_s, k = 0..n_steps, to the samples
    of ``move`` (linear between them, or each held over its step with ``hold="zero"``) and
    rest after them: (deviation (n_steps + 1,) m, displacement (n_steps + 1, K, 3) m or
    None). The static residual's share D a uses the acceleration at the end of each step, as
    the FMU reports it (with held inputs: the value held over the step just done)."""
    acc = rest_padded(move.acc[: n_steps + 1], n_steps)
    q = modal_states(model, acc, move.dt_s, hold=hold, xp=np)[..., 0]
    a_end = acc if hold == "linear" else np.vstack([np.zeros((1, 3)), acc[:-1]])
    disp = point_displacements(response_shapes(model), with_acceleration(model, q, a_end))
    return np.linalg.norm(disp, axis=2).max(axis=1), (disp if points else None)


def simulated_model(stored, fmu_path: str | os.PathLike, bound: dict | None = None) -> ModalModel:
    """The model an exported FMU simulates: the stored one with its damping ratios times the
    ``damping_scale`` parameter (the FMU's start value, or the value ``bound`` to it)."""
    variables = read_model_description(str(fmu_path)).modelVariables
    scale = float(next(v.start for v in variables if v.name == "damping_scale"))
    scale = float((bound or {}).get("damping_scale", scale))
    return stored.model.with_damping(np.asarray(stored.model.zeta) * scale)


def settle_time_at_points(t: np.ndarray, deviation: np.ndarray, threshold_m: float) -> float:
    """Time at which ``deviation <= threshold`` last became true (t[0] if always true)."""
    settled = deviation <= threshold_m
    rises = np.flatnonzero(settled[1:] & ~settled[:-1]) + 1
    return float(t[rises[-1]]) if rises.size else float(t[0])


def relative_difference(diff: float, scale: float) -> float:
    """``diff`` relative to ``scale`` (``diff`` itself for a zero scale)."""
    return diff / scale if scale > 0 else diff


def read_fmu_resource(path: str | os.PathLike):
    """The model and embedded trajectory stored in an exported FMU."""
    try:
        with zipfile.ZipFile(path) as zf:
            data = zf.read(f"resources/{RESOURCE_FILE}")
    except (zipfile.BadZipFile, KeyError, OSError) as exc:
        raise ModelFileError(f"{str(path)!r} is not a jaxflex FMU ({exc})") from exc
    return decode_resource(data, source=f"{path}:resources/{RESOURCE_FILE}")


def _choose_mode(fmi_version: int, given: bool, mode: str) -> str:
    if mode not in ("auto", *MODES):
        raise InputError(f"input_mode: must be one of auto, {', '.join(MODES)}; got {mode!r}")
    if mode == "auto":
        return "embedded" if not given else ("linear" if fmi_version == 2 else "held")
    if mode == "linear" and fmi_version != 2:
        raise InputError("input_mode 'linear' needs FMI 2.0 (FMI 3.0 has no input derivatives)")
    if (mode == "embedded") == given:
        raise InputError(
            "input_mode 'embedded' replays the FMU's own trajectory: do not pass a move"
            if given
            else f"input_mode {mode!r} needs a move (jaxflex.as_move(acc, dt_s))"
        )
    return mode


def verify(
    path: str | os.PathLike,
    move: Move | None = None,
    *,
    input_mode: str = "auto",
    extend_s: float | None = None,
    rtol: float = DEFAULT_RTOL,
) -> VerifyReport:
    """Validate the FMU at ``path`` with fmpy, simulate it with ``fmpy.simulate_fmu`` (output
    interval = the sample step; the "linear" mode uses fmpy's FMU2Slave through
    :class:`fmu.master.Session`) and compare with jaxflex.

    Without ``move`` the FMU replays its embedded trajectory; otherwise ``move`` (a
    jaxflex.Move: samples (n+1, 3) m/s^2 and their step, s) drives the inputs ("linear" for
    FMI 2.0, "held" for FMI 3.0 by default, see the module docstring). The run lasts until
    the FMU's default stop time or ``extend_s`` s after the last sample.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"FMU {str(path)!r} does not exist")
    stored = read_fmu_resource(path)
    md = read_model_description(str(path))
    fmi_version = int(md.fmiVersion[0])
    mode = _choose_mode(fmi_version, move is not None, input_mode)
    if mode == "embedded":
        if stored.acc is None:
            raise InputError(f"{str(path)!r} has no embedded trajectory: pass a move")
        move = stored.move
    else:
        move = as_move(move, name="move")
    dt_s = move.dt_s
    duration = move.n_steps * dt_s
    if extend_s is not None:
        stop = duration + float(extend_s)
    else:
        stop = max(float(md.defaultExperiment.stopTime or 0.0), duration)
    n_steps = round(stop / dt_s)
    stop = n_steps * dt_s
    points = fmi_version == 3
    if mode == "linear":
        with Session(path, instance_name="jaxflex_verify") as session:
            session.start(0.0)
            result = run_linear(session, move, n_steps)
    else:
        outputs = ["deviation", "settle_time", "settled"] + (["displaced_points"] * points)
        if mode == "embedded":
            drive: dict[str, Any] = {"start_values": {"use_embedded_trajectory": True}}
        else:
            drive = {"input": input_signal(move)}
        result = replay(path, stop, dt_s, outputs, **drive)
    if len(result["time"]) != n_steps + 1:
        raise InputError(
            f"the simulation returned {len(result['time'])} samples, expected {n_steps + 1}: "
            f"dt_s = {dt_s} s must divide the simulated time"
        )
    hold = "zero" if mode == "held" else "linear"
    ref_dev, ref_disp = reference_response(
        simulated_model(stored, path), move, n_steps, hold=hold, points=points
    )
    reference = f"jaxflex's engine ({'zero-order hold' if mode == 'held' else 'first-order hold'})"
    diff_p = rel_p = None
    if points:
        disp = np.asarray(result["displaced_points"]) - np.asarray(stored.model.points)[None]
        diff_p = float(np.max(np.abs(disp - ref_disp)))
        rel_p = relative_difference(diff_p, float(np.max(np.abs(ref_disp))))
    t = np.asarray(result["time"])
    notes = []
    if mode == "held":
        notes.append(
            "inputs are held over each step; jaxflex (linear between samples) differs by "
            "about half a step of delay"
        )
    return replay_report(
        path, mode, reference, dt_s, result, ref_dev, t, points=(diff_p, rel_p), rtol=rtol,
        notes=notes,
    )  # fmt: skip


def replay(path: Path, stop_s: float, dt_s: float, outputs: list[str], **drive):
    """fmpy's simulation of the FMU at ``path`` from 0 to ``stop_s`` s with the output
    interval ``dt_s`` s, recording ``outputs``; ``drive``: its ``input`` or ``start_values``."""
    return simulate_fmu(
        str(path),
        validate=False,
        start_time=0.0,
        stop_time=stop_s,
        output_interval=dt_s,
        output=outputs,
        **drive,
    )


def replay_report(
    path: Path,
    mode: str,
    reference: str,
    dt_s: float,
    result,
    ref_dev: np.ndarray,
    t_s: np.ndarray,
    *,
    points: tuple[float | None, float | None] = (None, None),
    rtol: float = DEFAULT_RTOL,
    notes: list[str],
) -> VerifyReport:
    """The report of a replay of the FMU at ``path`` (its model description: the FMI
    version and the threshold's start value, m) in ``mode`` at step ``dt_s`` s: fmpy's
    validation, the FMU's ``result`` (its deviation, m, and settle time, s, at the times
    ``t_s`` (n+1,) s) against the ``reference``'s deviation ``ref_dev`` (n+1,) m, and
    ``points`` (the largest absolute (m) and relative difference of the displaced points, or
    None without them)."""
    diff = float(np.max(np.abs(np.asarray(result["deviation"]) - ref_dev)))
    md = read_model_description(str(path))
    threshold_m = next(float(v.start) for v in md.modelVariables if v.name == "threshold")
    n_steps = len(ref_dev) - 1
    return VerifyReport(
        path=str(path),
        fmi_version=int(md.fmiVersion[0]),
        mode=mode,
        reference=reference,
        validation=list(validate_fmu(str(path))),
        n_steps=n_steps,
        dt_s=dt_s,
        stop_time_s=n_steps * dt_s,
        max_abs_diff_m=diff,
        max_rel_diff=relative_difference(diff, float(np.max(np.abs(ref_dev)))),
        max_abs_diff_points_m=points[0],
        max_rel_diff_points=points[1],
        settle_time_fmu_s=float(result["settle_time"][-1]),
        settle_time_reference_s=settle_time_at_points(t_s, ref_dev, threshold_m),
        rtol=rtol,
        notes=notes,
    )
