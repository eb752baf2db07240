"""``export_fmu``: a ModalModel (and optionally the optimised trajectory) as an FMU.

The FMU holds modelDescription.xml, the C sources (sources/, with buildDescription.xml for
FMI 3.0), the binaries compiled here (binaries/linux64 for FMI 2.0, binaries/x86_64-linux for
FMI 3.0, plus the Windows DLL when mingw-w64 is installed) and resources/jaxflex_model.bin.
With a trajectory, the case is also written beside the FMU: ``<name>_input.csv`` (columns
time, ax, ay, az in s and m/s^2: fmpy's ``simulate_fmu`` input format) and ``<name>_case.json``.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fmu.archive import content_token, zip_folder
from fmu.build import BuildReport, WrittenFmu, build_binaries, sources_for
from fmu.model_description import Description, build_description, model_description
from fmu.obstacles import obstacle_records
from fmu.options import CellOutputs, Fmi, Turning
from fmu.resource import (
    CellData,
    Counts,
    TurningData,
    encode_resource,
    pose_samples,
    resource_counts,
)
from fmu.toolchain import C_DIR as _C_DIR
from fmu.variables import (
    INPUT_COLUMNS,
    POSE_INPUT_NAMES,
    RESOURCE_FILE,
    config_header,
    pose_unit,
)
from jaxflex.defaults import DT_S, THRESHOLD_M
from jaxflex.errors import InputError
from jaxflex.files import check_output_file, check_positive, whole_or_absent, write_text_atomic
from jaxflex.geometry import Cell, part_half_thickness
from jaxflex.model import ModalModel, require_model
from jaxflex.response import (
    Move,
    PosePath,
    Turn,
    analyze_move,
    as_move,
    require_rotation,
    turning_settle,
)

CASE_FORMAT = "jaxflex.fmu_case"
DEFAULT_FMI = Fmi()  # FMI 2.0, the Windows DLL when mingw-w64 is installed
NO_CELL = CellOutputs()  # no cell: the cups' and (with stress) the stresses' outputs only
_CASE_TIMES = ("cycle_time_s", "transfer_time_s", "settle_time_s")


@dataclass(frozen=True, kw_only=True)
class ExportResult(WrittenFmu):
    """What :func:`export_fmu` wrote: the FMU (WrittenFmu), its counts and resource size,
    and with a trajectory the files beside it and the case."""

    counts: Counts
    resource_bytes: int
    input_csv: Path | None = None
    case_json: Path | None = None
    case: dict[str, Any] | None = None


def model_identifier(path: Path) -> str:
    """A C identifier from the FMU file name (``part-A.fmu`` -> ``part_A``)."""
    ident = re.sub(r"\W", "_", path.stem, flags=re.ASCII) or "jaxflex_part"
    return f"_{ident}" if ident[0].isdigit() else ident


def sidecar_paths(fmu_path: str | os.PathLike) -> tuple[Path, Path]:
    """(input CSV, case JSON) written beside ``fmu_path`` when a trajectory is exported."""
    path = Path(fmu_path)
    return path.with_name(f"{path.stem}_input.csv"), path.with_name(f"{path.stem}_case.json")


def _check_arguments(model, path, threshold_m, damping_scale):
    require_model(model)
    path = Path(path)
    if path.suffix.lower() != ".fmu":
        raise InputError(f"path: an FMU file name must end in .fmu, got {str(path)!r}")
    threshold_m = check_positive("threshold_m", threshold_m)
    zeta_max = float(np.max(model.zeta))
    scale = float(damping_scale)
    if not (math.isfinite(scale) and scale >= 0 and scale * zeta_max < 1):
        raise InputError(
            f"damping_scale: must be >= 0 and keep every damping ratio below 1 (largest zeta "
            f"{zeta_max:g}), got {damping_scale!r}"
        )
    return path, threshold_m, scale


def _check_options(fmi, outputs, turning) -> None:
    """InputError naming the keyword unless each option is its object (fmu.options)."""
    if not isinstance(fmi, Fmi):
        raise InputError(f"fmi: expected an fmu.Fmi, got {type(fmi).__name__}")
    if not isinstance(outputs, CellOutputs):
        raise InputError(f"outputs: expected an fmu.CellOutputs, got {type(outputs).__name__}")
    if turning is not None and not isinstance(turning, Turning):
        raise InputError(f"turning: None or an fmu.Turning, got {type(turning).__name__}")


def _check_outputs(path: Path, *, with_sidecars: bool) -> None:
    """InputError naming the file unless the FMU (and with a trajectory its input CSV and
    case JSON) may be written: absent or regular files, never links (jaxflex.files)."""
    check_output_file("path", path)
    if with_sidecars:
        csv_path, json_path = sidecar_paths(path)
        check_output_file("path (the input CSV beside the FMU)", csv_path)
        check_output_file("path (the case JSON beside the FMU)", json_path)


def check_trajectory(trajectory) -> Move | None:
    """``trajectory`` if it is None or a Move at rest at both ends; InputError naming
    ``trajectory`` otherwise."""
    if trajectory is None:
        return None
    if not isinstance(trajectory, Move):
        raise InputError(
            "trajectory: None or a jaxflex.Move (jaxflex.as_move(acc, dt_s): acc (n+1, 3) "
            f"m/s^2), got {type(trajectory).__name__}"
        )
    return as_move(trajectory, at_rest=True, name="trajectory acc")


def _case_summary(model, move: Move, threshold_m, case, turning_data, turning) -> dict[str, Any]:
    """Limits, threshold and the exact cycle time of the exported move (a turning part's:
    of its poses ``turning.pose`` with jaxflex._turning)."""
    acc, dt_s = move.acc, move.dt_s
    case = dict(case or {})
    summary: dict[str, Any] = {
        "threshold_m": threshold_m,
        "dt_s": dt_s,
        "n_samples": int(acc.shape[0]),
        "duration_s": (acc.shape[0] - 1) * dt_s,
        "limits": case.pop("limits", None),
    }
    case_threshold = case.pop("threshold_m", threshold_m)
    times = {key: case.pop(key) for key in _CASE_TIMES if key in case}
    if len(times) < len(_CASE_TIMES) or not math.isclose(case_threshold, threshold_m):
        if turning is None:
            report = analyze_move(model, move, threshold_m=threshold_m)
        else:
            pivot, gravity = turning_data.pivot_m, turning_data.gravity_m_s2
            turn = Turn(turning.pose, acc, pivot_m=pivot, gravity_m_s2=gravity)
            report = turning_settle(model, turn, threshold_m)
        times = {key: float(getattr(report, key)) for key in _CASE_TIMES}
    summary.update(times)
    summary["optimisation"] = case  # everything else the optimiser reported, unchanged
    return summary


def _stop_time(move: Move | None, summary) -> float:
    """The FMU's default stop time, s: 1.25 x the embedded move's cycle (whole steps of it),
    2 s without a move."""
    if move is None:
        return 2.0
    horizon = max(summary["duration_s"], summary["cycle_time_s"])
    return math.ceil(1.25 * horizon / move.dt_s - 1e-9) * move.dt_s


def _stage(stage: Path, fmi_version: int, ident: str, config: str, xml: str, resource: bytes):
    sources = stage / "sources"
    sources.mkdir(parents=True)
    for name in sources_for(fmi_version):
        shutil.copyfile(_C_DIR / name, sources / name)
    (sources / "jxf_config.h").write_text(config, encoding="utf-8")
    if fmi_version == 3:
        (sources / "buildDescription.xml").write_text(build_description(ident), encoding="utf-8")
    (stage / "resources").mkdir()
    (stage / "resources" / RESOURCE_FILE).write_bytes(resource)
    (stage / "modelDescription.xml").write_text(xml, encoding="utf-8")


def _write_sidecars(path: Path, move: Move, summary, desc: Description, poses=None) -> dict:
    """The input CSV (a turning part's with the pose columns: ``poses`` (N, 10)) and the
    case JSON beside the FMU: ExportResult's ``input_csv``, ``case_json`` and ``case``."""
    csv_path, json_path = sidecar_paths(path)
    t = move.dt_s * np.arange(move.n_steps + 1)
    names, values = list(INPUT_COLUMNS), np.column_stack([t, move.acc])
    if poses is not None:
        names += POSE_INPUT_NAMES
        values = np.column_stack([values, poses])
    lines = [",".join(names)]
    lines += [",".join(f"{x:.17g}" for x in row) for row in values]
    write_text_atomic(csv_path, "\n".join(lines) + "\n")
    case = {
        "format": CASE_FORMAT,
        "schema_version": 1,
        "fmu": path.name,
        "fmi_version": desc.fmi_version,
        "instantiation_token": desc.token,
        "n_points": desc.counts.points,
        "n_modes": desc.counts.modes,
        "input_csv": csv_path.name,
        "input_units": dict(zip(INPUT_COLUMNS, ("s", "m/s2", "m/s2", "m/s2"), strict=True))
        | ({} if poses is None else {name: pose_unit(name) for name in POSE_INPUT_NAMES}),
        "replay": (
            "set the parameter use_embedded_trajectory = true for the exact replay, or feed "
            f"{csv_path.name} as input with a communication step of dt_s (FMI 2.0: with input "
            "derivatives the input is linear over a step, as in jaxflex; otherwise held)"
        ),
        **summary,
    }
    write_text_atomic(json_path, json.dumps(case, indent=2))
    return {"input_csv": csv_path, "case_json": json_path, "case": case}


def _half_thickness(model: ModalModel, cell: Cell | None) -> float:
    """Half the sheet's thickness (m) the FMU takes off the distance: the cell file's, else
    the model's, else 0 (a model from modal results; said in the FMU's description)."""
    if cell is not None and cell.thickness_m is not None:
        return 0.5 * cell.thickness_m
    half = part_half_thickness(model)
    return 0.0 if half is None else half


def _cell_data(model: ModalModel, outputs: CellOutputs) -> CellData:
    """The resource's cell block of the model posed in ``outputs.cell`` (if any)."""
    if outputs.stress and model.stress is None:
        raise InputError("stress: the model has no stresses (make it with fem of this version)")
    cell = outputs.cell
    return CellData(
        outputs.gravity_m_s2,
        outputs.cup_safety,
        obstacle_records(() if cell is None else cell.obstacles),
        cups=model.cups is not None,
        stress=outputs.stress,
        half_thickness_m=_half_thickness(model, cell),
    )


def _turning_data(
    model: ModalModel, turning: Turning | None, outputs: CellOutputs, move: Move | None
) -> TurningData | None:
    """The data of a turning part (None without ``turning``): pivot, gravity (the cell's with
    a cell) and, with a trajectory ``move``, the poses of ``turning.pose`` at its samples;
    refuses inconsistent inputs, naming the field."""
    if turning is None:
        return None
    require_rotation(model)  # ModelError saying what the model lacks
    gravity = turning.gravity_in(outputs)
    if move is None:
        if turning.pose is not None:
            raise InputError("pose: the orientation path of an embedded move needs trajectory")
        return TurningData(turning.pivot_m, gravity)
    if turning.pose is None:
        raise InputError(
            "pose: a turning part's embedded move needs its orientation path (a "
            "jaxflex.response.PosePath at the trajectory's samples; --trajectory: the turn of "
            "`jaxflex optimize --rotate`)"
        )
    pose = check_pose(turning.pose, move.n_steps + 1, move.dt_s)
    return TurningData(turning.pivot_m, gravity, pose_samples(pose))


def _description(model, fmi: Fmi, ident: str, token: str, counts: Counts, start: dict):
    """What modelDescription.xml states: the options' name and text or made here, and the
    ``start`` values (threshold_m, damping_scale, stop_time_s, step_s)."""
    text = fmi.description or (
        f"Flexible sheet-metal part carried by a robot: exact modal response of "
        f"{model.n_modes} modes at {model.n_points} points (jaxflex)"
        + (", turning: the pose as inputs" if counts.turning else "")
    )
    zeta_max = float(np.max(model.zeta))
    return Description(
        fmi_version=fmi.version,
        model_name=fmi.model_name or ident,
        model_identifier=ident,
        token=token,
        description=text,
        counts=counts,
        damping_scale_max=(1.0 / zeta_max) * (1 - 1e-12) if zeta_max > 0 else 1e6,
        start_time_s=0.0,
        **start,
    )


def _build(path: Path, desc: Description, resource: bytes, windows: bool | None) -> BuildReport:
    """Stage the FMU's files (its C configuration from ``desc``), build its binaries and zip
    it to ``path``."""
    config = config_header(
        fmi_version=desc.fmi_version,
        token=desc.token,
        counts=desc.counts,
        threshold_m=desc.threshold_m,
        damping_scale=desc.damping_scale,
    )
    version, ident = desc.fmi_version, desc.model_identifier
    with tempfile.TemporaryDirectory(prefix="jaxflex_fmu_") as tmp:
        stage = Path(tmp) / "fmu"
        _stage(stage, version, ident, config, model_description(desc), resource)
        built = build_binaries(stage / "sources", stage / "binaries", version, ident, windows)
        zip_folder(stage, path)
    return built


def check_pose(pose: PosePath, n_samples: int, dt_s: float) -> PosePath:
    """``pose`` if it is an orientation path of ``n_samples`` samples at step ``dt_s`` (s)
    that starts and ends at rest with rotations (orthonormal, det +1), else InputError
    naming ``pose`` and what is wrong."""
    if not isinstance(pose, PosePath):
        raise InputError(f"pose: expected a jaxflex.response.PosePath, got {type(pose).__name__}")
    shapes = [np.shape(pose.rotation), np.shape(pose.omega_rad_s), np.shape(pose.alpha_rad_s2)]
    if shapes != [(n_samples, 3, 3), (n_samples, 3), (n_samples, 3)]:
        raise InputError(
            f"pose: {shapes[0][0] if shapes[0] else 0} samples of shapes {shapes}; the "
            f"trajectory has {n_samples} samples (rotation (n, 3, 3), rates (n, 3))"
        )
    if not math.isclose(pose.dt_s, dt_s, rel_tol=1e-12):
        raise InputError(f"pose: sampled every {pose.dt_s!r} s, the trajectory every {dt_s!r} s")
    rot = np.asarray(pose.rotation, dtype=np.float64)
    rates = np.concatenate([pose.omega_rad_s, pose.alpha_rad_s2], axis=1)
    if not (np.isfinite(rot).all() and np.isfinite(rates).all()):
        raise InputError("pose: a rotation, angular velocity or acceleration is not finite")
    gram = np.einsum("kij,kil->kjl", rot, rot) - np.eye(3)
    if np.abs(gram).max() > 1e-9 or (np.linalg.det(rot) <= 0).any():
        raise InputError("pose: every rotation must be orthonormal with determinant +1")
    scale = 1e-9 * max(1.0, float(np.abs(rates).max()))
    if np.abs(rates[[0, -1]]).max() > scale:
        raise InputError(
            "pose: the turn must start and end at rest (angular velocity and acceleration 0 at "
            "the first and last sample)"
        )
    return pose


@whole_or_absent()  # the FMU and its side files: all of them or none
def export_fmu(
    model: ModalModel,
    path: str | os.PathLike,
    trajectory: Move | None = None,
    *,
    fmi: Fmi = DEFAULT_FMI,
    threshold_m: float = THRESHOLD_M,
    damping_scale: float = 1.0,
    case: dict[str, Any] | None = None,
    outputs: CellOutputs = NO_CELL,
    turning: Turning | None = None,
) -> ExportResult:
    """Write ``model`` (K points, M modes) as an FMI 2.0 or 3.0 co-simulation FMU at ``path``
    (.fmu; its stem is the model identifier, made a C identifier), atomically; with a
    trajectory its side files too: every path is checked before the work, and a failure
    leaves none of them written (jaxflex.files.whole_or_absent).

    Args:
        trajectory: optional jaxflex.Move (``jaxflex.as_move(acc, dt_s)``, acc (n+1, 3)
            m/s^2 starting and ending at 0), embedded in the resource (replayed with
            ``use_embedded_trajectory = true``) and written beside the FMU as
            ``<name>_input.csv`` with ``<name>_case.json``; a turning part's: the pivot's
            world acceleration, its poses ``turning.pose``.
        fmi: the FMU to build (fmu.Fmi: FMI version, Windows DLL, model name, description).
        threshold_m: start value of the ``threshold`` parameter, m.
        damping_scale: start value of the ``damping_scale`` parameter.
        case: what the optimiser reported (``limits``, ``cycle_time_s``, ``transfer_time_s``,
            ``settle_time_s``, ``threshold_m``, ...); missing times are computed exactly.
        outputs: the robot cell's outputs (fmu.CellOutputs: the cell the model is posed in
            and its obstacles' distance, the cups' safety factor, the stresses).
        turning: a turning part (fmu.Turning: pivot, gravity, the embedded move's poses): the
            FMU takes the pose as inputs and is forced as jaxflex.simulate_turning; its cell
            outputs follow the turning part (jaxflex._turning_outputs, _turning_collision).
    """
    path, threshold_m, damping_scale = _check_arguments(model, path, threshold_m, damping_scale)
    _check_options(fmi, outputs, turning)
    move = check_trajectory(trajectory)
    _check_outputs(path, with_sidecars=move is not None)
    if case is not None and move is None:
        raise InputError("case: describes a trajectory, so it needs trajectory (a jaxflex.Move)")
    turning_data = _turning_data(model, turning, outputs, move)
    if outputs.cell is not None:
        model = outputs.cell.posed(model)
    cell_data = _cell_data(model, outputs)
    acc, dt_s = (None, None) if move is None else (move.acc, move.dt_s)
    counts = resource_counts(model, acc, cell_data, turning_data)
    summary = None
    if move is not None:
        summary = _case_summary(model, move, threshold_m, case, turning_data, turning)
    ident = model_identifier(path)
    start = {"threshold_m": threshold_m, "damping_scale": damping_scale, "step_s": dt_s or DT_S}
    start["stop_time_s"] = stop_time_s = _stop_time(move, summary)
    # the token covers what the binary and the resource must agree on, not the file's name
    # (its model identifier): an FMU exported under another name reuses the stored binary
    options = (fmi.version, fmi.model_name, fmi.description, threshold_m, damping_scale)
    blank = encode_resource(model, "", move, cell_data, turning_data)
    token = content_token(blank, repr((*options, stop_time_s)).encode())
    desc = _description(model, fmi, ident, token, counts, start)
    resource = encode_resource(model, token, move, cell_data, turning_data)
    built = _build(path, desc, resource, fmi.windows)
    sidecars = {}
    if move is not None:
        poses = None if turning_data is None else turning_data.pose_samples
        sidecars = _write_sidecars(path, move, summary, desc, poses)
    return ExportResult(
        fmu_path=path,
        fmi_version=fmi.version,
        token=token,
        model_identifier=ident,
        counts=counts,
        resource_bytes=len(resource),
        **built.written(),
        **sidecars,
    )
