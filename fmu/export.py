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
from jaxflex.geometry import DEFAULT_GRAVITY_M_S2, Cell, part_half_thickness
from jaxflex.model import ModalModel
from jaxflex.response import (
    DEFAULT_CUP_SAFETY,
    Move,
    PosePath,
    Turn,
    analyze_move,
    as_move,
    require_rotation,
    simulate_turning,
    turning_settle,
)

CASE_FORMAT = "jaxflex.fmu_case"
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


def _check_arguments(model, path, fmi_version, threshold_m, damping_scale):
    if not isinstance(model, ModalModel):
        raise InputError(f"model: expected a jaxflex.ModalModel, got {type(model).__name__}")
    if fmi_version not in (2, 3):
        raise InputError(f"fmi_version: must be 2 or 3, got {fmi_version!r}")
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


def _check_outputs(path: Path, *, with_sidecars: bool) -> None:
    """InputError naming the file unless the FMU (and with a trajectory its input CSV and
    case JSON) may be written: absent or regular files, never links (jaxflex.files)."""
    check_output_file("path", path)
    if with_sidecars:
        csv_path, json_path = sidecar_paths(path)
        check_output_file("path (the input CSV beside the FMU)", csv_path)
        check_output_file("path (the case JSON beside the FMU)", json_path)


def _check_trajectory(trajectory) -> tuple[np.ndarray | None, float | None]:
    if trajectory is None:
        return None, None
    if isinstance(trajectory, Move):
        acc, dt_s = trajectory, None
    else:
        try:
            acc, dt_s = trajectory
        except (TypeError, ValueError) as exc:
            raise InputError(
                "trajectory: expected a jaxflex.Move or a pair (acc (n+1, 3) m/s^2, dt_s)"
            ) from exc
    move = as_move(acc, dt_s, at_rest=True, name="trajectory acc", dt_name="trajectory dt_s")
    return move.acc, move.dt_s


def _case_summary(model, acc, dt_s, threshold_m, case, turning, pose) -> dict[str, Any]:
    """Limits, threshold and the exact cycle time of the exported move (a turning part's:
    of its ``pose`` path with jaxflex._turning)."""
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
            report = analyze_move(model, acc, dt_s, threshold_m)
        else:
            turn = Turn(pose, acc, pivot_m=turning.pivot_m, gravity_m_s2=turning.gravity_m_s2)
            report = turning_settle(pose, model, simulate_turning(model, turn), threshold_m)
        times = {key: float(getattr(report, key)) for key in _CASE_TIMES}
    summary.update(times)
    summary["optimisation"] = case  # everything else the optimiser reported, unchanged
    return summary


def _stop_time(acc, dt_s, summary) -> float:
    if acc is None:
        return 2.0
    horizon = max(summary["duration_s"], summary["cycle_time_s"])
    return math.ceil(1.25 * horizon / dt_s - 1e-9) * dt_s


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


def _write_sidecars(
    path: Path, acc, dt_s, summary, result_fields, poses=None
) -> tuple[Path, Path, dict]:
    """The input CSV (a turning part's with the pose columns: ``poses`` (N, 10)) and the
    case JSON beside the FMU."""
    csv_path, json_path = sidecar_paths(path)
    t = dt_s * np.arange(acc.shape[0])
    names, values = list(INPUT_COLUMNS), np.column_stack([t, acc])
    if poses is not None:
        names += POSE_INPUT_NAMES
        values = np.column_stack([values, poses])
    lines = [",".join(names)]
    lines += [",".join(f"{x:.17g}" for x in row) for row in values]
    write_text_atomic(csv_path, "\n".join(lines) + "\n")
    case = {
        "format": CASE_FORMAT,
        "schema_version": 1,
        **result_fields,
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
    return csv_path, json_path, case


def _half_thickness(model: ModalModel, cell: Cell | None) -> float:
    """Half the sheet's thickness (m) the FMU takes off the distance: the cell file's, else
    the model's, else 0 (a model from modal results; said in the FMU's description)."""
    if cell is not None and cell.thickness_m is not None:
        return 0.5 * cell.thickness_m
    half = part_half_thickness(model)
    return 0.0 if half is None else half


def _turning_data(
    model: ModalModel, turning: bool, pivot_m, gravity_m_s2, acc, dt_s, pose
) -> TurningData | None:
    """The data of a turning part (None when ``turning`` is off): pivot, gravity and, with a
    trajectory ``acc`` at ``dt_s``, the poses of the PosePath ``pose`` at its samples; refuses
    inconsistent inputs, naming the option."""
    if not turning:
        if pose is not None:
            raise InputError("pose: only for a turning part (turning=True, --turning)")
        return None
    require_rotation(model)  # ModelError saying what the model lacks
    pivot = np.asarray(pivot_m, dtype=np.float64)
    gravity = np.asarray(gravity_m_s2, dtype=np.float64)
    for name, value in (("pivot_m", pivot), ("gravity_m_s2", gravity)):
        if value.shape != (3,) or not np.isfinite(value).all():
            raise InputError(f"{name}: three finite numbers, got {value.tolist()!r}")
    if acc is None:
        if pose is not None:
            raise InputError("pose: the orientation path of an embedded move needs trajectory")
        return TurningData(pivot, gravity)
    if pose is None:
        raise InputError(
            "pose: a turning part's embedded move needs its orientation path (a "
            "jaxflex.response.PosePath at the trajectory's samples; --trajectory: the turn of "
            "`jaxflex optimize --rotate`)"
        )
    return TurningData(pivot, gravity, pose_samples(check_pose(pose, acc.shape[0], dt_s)))


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


def pose_options(turn: Turn | None, pivot_m=None) -> dict:
    """:func:`export_fmu`'s (and fmu.ssp.export_ssp's) keywords of a turning part's
    embedded move ``turn`` (a jaxflex.response.Turn: its pose path, pivot and gravity), or
    without one of the pivot ``pivot_m`` alone (default the origin)."""
    if turn is None:
        return {"pivot_m": (0.0, 0.0, 0.0) if pivot_m is None else pivot_m}
    return {"pose": turn.path, "pivot_m": turn.pivot_m, "gravity_m_s2": turn.gravity_m_s2}


@whole_or_absent()  # the FMU and its side files: all of them or none
def export_fmu(
    model: ModalModel,
    path: str | os.PathLike,
    fmi_version: int = 2,
    trajectory: Move | tuple[Any, float] | None = None,
    threshold_m: float = THRESHOLD_M,
    case: dict[str, Any] | None = None,
    *,
    damping_scale: float = 1.0,
    model_name: str | None = None,
    description: str | None = None,
    windows: bool | None = None,
    cell: Cell | None = None,
    cup_safety: float = DEFAULT_CUP_SAFETY,
    stress: bool = False,
    turning: bool = False,
    pivot_m=(0.0, 0.0, 0.0),
    gravity_m_s2=DEFAULT_GRAVITY_M_S2,
    pose: PosePath | None = None,
) -> ExportResult:
    """Write ``model`` as an FMI 2.0 or 3.0 co-simulation FMU at ``path`` (atomically; with
    a trajectory its side files too: every path is checked before the work, and a failure
    leaves none of them written, jaxflex.files.whole_or_absent).

    Args:
        model: the part (K points, M modes).
        path: the .fmu file; its stem is the model identifier (made a C identifier).
        fmi_version: 2 or 3.
        trajectory: optional Move (or its pair ``(acc, dt_s)``), acc (n+1, 3) m/s^2 starting
            and ending at 0,
            embedded in the resource (replayed with ``use_embedded_trajectory = true``) and
            written beside the FMU as ``<name>_input.csv`` with ``<name>_case.json``.
        threshold_m: start value of the ``threshold`` parameter, m.
        case: what the optimiser reported (``limits``, ``cycle_time_s``, ``transfer_time_s``,
            ``settle_time_s``, ``threshold_m``, ...); missing times are computed exactly.
        damping_scale: start value of the ``damping_scale`` parameter.
        model_name, description: text for modelDescription.xml.
        windows: build the Windows DLL too: None = when mingw-w64 is installed, True = must.
        cell: a jaxflex.geometry.Cell: the model is posed in it (inputs and points in cell
            coordinates, the trajectory too) and the FMU reports the distance to its
            obstacles (``min_distance``; FMI 3.0 also ``point_distances``).
        cup_safety: safety factor of the cup utilisation outputs (``cup_utilisation``; FMI 3.0
            also ``cup_utilisations``), present when the model has cup reactions.
        stress: also the von Mises outputs (``max_stress``; FMI 3.0 ``point_stresses``; the
            stress maps can make the resource large: 1.9 kB per stress point at 20 modes).
        turning: the part turns: the FMU takes the pose as inputs as well (the orientation
            quaternion quat_w..quat_z body -> world, the angular velocity omega_x..z and
            acceleration alpha_x..z in body components; ax, ay, az the world acceleration of
            ``pivot_m``) and is forced as jaxflex._turning (needs the model's rotation data).
            With a ``trajectory`` it embeds the move of poses: ``acc`` the pivot's world
            acceleration and ``pose``. The cell's outputs follow the turning part
            (jaxflex._turning_outputs, jaxflex._turning_collision; with a ``cell`` the pivot
            is in its coordinates at the start, the posed model's frame, and gravity the
            cell's).
        pivot_m: (3,) m, model frame: the point whose acceleration ax, ay, az are (turning).
        gravity_m_s2: (3,) m/s^2 in world components (turning; the cell's otherwise).
        pose: a turning part's embedded orientation path (jaxflex.response.PosePath at the
            trajectory's samples and step, starting and ending at rest), replayed with
            ``acc`` as jaxflex.simulate_turning does (the forcing linear between samples).
    """
    path, threshold_m, damping_scale = _check_arguments(
        model, path, fmi_version, threshold_m, damping_scale
    )
    acc, dt_s = _check_trajectory(trajectory)
    _check_outputs(path, with_sidecars=acc is not None)
    if turning and cell is not None:  # the turning part's gravity is the cell's
        gravity_m_s2 = cell.gravity_m_s2
    turning_data = _turning_data(model, turning, pivot_m, gravity_m_s2, acc, dt_s, pose)
    if cell is not None:
        model = cell.posed(model)
    if stress and model.stress is None:
        raise InputError("stress: the model has no stresses (make it with fem of this version)")
    cell_data = CellData(
        DEFAULT_GRAVITY_M_S2 if cell is None else cell.gravity_m_s2,
        check_positive("cup_safety", cup_safety),
        obstacle_records(() if cell is None else cell.obstacles),
        cups=model.cups is not None,
        stress=stress,
        half_thickness_m=_half_thickness(model, cell),
    )
    counts = resource_counts(model, acc, cell_data, turning_data)
    if case is not None and acc is None:
        raise InputError("case: describes a trajectory, so it needs trajectory=(acc, dt_s)")
    summary = None
    if acc is not None:
        summary = _case_summary(model, acc, dt_s, threshold_m, case, turning_data, pose)
    ident = model_identifier(path)
    stop_time_s = _stop_time(acc, dt_s, summary)
    # the token covers what the binary and the resource must agree on, not the file's name
    # (its model identifier): an FMU exported under another name reuses the stored binary
    options = (fmi_version, model_name, description, threshold_m, damping_scale, stop_time_s)
    token = content_token(
        encode_resource(model, "", acc, dt_s, cell_data, turning_data), repr(options).encode()
    )
    zeta_max = float(np.max(model.zeta))
    desc = Description(
        fmi_version=fmi_version,
        model_name=model_name or ident,
        model_identifier=ident,
        token=token,
        description=description
        or f"Flexible sheet-metal part carried by a robot: exact modal response of "
        f"{model.n_modes} modes at {model.n_points} points (jaxflex)"
        + (", turning: the pose as inputs" if turning_data else ""),
        counts=counts,
        threshold_m=threshold_m,
        damping_scale=damping_scale,
        damping_scale_max=(1.0 / zeta_max) * (1 - 1e-12) if zeta_max > 0 else 1e6,
        start_time_s=0.0,
        stop_time_s=stop_time_s,
        step_s=dt_s or DT_S,
    )
    config = config_header(
        fmi_version=fmi_version,
        token=token,
        counts=counts,
        threshold_m=threshold_m,
        damping_scale=damping_scale,
    )
    resource = encode_resource(model, token, acc, dt_s, cell_data, turning_data)
    with tempfile.TemporaryDirectory(prefix="jaxflex_fmu_") as tmp:
        stage = Path(tmp) / "fmu"
        _stage(stage, fmi_version, ident, config, model_description(desc), resource)
        built: BuildReport = build_binaries(
            stage / "sources", stage / "binaries", fmi_version, ident, windows
        )
        zip_folder(stage, path)
    fields = {
        "fmu": path.name,
        "fmi_version": fmi_version,
        "instantiation_token": token,
        "n_points": counts.points,
        "n_modes": counts.modes,
    }
    csv_path = json_path = case_out = None
    if acc is not None:
        poses = None if turning_data is None else turning_data.pose_samples
        csv_path, json_path, case_out = _write_sidecars(path, acc, dt_s, summary, fields, poses)
    return ExportResult(
        fmu_path=path,
        fmi_version=fmi_version,
        token=token,
        model_identifier=ident,
        counts=counts,
        resource_bytes=len(resource),
        **built.written(),
        input_csv=csv_path,
        case_json=json_path,
        case=case_out,
    )
