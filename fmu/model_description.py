"""modelDescription.xml (FMI 2.0 and 3.0) and buildDescription.xml (FMI 3.0)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from datetime import UTC, datetime

import jaxflex
from fmu.build import compiled_files
from fmu.resource import Counts
from fmu.variables import DIMENSIONS, Variable, input_description, variables_for

LOG_CATEGORIES = (
    ("logStatusError", "Errors: bad inputs or parameters, missing or corrupt resources"),
    ("logStatusWarning", "Warnings: inconsistent communication points"),
    ("logAll", "Debug messages: resource loading, recomputed step matrices"),
)
UNITS = {  # name: SI base-unit exponents (also the SSD's units, fmu.ssp)
    "m": {"m": "1"},
    "s": {"s": "1"},
    "m/s2": {"m": "1", "s": "-2"},
    "rad/s": {"rad": "1", "s": "-1"},
    "rad/s2": {"rad": "1", "s": "-2"},
    "Pa": {"kg": "1", "m": "-1", "s": "-2"},
}


@dataclass(frozen=True)
class Description:
    """What modelDescription.xml states about one export (sizes in points/modes/samples)."""

    fmi_version: int
    model_name: str
    model_identifier: str
    token: str
    description: str
    counts: Counts
    threshold_m: float
    damping_scale: float
    damping_scale_max: float
    start_time_s: float
    stop_time_s: float
    step_s: float

    def size(self, dim) -> int:
        """The size of an array dimension of fmu.variables."""
        return dim if isinstance(dim, int) else getattr(self.counts, DIMENSIONS[dim])


def _fmt(x: float) -> str:
    return repr(float(x))


def unit_definitions(parent: ET.Element, names=None) -> None:
    """The UnitDefinitions element of the units ``names`` (default: every unit an exported
    FMU uses: m, s, m/s2, rad/s, rad/s2, Pa) with their SI base units."""
    units = ET.SubElement(parent, "UnitDefinitions")
    for name, exponents in UNITS.items():
        if names is None or name in names:
            ET.SubElement(ET.SubElement(units, "Unit", name=name), "BaseUnit", exponents)


def _log_categories(parent: ET.Element) -> None:
    cats = ET.SubElement(parent, "LogCategories")
    for name, text in LOG_CATEGORIES:
        ET.SubElement(cats, "Category", name=name, description=text)


def _description_of(v: Variable, d: Description) -> str:
    if v.causality == "input":
        return f"{v.description}; {input_description(d.fmi_version)}"
    return v.description


def _start(v: Variable, d: Description) -> str | None:
    if v.causality == "input":
        return "1.0" if v.name == "quat_w" else "0.0"  # at rest, identity orientation
    return {
        "threshold": _fmt(d.threshold_m),
        "damping_scale": _fmt(d.damping_scale),
        "use_embedded_trajectory": "false",
    }.get(v.name)


def _value_attributes(v: Variable, d: Description) -> dict[str, str]:
    attrs = {}
    start = _start(v, d)
    if start is not None:
        attrs["start"] = start
    if v.unit is not None:
        attrs["unit"] = v.unit
    if v.name == "threshold":
        attrs["min"] = "0.0"
    if v.name == "damping_scale":
        attrs["min"] = "0.0"
        attrs["max"] = _fmt(d.damping_scale_max)
    return attrs


def _variable_attributes(v: Variable, d: Description) -> dict[str, str]:
    attrs = {
        "name": v.name,
        "valueReference": str(v.vr),
        "description": _description_of(v, d),
        "causality": v.causality,
        "variability": v.variability,
    }
    if v.initial is not None and v.causality not in ("input", "parameter"):
        attrs["initial"] = v.initial
    return attrs


def _root(d: Description, token_attribute: str, **extra: str) -> ET.Element:
    return ET.Element(
        "fmiModelDescription",
        {
            "fmiVersion": f"{d.fmi_version}.0",
            "modelName": d.model_name,
            token_attribute: d.token,
            "description": d.description,
            "generationTool": f"jaxflex {jaxflex.__version__}",
            "generationDateAndTime": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "variableNamingConvention": "flat",
            **extra,
        },
    )


def _after_interface(root: ET.Element, d: Description) -> ET.Element:
    """UnitDefinitions, LogCategories, DefaultExperiment; returns the ModelVariables element."""
    unit_definitions(root)
    _log_categories(root)
    ET.SubElement(
        root,
        "DefaultExperiment",
        startTime=_fmt(d.start_time_s),
        stopTime=_fmt(d.stop_time_s),
        stepSize=_fmt(d.step_s),
    )
    return ET.SubElement(root, "ModelVariables")


def cosimulation(
    root: ET.Element,
    fmi_version: int,
    ident: str,
    c_files: tuple[str, ...],
    *,
    output_derivatives: int,
    interpolates_inputs: bool,
) -> ET.Element:
    """The CoSimulation element of a jaxflex FMU (the part's and the trajectory source's:
    the same FMI bindings, so the same capabilities but for the output derivatives' order and
    the FMI 2.0 input derivatives); FMI 2.0 lists the ``c_files`` as its SourceFiles."""
    attrs = {
        "modelIdentifier": ident,
        "canHandleVariableCommunicationStepSize": "true",
        "canBeInstantiatedOnlyOncePerProcess": "false",
        "maxOutputDerivativeOrder": str(output_derivatives),
    }
    if fmi_version == 2:
        attrs |= {
            "needsExecutionTool": "false",
            "canInterpolateInputs": "true" if interpolates_inputs else "false",
            "canRunAsynchronuously": "false",
            "canNotUseMemoryManagementFunctions": "true",
            "canGetAndSetFMUstate": "false",
            "canSerializeFMUstate": "false",
            "providesDirectionalDerivative": "false",
        }
    else:
        attrs |= {
            "canGetAndSetFMUState": "false",
            "canSerializeFMUState": "false",
            "providesDirectionalDerivatives": "false",
            "providesAdjointDerivatives": "false",
            "providesIntermediateUpdate": "false",
            "hasEventMode": "false",
        }
    element = ET.SubElement(root, "CoSimulation", attrs)
    if fmi_version == 2:
        files = ET.SubElement(element, "SourceFiles")
        for name in c_files:
            ET.SubElement(files, "File", name=name)
    return element


def _fmi2(d: Description, variables: list[Variable]) -> ET.Element:
    root = _root(d, "guid", numberOfEventIndicators="0")
    cosimulation(
        root, 2, d.model_identifier, compiled_files(2), output_derivatives=0,
        interpolates_inputs=True,
    )  # fmt: skip
    mv = _after_interface(root, d)
    for v in variables:
        sv = ET.SubElement(mv, "ScalarVariable", _variable_attributes(v, d))
        ET.SubElement(sv, "Real" if v.kind == "real" else "Boolean", _value_attributes(v, d))
    index = {v.name: i + 1 for i, v in enumerate(variables)}
    outputs = [v for v in variables if v.causality == "output"]
    ms = ET.SubElement(root, "ModelStructure")
    out_el = ET.SubElement(ms, "Outputs")
    for v in outputs:  # no direct feedthrough: outputs depend on the state only
        ET.SubElement(out_el, "Unknown", index=str(index[v.name]), dependencies="")
    init_el = ET.SubElement(ms, "InitialUnknowns")
    for v in outputs:
        ET.SubElement(init_el, "Unknown", index=str(index[v.name]))
    return root


def _fmi3(d: Description, variables: list[Variable]) -> ET.Element:
    root = _root(d, "instantiationToken")
    cosimulation(
        root, 3, d.model_identifier, compiled_files(3), output_derivatives=0,
        interpolates_inputs=False,
    )  # fmt: skip
    mv = _after_interface(root, d)
    for v in variables:
        attrs = _variable_attributes(v, d)
        attrs.update(_value_attributes(v, d))
        el = ET.SubElement(mv, "Float64" if v.kind == "real" else "Boolean", attrs)
        for dim in v.dims:
            ET.SubElement(el, "Dimension", start=str(d.size(dim)))
    ms = ET.SubElement(root, "ModelStructure")
    outputs = [v for v in variables if v.causality == "output"]
    for v in outputs:  # no direct feedthrough: outputs depend on the state only
        ET.SubElement(ms, "Output", valueReference=str(v.vr), dependencies="")
    for v in variables:
        if v.causality == "output" or v.causality == "calculatedParameter":
            ET.SubElement(ms, "InitialUnknown", valueReference=str(v.vr))
    return root


def _to_text(root: ET.Element) -> str:
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def model_description(d: Description) -> str:
    """modelDescription.xml text for the FMI version in ``d``."""
    variables = variables_for(d.fmi_version, d.counts.trajectory > 0, d.counts.variable_groups())
    build = _fmi2 if d.fmi_version == 2 else _fmi3
    return _to_text(build(d, variables))


def build_description(model_identifier: str, source_files: tuple[str, ...] | None = None) -> str:
    """sources/buildDescription.xml (FMI 3.0): how to compile ``source_files`` (default: the
    part FMU's) on any platform."""
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    config = ET.SubElement(root, "BuildConfiguration", modelIdentifier=model_identifier)
    files = ET.SubElement(config, "SourceFileSet", language="C99")
    for name in source_files or compiled_files(3):
        ET.SubElement(files, "SourceFile", name=name)
    ET.SubElement(files, "IncludeDirectory", name=".")
    ET.SubElement(config, "Library", name="m", description="C math library (libm)")
    return _to_text(root)
