"""An SSP 1.0 package (System Structure and Parameterization) of an optimised move.

``export_ssp(model, "case.ssp", move)`` (a jaxflex.Move) writes one archive a co-simulation
tool opens as a whole:

    SystemStructure.ssd           system "case": components, connections, parameters
    resources/part.fmu            the part (see fmu.export; its trajectory is embedded too)
    resources/part_case.json      the case: limits, threshold, cycle time (fmu.export)
    resources/part_input.csv      the move as time, ax, ay, az (fmu.export)
    resources/trajectory.fmu      the trajectory source playing the move (see fmu.source)

The source's outputs ``ax``, ``ay``, ``az`` are connected to the part's inputs of the same
names; a turning part (``turning=fmu.Turning(pose=..., pivot_m=...)``) also takes the pose from the
source: quat_w..quat_z, omega_x..z, alpha_x..z, 13 connections in all. The part's
``threshold`` and ``damping_scale`` are bound in the parameter set named ``case`` (inline
``ssv:ParameterSet`` in a component ``ParameterBinding``). Both FMUs use the same FMI version.
"""

from __future__ import annotations

import math
import os
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from fmpy import read_model_description
from fmpy.ssp.ssd import read_ssd

import jaxflex
from fmu.archive import zip_folder
from fmu.export import DEFAULT_FMI, ExportResult, export_fmu
from fmu.model_description import UNITS
from fmu.options import Fmi, Turning
from fmu.source import SourceResult, export_source_fmu, source_channels
from jaxflex.defaults import THRESHOLD_M
from jaxflex.errors import InputError
from jaxflex.files import check_output_file, whole_or_absent
from jaxflex.model import ModalModel
from jaxflex.response import Move

PART, SOURCE = "part", "trajectory"
PARAMETER_SET = "case"
SSD_FILE = "SystemStructure.ssd"
_NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
}
_SSD_UNITS = ("m", "s", "m/s2", "rad/s", "rad/s2")  # of the connectors (fmu.model_description)
for _prefix, _uri in _NS.items():
    ET.register_namespace(_prefix, _uri)


def _q(name: str) -> str:
    """``"ssd:System"`` -> ElementTree's ``{namespace}System``."""
    prefix, local = name.split(":")
    return f"{{{_NS[prefix]}}}{local}"


@dataclass(frozen=True)
class Connector:
    """One connector of a component: an FMU variable exposed in the system."""

    name: str
    kind: str  # input, output, parameter
    type: str  # Real, Boolean
    unit: str | None = None


@dataclass(frozen=True)
class SspResult:
    """What :func:`export_ssp` wrote: the archive and the two FMUs inside it (their paths,
    and those of the part's case files, relative to the archive: ``resources/...``)."""

    ssp_path: Path
    fmi_version: int
    part: ExportResult
    source: SourceResult
    parameters: dict[str, float]
    stop_time_s: float
    case: dict[str, Any] | None = None


def part_connectors(fmu_path: Path) -> list[Connector]:
    """Connectors for every scalar input, output and parameter of the part FMU."""

    connectors = []
    for v in read_model_description(str(fmu_path)).modelVariables:
        if v.causality not in ("input", "output", "parameter") or v.dimensions:
            continue
        kind = "Boolean" if v.type == "Boolean" else "Real"
        connectors.append(Connector(v.name, v.causality, kind, v.unit))
    return connectors


def source_connectors(turning: bool = False) -> list[Connector]:
    """Connectors of the trajectory source's outputs (a turning move's: the pose too)."""
    return [Connector(c.name, "output", "Real", c.unit) for c in source_channels(turning)]


def _component(parent, name: str, source: str, connectors: list[Connector]) -> ET.Element:
    element = ET.SubElement(
        parent,
        _q("ssd:Component"),
        name=name,
        type="application/x-fmu-sharedlibrary",
        source=source,
    )
    group = ET.SubElement(element, _q("ssd:Connectors"))
    for c in connectors:
        node = ET.SubElement(group, _q("ssd:Connector"), name=c.name, kind=c.kind)
        ET.SubElement(node, _q(f"ssc:{c.type}"), {"unit": c.unit} if c.unit else {})
    return element


def _bind(component: ET.Element, parameters: dict[str, float]) -> None:
    bindings = ET.SubElement(component, _q("ssd:ParameterBindings"))
    values = ET.SubElement(
        ET.SubElement(bindings, _q("ssd:ParameterBinding")), _q("ssd:ParameterValues")
    )
    parameter_set = ET.SubElement(values, _q("ssv:ParameterSet"), version="1.0", name=PARAMETER_SET)
    group = ET.SubElement(parameter_set, _q("ssv:Parameters"))
    for name, value in parameters.items():
        node = ET.SubElement(group, _q("ssv:Parameter"), name=name)
        ET.SubElement(node, _q("ssv:Real"), value=repr(float(value)))


def system_structure(
    name: str,
    part: list[Connector],
    parameters: dict[str, float],
    stop_time_s: float,
    description: str,
    turning: bool = False,
) -> str:
    """SystemStructure.ssd: the part and the trajectory source, every output of the source
    (ax/ay/az, and the pose of a ``turning`` move) connected to the part's input of that name,
    the part's ``parameters`` bound in the parameter set ``case``, default experiment
    0 .. stop_time_s."""
    root = ET.Element(
        _q("ssd:SystemStructureDescription"),
        version="1.0",
        name=name,
        generationTool=f"jaxflex {jaxflex.__version__}",
        generationDateAndTime=datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
    )
    system = ET.SubElement(root, _q("ssd:System"), name=name, description=description)
    elements = ET.SubElement(system, _q("ssd:Elements"))
    signals = source_connectors(turning)
    _component(elements, SOURCE, f"resources/{SOURCE}.fmu", signals)
    _bind(_component(elements, PART, f"resources/{PART}.fmu", part), parameters)
    inputs = {c.name for c in part if c.kind == "input"}
    connections = ET.SubElement(system, _q("ssd:Connections"))
    for signal in signals:
        if signal.name not in inputs:
            raise InputError(f"the part FMU has no input {signal.name!r} for the source's output")
        ET.SubElement(
            connections,
            _q("ssd:Connection"),
            startElement=SOURCE,
            startConnector=signal.name,
            endElement=PART,
            endConnector=signal.name,
        )
    units = ET.SubElement(root, _q("ssd:Units"))
    for unit in _SSD_UNITS:
        exponents = UNITS[unit]
        ET.SubElement(
            ET.SubElement(units, _q("ssc:Unit"), name=unit), _q("ssc:BaseUnit"), exponents
        )
    ET.SubElement(
        root, _q("ssd:DefaultExperiment"), startTime="0.0", stopTime=repr(float(stop_time_s))
    )
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def stop_time_of(fmu_path: Path) -> float:
    """The default experiment's stop time of an FMU, s."""
    with zipfile.ZipFile(fmu_path) as zf:
        root = ET.fromstring(zf.read("modelDescription.xml"))
    return float(root.find("DefaultExperiment").get("stopTime"))


@whole_or_absent()  # the package: whole or absent
def export_ssp(
    model: ModalModel,
    path: str | os.PathLike,
    trajectory: Move,
    *,
    fmi: Fmi = DEFAULT_FMI,
    threshold_m: float = THRESHOLD_M,
    damping_scale: float = 1.0,
    case: dict[str, Any] | None = None,
    turning: Turning | None = None,
) -> SspResult:
    """Write the SSP package of ``model`` moved by ``trajectory`` (a jaxflex.Move at rest at
    both ends) at ``path`` (.ssp, atomically); both FMUs of ``fmi``'s version, Windows DLLs
    and model name. ``threshold_m``, ``case``, ``damping_scale`` and ``turning`` as in
    :func:`fmu.export_fmu`; the threshold and damping scale are also bound as SSP parameters.
    A turning move (``turning`` with its ``pose``; the trajectory the pivot's world
    acceleration): the turning part FMU, its pose inputs connected to the turning source's
    pose outputs."""
    path = Path(path)
    if path.suffix.lower() != ".ssp":
        raise InputError(f"path: an SSP file name must end in .ssp, got {str(path)!r}")
    if trajectory is None:
        raise InputError("trajectory: an SSP package plays a move; pass a jaxflex.Move")
    check_output_file("path", path)
    with tempfile.TemporaryDirectory(prefix="jaxflex_ssp_") as tmp:
        stage = Path(tmp) / "ssp"
        resources = stage / "resources"
        resources.mkdir(parents=True)
        part = export_fmu(
            model,
            resources / f"{PART}.fmu",
            trajectory,
            fmi=replace(fmi, description=None),
            threshold_m=threshold_m,
            damping_scale=damping_scale,
            case=case,
            turning=turning,
        )
        pose = None if turning is None else turning.pose
        source = export_source_fmu(
            resources / f"{SOURCE}.fmu",
            trajectory,
            fmi.version,
            pose=pose,
            windows=fmi.windows,
        )
        parameters = {"threshold": float(threshold_m), "damping_scale": float(damping_scale)}
        stop = stop_time_of(part.fmu_path)
        text = system_structure(
            path.stem,
            part_connectors(part.fmu_path),
            parameters,
            stop,
            fmi.description
            or f"{fmi.model_name or path.stem}: a flexible part moved by the optimised "
            f"trajectory{' and turned by its poses' if turning else ''} (FMI {fmi.version}.0 "
            "co-simulation, jaxflex)",
            turning=turning is not None,
        )
        (stage / SSD_FILE).write_text(text, encoding="utf-8")
        zip_folder(stage, path)
    inside = Path("resources")
    return SspResult(
        ssp_path=path,
        fmi_version=fmi.version,
        part=replace(
            part,
            fmu_path=inside / part.fmu_path.name,
            input_csv=inside / part.input_csv.name,
            case_json=inside / part.case_json.name,
        ),
        source=replace(source, fmu_path=inside / source.fmu_path.name),
        parameters=parameters,
        stop_time_s=stop,
        case=part.case,
    )


def read_parameters(path: str | os.PathLike) -> dict[str, dict[str, float | bool]]:
    """The values bound to the components' parameters in an SSP package, by component name
    (read with fmpy's SSD reader, which validates against the SSP 1.0 schema)."""

    bound: dict[str, dict[str, float | bool]] = {}
    for component in read_ssd(os.fspath(path)).system.elements:
        for binding in component.parameterBindings:
            for values in binding.parameterValues:
                for p in values.parameters:
                    value = p.value == "true" if p.type == "Boolean" else float(p.value)
                    bound.setdefault(component.name, {})[p.name] = value
    return bound


def package_fmi_version(ssp_path: str | os.PathLike) -> int:
    """FMI major version of the FMUs in an SSP package (all the same in ours)."""
    with zipfile.ZipFile(ssp_path) as zf:
        ssd = ET.fromstring(zf.read(SSD_FILE))
        versions = set()
        for component in ssd.iter(_q("ssd:Component")):
            with zf.open(component.get("source")) as handle, zipfile.ZipFile(handle) as fmu:
                versions.add(
                    int(ET.fromstring(fmu.read("modelDescription.xml")).get("fmiVersion")[0])
                )
    if len(versions) != 1:
        raise InputError(f"{ssp_path}: components of FMI versions {sorted(versions)}")
    return versions.pop()


def held_samples(move: Move, step_s: float, n_steps: int) -> np.ndarray:
    """What a host that copies values at communication points k * step_s feeds the part:
    the source's output there (the samples of ``move``, linear between them, 0 after),
    (n_steps + 1, 3) m/s^2."""
    t = step_s * np.arange(n_steps + 1)
    grid = move.dt_s * np.arange(move.acc.shape[0])
    return np.column_stack([np.interp(t, grid, move.acc[:, i], right=0.0) for i in range(3)])


def steps_for(stop_time_s: float, step_s: float) -> int:
    """Communication steps of ``step_s`` that reach ``stop_time_s`` (rounded to the grid)."""
    return max(1, math.ceil(stop_time_s / step_s - 1e-9))
