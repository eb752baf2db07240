"""The trajectory source FMU: plays the optimised move's samples in a co-simulation.

Outputs ``ax``, ``ay``, ``az`` (m/s^2, value references 1-3, the names of the part FMU's
inputs) at a communication point t: the samples taken every ``dt_s`` from the start time,
linear between them, at rest before the start and after the last sample. A turning move's
source (``pose=``, a jaxflex.response.PosePath) also outputs the pose a turning part FMU takes,
with the part's names and value references (fmu.variables.POSE_INPUT_NAMES, 40-49):
quaternion body -> world, angular velocity and acceleration in body components, exactly the
samples jaxflex.simulate_turning uses at the sample times; between them the orientation
turns as the part turns its own embedded move (``fmu/c/jxf_source.c``). Their first time
derivative is provided (``maxOutputDerivativeOrder = 1``: ``fmi2GetRealOutputDerivatives`` /
``fmi3GetOutputDerivatives``): the slope of the segment beginning at t (of the quaternion and
the angular velocity: the chord to the next sample), so an FMI 2.0 importer that forwards it
to the part's ``fmi2SetRealInputDerivatives`` drives the part with exactly the move jaxflex
optimised (the first-order hold between the samples); an importer that copies values only
holds each sample over the step. The samples are compiled into the binary (the core
``fmu/c/jxf_source.c`` under the FMI bindings every jaxflex FMU shares, data in the generated
``sources/jxf_source_data.h``); the FMU has no resources.
"""

from __future__ import annotations

import os
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

import jaxflex
from fmu.archive import content_token, zip_folder
from fmu.build import SOURCE_CORE, WrittenFmu, build_binaries, compiled_files, sources_for
from fmu.export import check_pose, model_identifier
from fmu.model_description import build_description, cosimulation, unit_definitions
from fmu.resource import pose_samples
from fmu.toolchain import C_DIR
from fmu.variables import POSE_INPUT_NAMES, pose_unit
from jaxflex.errors import InputError
from jaxflex.response import Move, PosePath, as_move

DATA_FILE = "jxf_source_data.h"
OUTPUTS = ("ax", "ay", "az")  # value references 1, 2, 3
POSE_VR = 40  # quat_w; then quat_x .. alpha_z, as the turning part's inputs (fmu.variables)
_OUTPUT_TEXT = (
    "Base acceleration along {axis}, m/s^2 (a turning move: of the pivot, world components): "
    "the optimised move's samples, linear between them, 0 before the start and after the last "
    "sample; first derivative = slope of the segment beginning at the communication point"
)
_POSE_TEXT = (
    "{name} of the turning move's pose (quaternion body to world; omega, alpha in body "
    "components): the samples at their times, the orientation turned between them as the "
    "part's embedded move, the first / last sample outside; first derivative = slope to the "
    "next sample (alpha: of the segment)"
)


@dataclass(frozen=True, kw_only=True)
class SourceResult(WrittenFmu):
    """What :func:`export_source_fmu` wrote: the FMU (WrittenFmu) playing ``n_samples``
    samples every ``dt_s`` s; ``outputs`` the names of its outputs (ax, ay, az, and the pose
    of a turning move)."""

    n_samples: int
    dt_s: float
    outputs: tuple[str, ...] = OUTPUTS


@dataclass(frozen=True)
class Channel:
    """One output of the source: name, value reference, unit (None: dimensionless)."""

    name: str
    vr: int
    unit: str | None
    description: str


def source_channels(turning: bool) -> tuple[Channel, ...]:
    """The outputs of a straight (ax, ay, az) or turning (and the pose) move's source."""
    straight = tuple(
        Channel(name, vr, "m/s2", _OUTPUT_TEXT.format(axis=name[1]))
        for vr, name in enumerate(OUTPUTS, start=1)
    )
    if not turning:
        return straight
    pose = tuple(
        Channel(
            name,
            POSE_VR + i,
            None if pose_unit(name) == "1" else pose_unit(name),
            _POSE_TEXT.format(name=name),
        )
        for i, name in enumerate(POSE_INPUT_NAMES)
    )
    return straight + pose


def source_samples(acc: np.ndarray, pose: PosePath | None) -> np.ndarray:
    """(n+1, 3) ``acc`` m/s^2, or with a ``pose`` (n+1, 13): acc, then the pose as the part
    FMU embeds it (fmu.resource.pose_samples: quaternion w, x, y, z body -> world, omega rad/s,
    alpha rad/s^2 body), each quaternion in the hemisphere of the one before (q and -q are the
    same orientation; the source's chord between neighbours must not pass through 0)."""
    if pose is None:
        return acc
    poses = pose_samples(pose)
    quat = poses[:, :4]
    flips = np.cumprod(np.where(np.sum(quat[1:] * quat[:-1], axis=1) < 0.0, -1.0, 1.0))
    quat[1:] *= flips[:, None]
    return np.hstack([acc, poses])


def source_data_header(
    fmi_version: int, token: str, samples: np.ndarray, dt_s: float, channels=None
) -> str:
    """``jxf_source_data.h``: FMI version, token, sample count and step (s), the ``channels``
    (default ax, ay, az) and the ``samples`` (n+1, len(channels)) (SI units, printed with 17
    significant digits, so they round-trip exactly)."""
    channels = channels or source_channels(False)
    rows = ",\n".join("    " + ", ".join(f"{x!r}" for x in map(float, row)) for row in samples)
    vrs = ", ".join(f"{c.vr}u" for c in channels)
    return "\n".join(
        [
            "/* Generated by jaxflex (fmu.source): the move this trajectory source plays. */",
            "#ifndef JXF_SOURCE_DATA_H",
            "#define JXF_SOURCE_DATA_H",
            f"#define JXF_SOURCE_FMI_VERSION {int(fmi_version)}",
            f'#define JXF_SOURCE_TOKEN "{token}"',
            f"#define JXF_SOURCE_N {len(samples)}",
            f"#define JXF_SOURCE_DT {float(dt_s)!r}",
            f"#define JXF_SOURCE_TURNING {int(len(channels) > len(OUTPUTS))}",
            f"#define JXF_SOURCE_CHANNELS {len(channels)}",
            f"static const unsigned jxf_source_vrs[JXF_SOURCE_CHANNELS] = {{{vrs}}};",
            "static const double jxf_source_samples[JXF_SOURCE_CHANNELS * JXF_SOURCE_N] = {",
            rows,
            "};",
            "#endif",
            "",
        ]
    )


def _root(fmi_version: int, token: str, ident: str, n_samples: int, dt_s: float) -> ET.Element:
    return ET.Element(
        "fmiModelDescription",
        {
            "fmiVersion": f"{fmi_version}.0",
            "modelName": ident,
            ("guid" if fmi_version == 2 else "instantiationToken"): token,
            "description": f"Trajectory source: {n_samples} acceleration samples every {dt_s:g} "
            "s, linear between them (jaxflex)",
            "generationTool": f"jaxflex {jaxflex.__version__}",
            "generationDateAndTime": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "variableNamingConvention": "flat",
            **({"numberOfEventIndicators": "0"} if fmi_version == 2 else {}),
        },
    )


def _common(root: ET.Element, n_samples: int, dt_s: float, units) -> ET.Element:
    """UnitDefinitions (of ``units``), LogCategories, DefaultExperiment; returns the
    ModelVariables element."""
    unit_definitions(root, units)
    cats = ET.SubElement(root, "LogCategories")
    for name, text in (
        ("logStatusError", "Errors: wrong token, calls out of order, bad step sizes"),
        ("logStatusWarning", "Warnings: inconsistent communication points"),
        ("logAll", "Debug messages"),
    ):
        ET.SubElement(cats, "Category", name=name, description=text)
    ET.SubElement(
        root,
        "DefaultExperiment",
        startTime="0.0",
        stopTime=repr((n_samples - 1) * float(dt_s)),
        stepSize=repr(float(dt_s)),
    )
    return ET.SubElement(root, "ModelVariables")


def source_model_description(
    fmi_version: int, token: str, ident: str, n_samples: int, dt_s: float, channels=None
) -> str:
    """modelDescription.xml of the trajectory source (FMI 2.0 or 3.0) with the outputs
    ``channels`` (default ax, ay, az)."""
    channels = channels or source_channels(False)
    root = _root(fmi_version, token, ident, n_samples, dt_s)
    cosimulation(
        root, fmi_version, ident, compiled_files(fmi_version, SOURCE_CORE),
        output_derivatives=1, interpolates_inputs=False,
    )  # fmt: skip
    units = {"s"} | {c.unit for c in channels if c.unit}
    variables = _common(root, n_samples, dt_s, units)
    if fmi_version == 3:
        ET.SubElement(
            variables,
            "Float64",
            name="time",
            valueReference="0",
            causality="independent",
            variability="continuous",
            unit="s",
            description="Simulation time, s",
        )
    for c in channels:
        attrs = {
            "name": c.name,
            "valueReference": str(c.vr),
            "description": c.description,
            "causality": "output",
            "variability": "continuous",
            "initial": "calculated",
        }
        unit = {"unit": c.unit} if c.unit else {}
        if fmi_version == 2:
            ET.SubElement(ET.SubElement(variables, "ScalarVariable", attrs), "Real", unit)
        else:
            ET.SubElement(variables, "Float64", {**attrs, **unit})
    structure = ET.SubElement(root, "ModelStructure")
    if fmi_version == 2:  # indices into ModelVariables (1-based): the outputs are 1..n
        outputs = ET.SubElement(structure, "Outputs")
        initial = ET.SubElement(structure, "InitialUnknowns")
        for index in range(1, len(channels) + 1):
            ET.SubElement(outputs, "Unknown", index=str(index), dependencies="")
            ET.SubElement(initial, "Unknown", index=str(index), dependencies="")
    else:
        for c in channels:
            ET.SubElement(structure, "Output", valueReference=str(c.vr), dependencies="")
        for c in channels:
            ET.SubElement(structure, "InitialUnknown", valueReference=str(c.vr), dependencies="")
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def export_source_fmu(
    path: str | os.PathLike,
    move: Move,
    fmi_version: int = 2,
    *,
    pose: PosePath | None = None,
    windows: bool | None = None,
) -> SourceResult:
    """Write the trajectory source FMU for ``move`` (a jaxflex.Move: samples (n+1, 3) m/s^2,
    at rest at both ends, and their step), atomically at ``path`` (.fmu; its stem becomes the
    model identifier). ``pose``: a turning move's orientation path (jaxflex.response.PosePath at
    the same samples and step, at rest at both ends; the move's samples are then the pivot's
    world acceleration), output as the turning part's pose inputs. ``windows``: build the Windows
    DLL too (None = when mingw-w64 is installed, True = must)."""
    if fmi_version not in (2, 3):
        raise InputError(f"fmi_version: must be 2 or 3, got {fmi_version!r}")
    path = Path(path)
    if path.suffix.lower() != ".fmu":
        raise InputError(f"path: an FMU file name must end in .fmu, got {str(path)!r}")
    move = as_move(move, at_rest=True, name="trajectory", dt_name="trajectory dt_s")
    acc, dt_s = move.acc, move.dt_s
    if pose is not None:
        pose = check_pose(pose, len(acc), dt_s)
    channels = source_channels(pose is not None)
    samples = source_samples(acc, pose)
    ident = model_identifier(path)
    names = [channel.name for channel in channels]
    # not the file's name (its model identifier): another name reuses the stored binary
    token = content_token(samples.tobytes(), repr((fmi_version, dt_s, names)).encode())
    with tempfile.TemporaryDirectory(prefix="jaxflex_source_") as tmp:
        stage = Path(tmp) / "fmu"
        sources = stage / "sources"
        sources.mkdir(parents=True)
        for name in sources_for(fmi_version, SOURCE_CORE):
            (sources / name).write_bytes((C_DIR / name).read_bytes())
        (sources / DATA_FILE).write_text(
            source_data_header(fmi_version, token, samples, dt_s, channels), encoding="utf-8"
        )
        if fmi_version == 3:
            (sources / "buildDescription.xml").write_text(
                build_description(ident, compiled_files(3, SOURCE_CORE)), encoding="utf-8"
            )
        (stage / "modelDescription.xml").write_text(
            source_model_description(fmi_version, token, ident, len(acc), dt_s, channels),
            encoding="utf-8",
        )
        built = build_binaries(
            sources,
            stage / "binaries",
            fmi_version,
            ident,
            windows,
            compiled_files(fmi_version, SOURCE_CORE),
        )
        zip_folder(stage, path)
    return SourceResult(
        fmu_path=path,
        fmi_version=fmi_version,
        token=token,
        model_identifier=ident,
        n_samples=len(acc),
        dt_s=dt_s,
        outputs=tuple(c.name for c in channels),
        **built.written(),
    )
