"""Co-simulation engines nobody here wrote, driving the exported FMUs and SSP packages.

* ``ecospy`` (Ecos, PyPI; needs the TBB runtime, Debian ``libtbb12``): FMI 2.0 and 3.0 FMUs
  and SSP 1.0 packages.
* ``libcosimpy`` (Open Simulation Platform's libcosim, PyPI, Linux/Windows x86_64): FMI 2.0
  FMUs and SSP packages. libcosimpy 0.0.6 crashes the process (SIGSEGV in
  ``CosimExecution.add_local_slave``) when it is given an FMI 3.0 FMU, so FMI 3.0 is refused
  here before libcosim sees it.
* fmpy's ``fmpy.ssp.simulation.simulate_ssp``: SSP packages of FMI 1.0/2.0 FMUs.

All three are fixed-step Jacobi masters that copy output values to connected inputs after
every step: an input is held over the step (no input derivatives), so the part FMU fed by
the trajectory source sees each acceleration sample held for one step.

Every runner returns ``{"time": (n,), name: (n,)}``: the communication points it reports and
the named outputs there (``deviation``, ``settle_time``, ``settled`` of an FMU; for an SSP,
``part.deviation`` etc. named ``<component>.<variable>``).

ecospy and libcosimpy are optional (the dev extra installs them where they exist): they are
imported where they are used, and a missing one is reported as a skipped host.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import shutil
import sys
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Iterator

import numpy as np
from fmpy.ssp.simulation import simulate_ssp
from fmpy.ssp.ssd import Parameter, ParameterSet

from fmu.ssp import package_fmi_version, read_parameters
from jaxflex.errors import InputError

REAL_OUTPUTS = ("deviation", "settle_time")
BOOL_OUTPUTS = ("settled",)
_ECOS_HINT = (
    "pip install ecospy; it needs the TBB runtime (Debian/Ubuntu: apt-get install libtbb12)"
)


def ecospy_unavailable() -> str | None:
    """Why ecospy cannot be used here, or None when it loads."""
    try:
        import ecospy  # noqa: F401  (loads libecosc, which needs libtbb.so.12)
    except (ImportError, OSError) as exc:
        return f"ecospy cannot be loaded ({exc}); {_ECOS_HINT}"
    return None


def libcosimpy_unavailable() -> str | None:
    """Why libcosimpy cannot be used here, or None when it loads."""
    try:
        from libcosimpy.CosimExecution import CosimExecution  # noqa: F401
    except (ImportError, OSError) as exc:
        return f"libcosimpy cannot be loaded ({exc}); pip install libcosimpy (Linux/Windows x86_64)"
    return None


def fmi_version_of(fmu_path: str | os.PathLike) -> int:
    """FMI major version of an FMU (2 or 3), from its modelDescription.xml."""
    with zipfile.ZipFile(fmu_path) as zf:
        root = ET.fromstring(zf.read("modelDescription.xml"))
    return int(root.get("fmiVersion", "0")[0])


@contextlib.contextmanager
def _c_stdout_to_stderr() -> Iterator[None]:
    """Ecos's FMU loader (fmi4c) prints progress to the C stdout; send it to stderr so that
    our stdout (reports, JSON) stays clean. POSIX only (elsewhere nothing is redirected)."""
    if os.name != "posix":
        yield
        return
    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        libc.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)


@contextlib.contextmanager
def _own_temp_directory() -> Iterator[None]:
    """Ecos unpacks an SSP package into a folder of the system's temporary directory and
    leaves it there; point its temporary directory (TMPDIR, read by the C++ library at each
    use) at a folder of ours for the call, and remove that folder afterwards."""
    folder = tempfile.mkdtemp(prefix="jaxflex_ecos_")
    saved = os.environ.get("TMPDIR")
    os.environ["TMPDIR"] = folder
    try:
        yield
    finally:
        if saved is None:
            os.environ.pop("TMPDIR", None)
        else:
            os.environ["TMPDIR"] = saved
        shutil.rmtree(folder, ignore_errors=True)


def _stack(rows: list[tuple]) -> dict[str, np.ndarray]:
    names = rows[0]
    return {name: np.asarray([row[i] for row in rows[1:]]) for i, name in enumerate(names)}


def _record_ecos(sim, n_steps: int, prefix: str) -> dict[str, np.ndarray]:
    names = (*REAL_OUTPUTS, *BOOL_OUTPUTS)
    rows: list[tuple] = [("time", *(f"{prefix}{n}" if prefix else n for n in names))]

    def record() -> None:
        reals = [sim.get_real(f"part::{n}") for n in REAL_OUTPUTS]
        bools = [sim.get_bool(f"part::{n}") for n in BOOL_OUTPUTS]
        rows.append((sim.get_time(), *reals, *bools))

    record()
    for _ in range(n_steps):
        sim.step()
        record()
    sim.terminate()
    return _stack(rows)


def ecos_fmu(
    fmu_path: str | os.PathLike, n_steps: int, dt_s: float, start_values: dict | None = None
) -> dict[str, np.ndarray]:
    """The part FMU alone in Ecos (instance ``part``), ``n_steps`` fixed steps of ``dt_s`` s,
    parameters from ``start_values`` (e.g. ``{"use_embedded_trajectory": True}``); outputs
    after initialization and after every step."""
    from ecospy import EcosLib, EcosSimulation, EcosSimulationStructure

    EcosLib.set_log_level("warn")
    with _c_stdout_to_stderr(), EcosSimulationStructure() as structure:
        structure.add_model("part", os.fspath(fmu_path))
        if start_values:
            values = {f"part::{name}": value for name, value in start_values.items()}
            structure.add_parameter_set("start", values)
        with EcosSimulation(structure=structure, step_size=dt_s) as sim:
            sim.init(parameter_set="start" if start_values else None)
            return _record_ecos(sim, n_steps, "")


def ecos_ssp(
    ssp_path: str | os.PathLike, n_steps: int, dt_s: float, parameter_set: str = "case"
) -> dict[str, np.ndarray]:
    """An SSP package in Ecos with its parameter set ``parameter_set`` applied; the part
    component's outputs (``part.deviation``, ...) after initialization and every step."""
    from ecospy import EcosLib, EcosSimulation

    EcosLib.set_log_level("warn")
    with (
        _c_stdout_to_stderr(),
        _own_temp_directory(),
        EcosSimulation(ssp_path=os.fspath(ssp_path), step_size=dt_s) as sim,
    ):
        sim.init(parameter_set=parameter_set)
        return _record_ecos(sim, n_steps, "part.")


def _refuse_fmi3(version: int, what: str, host: str) -> None:
    if version != 2:
        raise InputError(f"{what}: {host} runs FMI 2.0 FMUs only, this is FMI {version}.0")


def _record_libcosim(execution, index: int, n_steps: int, dt_s: float, prefix: str):
    from libcosimpy.CosimObserver import CosimObserver

    refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    names = (*REAL_OUTPUTS, *BOOL_OUTPUTS)
    rows: list[tuple] = [("time", *(f"{prefix}{n}" for n in names))]
    for k in range(n_steps):
        if not execution.step():
            raise RuntimeError(f"libcosim: step {k + 1} failed ({execution.status()})")
        reals = observer.last_real_values(index, [refs[n] for n in REAL_OUTPUTS])
        bools = observer.last_boolean_values(index, [refs[n] for n in BOOL_OUTPUTS])
        rows.append(((k + 1) * dt_s, *reals, *bools))
    return _stack(rows)


def libcosim_fmu(
    fmu_path: str | os.PathLike, n_steps: int, dt_s: float, start_values: dict | None = None
) -> dict[str, np.ndarray]:
    """The part FMU (FMI 2.0) alone in libcosim, ``n_steps`` fixed steps of ``dt_s`` s, Boolean
    or Real parameters from ``start_values``; outputs after every step."""
    _refuse_fmi3(fmi_version_of(fmu_path), str(fmu_path), "libcosim")
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_step_size(step_size=round(dt_s * 1e9))  # ns
    index = execution.add_local_slave(CosimLocalSlave(os.fspath(fmu_path), "part"))
    refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    for name, value in (start_values or {}).items():
        setter = (
            execution.boolean_initial_value
            if isinstance(value, bool)
            else (execution.real_initial_value)
        )
        if not setter(index, refs[name], value):
            raise RuntimeError(f"libcosim: cannot set the start value of {name}")
    return _record_libcosim(execution, index, n_steps, dt_s, "")


def libcosim_ssp(ssp_path: str | os.PathLike, n_steps: int, dt_s: float) -> dict[str, np.ndarray]:
    """An SSP package of FMI 2.0 FMUs in libcosim (fixed step ``dt_s``); the part's outputs
    after every step."""
    _refuse_fmi3(package_fmi_version(ssp_path), str(ssp_path), "libcosim")
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_ssp_file(os.fspath(ssp_path), step_size=round(dt_s * 1e9))
    index = execution.slave_index_from_instance_name("part")
    return _record_libcosim(execution, index, n_steps, dt_s, "part.")


def fmpy_ssp(ssp_path: str | os.PathLike, n_steps: int, dt_s: float) -> dict[str, np.ndarray]:
    """An SSP package of FMI 2.0 FMUs in fmpy's ``simulate_ssp`` (SSD validated against the
    SSP 1.0 schema, parameter bindings applied); the part's outputs after every step."""
    _refuse_fmi3(package_fmi_version(ssp_path), str(ssp_path), "fmpy's simulate_ssp")
    # simulate_ssp applies one set of "<component>.<name>" values, not the bindings it reads
    bound = ParameterSet(name="bindings")
    for component, values in read_parameters(ssp_path).items():
        for name, value in values.items():
            bound.parameters.append(Parameter(name=f"{component}.{name}", value=value))
    result = simulate_ssp(
        os.fspath(ssp_path),
        start_time=0.0,
        stop_time=(n_steps - 0.5) * dt_s,  # its loop runs while time < stop_time
        step_size=dt_s,
        parameter_set=bound,
    )
    names = [f"part.{n}" for n in (*REAL_OUTPUTS, *BOOL_OUTPUTS)]
    # each row holds the outputs after the step that starts at its time
    return {"time": result["time"] + dt_s, **{name: result[name] for name in names}}
