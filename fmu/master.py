"""A minimal co-simulation master for the exported FMUs, on fmpy's FMU2Slave / FMU3Slave.

``fmpy.simulate_fmu`` covers fixed communication steps with held inputs; this master also
sets input derivatives (FMI 2.0), changes the step size and resets an instance, which is what
a virtual-commissioning tool does. (fmpy 0.3.32's ``simulate_fmu(set_input_derivatives=True)``
only works for FMUs with exactly nine continuous inputs: its Input helper allocates a fixed
nine-slot derivative buffer.)
"""

from __future__ import annotations

import ctypes
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.fmi3 import FMU3Slave
from fmpy.logging import addLoggerProxy

_LABELS = ("OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING")


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
            callbacks = fmi2CallbackFunctions()
            callbacks.logger = fmi2CallbackLoggerTYPE(self._log2)
            callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            addLoggerProxy(ctypes.byref(callbacks))
            self._callbacks = callbacks  # keep alive while the instance exists
            slave = FMU2Slave(**kwargs)
            slave.instantiate(callbacks=callbacks, loggingOn=debug)
        else:
            slave = FMU3Slave(**kwargs)
            slave.instantiate(loggingOn=debug, logMessage=self._log3)
        return slave

    def _log2(self, env, name, status, category, message):
        self.messages.append((_LABELS[status], message.decode("utf-8", "replace")))

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
        """A scalar output or parameter, or a (K, 3) array (FMI 3.0 point coordinates)."""
        var, s = self.variables[name], self._slave
        if var.type == "Boolean":
            return bool(s.getBoolean([var.valueReference])[0])
        if self.fmi_version == 2:
            return s.getReal([var.valueReference])[0]
        if var.dimensions:
            n = int(np.prod([int(d.start) for d in var.dimensions]))
            return np.asarray(s.getFloat64([var.valueReference], n)).reshape(-1, 3)
        return s.getFloat64([var.valueReference])[0]

    def set_inputs(self, acc, rate=None) -> None:
        """Accelerations (3,) m/s^2 at the communication point; ``rate`` (3,) m/s^3 makes them
        linear over the next step (FMI 2.0 input derivatives)."""
        vrs = [self._vr(n) for n in ("ax", "ay", "az")]
        values = [float(a) for a in acc]
        if self.fmi_version == 2:
            self._slave.setReal(vrs, values)
            if rate is not None:
                self._slave.setRealInputDerivatives(vrs, [1, 1, 1], [float(r) for r in rate])
        else:
            if rate is not None:
                raise ValueError("FMI 3.0 has no input derivatives: inputs are held over a step")
            self._slave.setFloat64(vrs, values)

    def step(self, t: float, h: float) -> None:
        self._slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)

    def reset(self) -> None:
        self._slave.reset()

    def close(self) -> None:
        if self._slave is not None:
            self._slave.freeInstance()
            self._slave = None
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def run_linear(session: Session, acc, dt_s: float, n_steps: int) -> dict[str, np.ndarray]:
    """Drive an initialized FMI 2.0 session with samples ``acc`` (linear between them, 0 after
    the last) for ``n_steps`` steps of ``dt_s``: recorded outputs at t_0 .. t_n."""
    acc = np.asarray(acc, dtype=np.float64)
    padded = np.zeros((max(n_steps + 1, len(acc)) + 1, 3))
    padded[: len(acc)] = acc
    rates = np.diff(padded, axis=0) / dt_s
    out = {"time": [], "deviation": [], "settle_time": [], "settled": []}

    def record(t):
        out["time"].append(t)
        for name in ("deviation", "settle_time", "settled"):
            out[name].append(session.get(name))

    record(0.0)
    for k in range(n_steps):
        t = k * dt_s
        session.set_inputs(padded[k], rates[k])
        session.step(t, dt_s)
        record((k + 1) * dt_s)
    return {key: np.asarray(value) for key, value in out.items()}
