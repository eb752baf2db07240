"""A built FMU binary is checked in place before the FMU is reported valid (fmu.build): the
host library loads, exports every function of its FMI version (the standard's headers list
them), and one communication step of the part agrees with the engine on the model in the
FMU's own resource; a Windows DLL exports every function (its export table). The library is
loaded in a child process, so that a broken binary cannot take the export down with it.

The step: from rest, the inputs ax, ay, az held at STEP_ACC_M_S2 over one step of the FMU's
default step size, its deviation output against jaxflex's exact zero-order-hold response
(fmu.verify.reference_response) to DEFAULT_RTOL, as fmu.verify compares whole runs.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from functools import cache
from pathlib import Path

from fmu.toolchain import FmuBuildError, fmi_headers

STEP_ACC_M_S2 = (0.3, -0.2, 1.0)  # the held inputs ax, ay, az of the checked step
CHECK_TIMEOUT_S = 120.0
VR_INPUTS = (1, 2, 3)  # ax, ay, az (fmu.variables)
VR_DEVIATION = 10

# the child: load the library and look every function up; then (argument "step") run one
# step through fmpy's slave of the FMU folder and print its deviation (JSON on stdout)
_CHILD = """
import ctypes, json, sys
folder, library, names, step = sys.argv[1], sys.argv[2], sys.argv[3].split(","), sys.argv[4]
lib = ctypes.CDLL(library)
missing = [name for name in names if not hasattr(lib, name)]
if missing or step == "no":
    print(json.dumps({"missing": missing}))
    sys.exit(0)
from fmpy import read_model_description
md = read_model_description(folder)
ident, dt = md.coSimulation.modelIdentifier, float(md.defaultExperiment.stepSize)
inputs, acc = [1, 2, 3], [float(v) for v in step.split(",")]
if md.fmiVersion.startswith("2"):
    from fmpy.fmi2 import FMU2Slave
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=ident,
                    instanceName="jaxflex_check")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.setReal(inputs, acc)
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=dt)
    deviation = fmu.getReal([10])[0]
else:
    from fmpy.fmi3 import FMU3Slave
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=ident,
                    instanceName="jaxflex_check")
    fmu.instantiate()
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    fmu.setFloat64(inputs, acc)
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=dt)
    deviation = fmu.getFloat64([10])[0]
fmu.terminate()
fmu.freeInstance()
print(json.dumps({"missing": [], "deviation": deviation, "dt_s": dt}))
"""


@cache
def fmi_functions(fmi_version: int) -> tuple[str, ...]:
    """Every function of FMI ``fmi_version`` (2 or 3), as fmpy's copy of the standard's
    header declares them (``#define fmi2DoStep fmi2FullName(fmi2DoStep)``)."""
    header = (fmi_headers() / f"fmi{fmi_version}Functions.h").read_text(encoding="utf-8")
    names = re.findall(rf"#define\s+(fmi{fmi_version}\w+)\s+fmi{fmi_version}FullName\(", header)
    if not names:
        raise FmuBuildError(f"no FMI {fmi_version} functions found in the FMI headers")
    return tuple(sorted(set(names)))


def check_library(folder: Path, library: Path, fmi_version: int, *, step: bool) -> None:
    """FmuBuildError unless the host ``library`` of the FMU staged in ``folder`` loads and
    exports every FMI function and (``step``: the part's) one step agrees with the engine."""
    folder, library = folder.resolve(), library.resolve()
    names = fmi_functions(fmi_version)
    acc = ",".join(repr(v) for v in STEP_ACC_M_S2) if step else "no"
    command = [sys.executable, "-c", _CHILD, str(folder), str(library), ",".join(names), acc]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=CHECK_TIMEOUT_S)
    except subprocess.TimeoutExpired as exc:
        raise FmuBuildError(f"{library.name}: no answer within {CHECK_TIMEOUT_S:g} s") from exc
    if done.returncode != 0:
        why = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
        raise FmuBuildError(f"{library.name} does not load or run: {why}")
    answer = json.loads(done.stdout.strip().splitlines()[-1])
    if answer["missing"]:
        missing = answer["missing"]
        raise FmuBuildError(
            f"{library.name} lacks {len(missing)} of the {len(names)} FMI {fmi_version} "
            f"functions ({', '.join(missing[:3])}{', ...' if len(missing) > 3 else ''})"
        )
    if step:
        _check_step(folder, library, answer["deviation"], answer["dt_s"])


def _check_step(folder: Path, library: Path, deviation_m: float, dt_s: float) -> None:
    """The step's deviation against jaxflex's on the model in the FMU's resource."""
    import numpy as np

    from fmu.resource import decode_resource
    from fmu.variables import RESOURCE_FILE
    from fmu.verify import DEFAULT_RTOL, reference_response, simulated_model
    from jaxflex.response import as_move

    resource = folder / "resources" / RESOURCE_FILE
    stored = decode_resource(resource.read_bytes(), source=str(resource))
    acc = np.array([STEP_ACC_M_S2, (0.0, 0.0, 0.0)])
    model = simulated_model(stored, folder)
    reference = float(reference_response(model, as_move(acc, dt_s), 1, hold="zero")[0][1])
    if not abs(deviation_m - reference) <= DEFAULT_RTOL * abs(reference):
        raise FmuBuildError(
            f"{library.name}: one step gives a deviation of {deviation_m!r} m, jaxflex "
            f"{reference!r} m (tolerance {DEFAULT_RTOL:g} relative)"
        )


def check_dll(dll: Path, fmi_version: int) -> None:
    """FmuBuildError unless the Windows ``dll`` exports every FMI function (its export
    table, read with mingw-w64's objdump; not loaded: that needs wine)."""
    from fmu.windows import dll_exports

    missing = sorted(set(fmi_functions(fmi_version)) - dll_exports(dll))
    if missing:
        raise FmuBuildError(
            f"{dll.name} lacks {len(missing)} FMI {fmi_version} functions "
            f"({', '.join(missing[:3])}{', ...' if len(missing) > 3 else ''})"
        )
