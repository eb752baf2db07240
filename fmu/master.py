"""A minimal co-simulation master for the exported FMUs, on fmpy's FMU2Slave / FMU3Slave.

``fmpy.simulate_fmu`` covers fixed communication steps with held inputs; this master also
sets input derivatives (FMI 2.0), changes the step size and resets an instance, which is what
a virtual-commissioning tool does. (fmpy 0.3.32's ``simulate_fmu(set_input_derivatives=True)``
only works for FMUs with exactly nine continuous inputs: its Input helper allocates a fixed
nine-slot derivative buffer.)
"""

from __future__ import annotations

import ctypes
import itertools
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi1 import printLogMessage
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.fmi3 import FMU3Slave
from fmpy.logging import addLoggerProxy

from jaxflex.response import Move

_LABELS = ("OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING")
# FMI 2.0 log messages of open sessions, by the componentEnvironment their instance got
_FMI2_LOGS: dict[int, list[tuple[str, str]]] = {}
_FMI2_KEYS = itertools.count(1)


def _route_fmi2_log(env, name, status, category, message) -> None:
    """The one FMI 2.0 logger of this process. fmpy formats the variadic arguments in a
    native proxy that keeps a single process-wide pointer to the Python logger it wraps, so a
    logger per session would dangle (and crash the next FMU that logs) once its session is
    gone. Messages of our sessions go to their list, any other FMU's are printed as fmpy's
    default logger prints them."""
    messages = _FMI2_LOGS.get(env or 0)
    if messages is None:
        printLogMessage(env, name, status, category, message)
    else:
        messages.append((_LABELS[status], message.decode("utf-8", "replace")))


_FMI2_LOGGER = fmi2CallbackLoggerTYPE(_route_fmi2_log)


class Session:
    """One instance of the FMU at ``fmu`` (.fmu file, or its extracted folder with
    ``unzip_dir``). Log messages are collected in ``messages`` as (status label, text)."""

    def __init__(
        self,
        fmu: str | os.PathLike,
        *,
        unzip_dir: str | os.PathLike | None = None,
        instance_name: str = "jaxflex",
        debug: bool = False,
    ) -> None:
        self.messages: list[tuple[str, str]] = []
        self.description = read_model_description(str(unzip_dir or fmu))
        self.fmi_version = int(self.description.fmiVersion[0])
        self._tmp = None if unzip_dir is not None else extract(str(fmu))
        self.unzip_dir = Path(unzip_dir or self._tmp)
        self.variables = {v.name: v for v in self.description.modelVariables}
        self._slave = None
        try:
            self._slave = self._instantiate(instance_name, debug)
        except Exception:
            self.close()
            raise

    # -- instantiation and logging -------------------------------------------------------
    def _instantiate(self, instance_name: str, debug: bool):
        md = self.description
        kwargs = {
            "guid": md.guid,
            "unzipDirectory": str(self.unzip_dir),
            "modelIdentifier": md.coSimulation.modelIdentifier,
            "instanceName": instance_name,
        }
        if self.fmi_version == 2:
            self._log_key = next(_FMI2_KEYS)
            _FMI2_LOGS[self._log_key] = self.messages
            callbacks = fmi2CallbackFunctions()
            callbacks.logger = _FMI2_LOGGER
            callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            callbacks.componentEnvironment = self._log_key
            addLoggerProxy(ctypes.byref(callbacks))
            self._callbacks = callbacks  # keep alive while the instance exists
            slave = FMU2Slave(**kwargs)
            slave.instantiate(callbacks=callbacks, loggingOn=debug)
        else:
            slave = FMU3Slave(**kwargs)
            slave.instantiate(loggingOn=debug, logMessage=self._log3)
        return slave

    def _log3(self, env, status, category, message):
        self.messages.append((_LABELS[status], message.decode("utf-8", "replace")))

    # -- simulation ----------------------------------------------------------------------
    def start(self, start_time: float = 0.0, start_values: dict[str, Any] | None = None) -> None:
        """Initialization with the given parameter values, then ready for the first step."""
        s = self._slave
        if self.fmi_version == 2:
            s.setupExperiment(startTime=start_time)
            s.enterInitializationMode()
        else:
            s.enterInitializationMode(startTime=start_time)
        for name, value in (start_values or {}).items():
            self.set(name, value)
        s.exitInitializationMode()

    def _vr(self, name: str) -> int:
        if name not in self.variables:
            raise KeyError(f"the FMU has no variable {name!r}")
        return self.variables[name].valueReference

    def set(self, name: str, value: float | bool) -> None:
        var, s = self.variables[name], self._slave
        if var.type == "Boolean":
            s.setBoolean([var.valueReference], [bool(value)])
        elif self.fmi_version == 2:
            s.setReal([var.valueReference], [float(value)])
        else:
            s.setFloat64([var.valueReference], [float(value)])

    def get(self, name: str) -> Any:
        """A scalar output or parameter, or an array of its declared dimensions (FMI 3.0)."""
        var, s = self.variables[name], self._slave
        if var.type == "Boolean":
            return bool(s.getBoolean([var.valueReference])[0])
        if self.fmi_version == 2:
            return s.getReal([var.valueReference])[0]
        if var.dimensions:
            dims = [int(d.start) for d in var.dimensions]
            return np.asarray(s.getFloat64([var.valueReference], int(np.prod(dims)))).reshape(dims)
        return s.getFloat64([var.valueReference])[0]

    def set_inputs(self, acc, rate=None, names=("ax", "ay", "az")) -> None:
        """Accelerations (3,) m/s^2 at the communication point; ``rate`` (3,) m/s^3 makes them
        linear over the next step (FMI 2.0 input derivatives). Other inputs by their
        ``names`` (a turning part's pose: fmu.variables.POSE_INPUT_NAMES)."""
        vrs = [self._vr(n) for n in names]
        values = [float(a) for a in acc]
        if self.fmi_version == 2:
            self._slave.setReal(vrs, values)
            if rate is not None:
                orders = [1] * len(vrs)
                self._slave.setRealInputDerivatives(vrs, orders, [float(r) for r in rate])
        else:
            if rate is not None:
                raise ValueError("FMI 3.0 has no input derivatives: inputs are held over a step")
            self._slave.setFloat64(vrs, values)

    def output_rates(self, names) -> np.ndarray:
        """First time derivatives of the named Real outputs at the communication point
        (fmi2GetRealOutputDerivatives / fmi3GetOutputDerivatives), one per name."""
        vrs = [self._vr(n) for n in names]
        if self.fmi_version == 2:
            return np.asarray(self._slave.getRealOutputDerivatives(vrs, [1] * len(vrs)))
        return np.asarray(self._slave.getOutputDerivatives(vrs, [1] * len(vrs)))

    def step(self, t: float, h: float) -> None:
        self._slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)

    def reset(self) -> None:
        self._slave.reset()

    def close(self) -> None:
        if self._slave is not None:
            self._slave.freeInstance()
            self._slave = None
        _FMI2_LOGS.pop(getattr(self, "_log_key", 0), None)
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def run_linear(session: Session, move: Move, n_steps: int) -> dict[str, np.ndarray]:
    """Drive an initialized FMI 2.0 session with the samples of ``move`` (a jaxflex.Move;
    linear between them, 0 after the last) for ``n_steps`` steps of its ``dt_s``: recorded
    outputs at t_0 .. t_n."""
    acc, dt_s = move.acc, move.dt_s
    padded = np.zeros((max(n_steps + 1, len(acc)) + 1, 3))
    padded[: len(acc)] = acc
    rates = np.diff(padded, axis=0) / dt_s
    out = _record(session, 0.0)
    for k in range(n_steps):
        t = k * dt_s
        session.set_inputs(padded[k], rates[k])
        session.step(t, dt_s)
        _record(session, (k + 1) * dt_s, out)
    return {key: np.asarray(value) for key, value in out.items()}


def _record(session: Session, t: float, out: dict | None = None) -> dict[str, list]:
    """Append the time and the part's outputs to ``out`` (a new record when None)."""
    out = (
        out if out is not None else {"time": [], "deviation": [], "settle_time": [], "settled": []}
    )
    out["time"].append(t)
    for name in ("deviation", "settle_time", "settled"):
        out[name].append(session.get(name))
    return out


def run_chained(
    source: Session,
    part: Session,
    dt_s: float,
    n_steps: int,
    *,
    forward_rates: bool,
    names: tuple[str, ...] = ("ax", "ay", "az"),
) -> dict[str, np.ndarray]:
    """Drive the initialized ``part`` with the outputs ``names`` (default ax, ay, az; a
    turning move's source: its pose too) of the initialized trajectory ``source`` for
    ``n_steps`` steps of ``dt_s``, as a master of a connected system does: values at each
    communication point, and with ``forward_rates`` (FMI 2.0) their time derivatives as the
    part's input derivatives, so the part sees the source's signal reach its next sample at
    the end of each step instead of held values. Recorded outputs at t_0 .. t_n."""
    out = _record(part, 0.0)
    for k in range(n_steps):
        t = k * dt_s
        values = [source.get(name) for name in names]
        part.set_inputs(values, source.output_rates(names) if forward_rates else None, names)
        source.step(t, dt_s)
        part.step(t, dt_s)
        _record(part, (k + 1) * dt_s, out)
    return {key: np.asarray(value) for key, value in out.items()}
