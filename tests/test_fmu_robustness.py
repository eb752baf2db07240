"""The FMU never crashes its host: bad inputs are rejected with fmi2Error/fmi3Error and a
logged message (state untouched), missing or damaged resources make instantiation return
NULL with a message, every resource-location form an importer may pass is understood, calls
out of order are refused, and a valgrind run finds no memory errors and no leaks."""

from __future__ import annotations

import ctypes
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from conftest import random_model
from fmpy.fmi1 import FMICallException
from test_fmu_export import smooth_profile

import jaxflex
from fmu import export_fmu
from fmu.bench.steps import run
from fmu.harness import compile_harness, resource_location, unpack
from fmu.master import Session
from fmu.options import Fmi

DT = 0.01


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """FMI 2.0 and 3.0 FMUs with an embedded move: (fmu path, extracted folder, token)."""
    out = tmp_path_factory.mktemp("fmu_robust")
    part = random_model(5, n_points=25, n_modes=5)
    built = {}
    for version in (2, 3):
        path = out / f"r{version}.fmu"
        move = jaxflex.as_move(smooth_profile(3, 40), DT)
        result = export_fmu(part, path, move, fmi=Fmi(version), threshold_m=0.01)
        folder = out / f"x{version}"
        with zipfile.ZipFile(path) as zf:
            zf.extractall(folder)
        built[version] = (path, folder, result.token)
    return built


def _library(folder: Path, version: int) -> Path:
    plat = "linux64" if version == 2 else "x86_64-linux"
    return next((folder / "binaries" / plat).glob("*.so"))


class RawFmu:
    """Direct calls into the FMU library with any resource location, collecting messages."""

    def __init__(self, folder: Path, version: int) -> None:
        self.version = version
        self.messages: list[str] = []
        self.lib = ctypes.CDLL(str(_library(folder, version)))
        s, i, p = ctypes.c_char_p, ctypes.c_int, ctypes.c_void_p
        if version == 2:
            from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
            from fmpy.logging import addLoggerProxy

            self.callbacks = fmi2CallbackFunctions()
            self.callbacks.logger = fmi2CallbackLoggerTYPE(self._log2)
            addLoggerProxy(ctypes.byref(self.callbacks))
            self._prototype("fmi2Instantiate", [s, i, s, s, p, i, i])
        else:
            from fmpy.fmi3 import fmi3LogMessageCallback

            self.log3 = fmi3LogMessageCallback(self._log3)
            cb, b, n = fmi3LogMessageCallback, ctypes.c_bool, ctypes.c_size_t
            self._prototype("fmi3InstantiateCoSimulation", [s, s, s, b, b, b, b, p, n, p, cb, p])
            self._prototype("fmi3InstantiateModelExchange", [s, s, s, b, b, p, cb])

    def _prototype(self, name: str, argtypes: list) -> None:
        fn = getattr(self.lib, name)
        fn.argtypes, fn.restype = argtypes, ctypes.c_void_p

    def _log2(self, env, name, status, category, message):
        self.messages.append(message.decode())

    def _log3(self, env, status, category, message):
        self.messages.append(message.decode())

    def instantiate(self, location: str | None, token: str, *, kind: int = 1):
        loc = None if location is None else location.encode()
        if self.version == 2:
            return self.lib.fmi2Instantiate(
                b"raw", kind, token.encode(), loc, ctypes.byref(self.callbacks), 0, 0
            )
        args = (b"raw", token.encode(), loc, 0, 0)
        if kind == 0:
            return self.lib.fmi3InstantiateModelExchange(*args, None, self.log3)
        return self.lib.fmi3InstantiateCoSimulation(*args, 0, 0, None, 0, None, self.log3, None)

    def free(self, instance) -> None:
        getattr(self.lib, f"fmi{self.version}FreeInstance")(ctypes.c_void_p(instance))


def _session(fmus, version, **kwargs) -> Session:
    path, folder, _ = fmus[version]
    return Session(path, unzip_dir=folder, **kwargs)


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_input_is_rejected_and_the_state_untouched(fmus, version, bad):
    steps = 20
    with _session(fmus, version) as clean:
        clean.start(0.0)
        for k in range(steps):
            clean.set_inputs([0.5 * k, -1.0, 2.0])
            clean.step(k * DT, DT)
        expected = clean.get("deviation")
    with _session(fmus, version) as s:
        s.start(0.0)
        for k in range(steps):
            s.set_inputs([0.5 * k, -1.0, 2.0])
            with pytest.raises(FMICallException):  # all three values rejected together
                s.set_inputs([1.0, bad, 1.0])
            assert s.get("ax") == 0.5 * k
            s.step(k * DT, DT)
        assert s.get("deviation") == expected
        errors = [m for level, m in s.messages if level == "ERROR"]
    assert len(errors) == steps and all("ay" in m and "not finite" in m for m in errors)


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        ("threshold", 0.0, "threshold"),
        ("threshold", float("nan"), "threshold"),
        ("damping_scale", -0.5, "damping_scale"),
        ("damping_scale", 1e3, "below 1"),
        ("deviation", 1.0, "cannot set"),
    ],
)
def test_bad_parameter_values_are_rejected(fmus, version, name, value, message):
    with _session(fmus, version) as s:
        s.start(0.0)
        before = s.get(name)
        with pytest.raises(FMICallException):
            s.set(name, value)
        assert s.get(name) == before
        assert any(message in m for _, m in s.messages)


@pytest.mark.parametrize("version", [2, 3])
def test_bad_steps_and_calls_out_of_order_are_refused(fmus, version):
    with _session(fmus, version) as s:
        with pytest.raises(FMICallException):
            s.step(0.0, DT)  # before initialization
        s.start(0.0)
        for h in (0.0, -DT, float("nan"), float("inf")):
            with pytest.raises(FMICallException):
                s.step(0.0, h)
        with pytest.raises(FMICallException):
            s.set("use_embedded_trajectory", True)  # fixed parameter, after initialization
        s.step(0.0, DT)  # still usable
        messages = " ".join(m for _, m in s.messages)
    assert "not allowed in the current state" in messages
    assert "finite number > 0" in messages and "fixed parameter" in messages


def test_fmi2_input_derivatives_are_checked(fmus):
    with _session(fmus, 2) as s:
        s.start(0.0)
        for rate in ([0.0, float("nan"), 0.0], [float("inf")] * 3):
            with pytest.raises(FMICallException):
                s.set_inputs([0.0, 0.0, 0.0], rate)
        assert any("time derivative of input" in m for _, m in s.messages)


@pytest.mark.parametrize("version", [2, 3])
def test_unsupported_functions_log_and_return_an_error(fmus, version):
    raw = RawFmu(fmus[version][1], version)
    location = resource_location(version, fmus[version][1] / "resources")
    inst = raw.instantiate(location, fmus[version][2])
    state = ctypes.c_void_p()
    assert (
        getattr(raw.lib, f"fmi{version}GetFMU{'s' if version == 2 else 'S'}tate")(
            ctypes.c_void_p(inst), ctypes.byref(state)
        )
        == 3
    )  # fmiError
    assert raw.messages[-1].endswith("is not supported by this co-simulation FMU")
    raw.free(inst)
    assert raw.instantiate(location, fmus[version][2], kind=0) is None  # model exchange
    assert "co-simulation only" in raw.messages[-1]


def _resources_copy(fmus, version, tmp_path, name="res") -> Path:
    target = tmp_path / name
    shutil.copytree(fmus[version][1] / "resources", target)
    return target


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda p: p.unlink(), "cannot open the resource file"),
        (lambda p: p.write_bytes(p.read_bytes()[:-100]), "truncated"),
        (lambda p: p.write_bytes(b""), "not a jaxflex FMU resource"),
        (
            lambda p: p.write_bytes((b := p.read_bytes())[:300] + bytes([b[300] ^ 1]) + b[301:]),
            "CRC-32",
        ),
        (
            lambda p: p.write_bytes((b := p.read_bytes())[:17] + b"Z" + b[18:]),
            "belongs to another FMU",
        ),
    ],
    ids=["missing", "truncated", "empty", "bit-flip", "other-token"],
)
def test_missing_or_damaged_resource_gives_null_with_a_message(
    fmus, version, tmp_path, damage, message
):
    res = _resources_copy(fmus, version, tmp_path)
    damage(res / "jaxflex_model.bin")
    raw = RawFmu(fmus[version][1], version)
    assert raw.instantiate(resource_location(version, res), fmus[version][2]) is None
    assert any(message in m for m in raw.messages), raw.messages


@pytest.mark.parametrize("version", [2, 3])
def test_wrong_token_or_no_location_gives_null(fmus, version):
    raw = RawFmu(fmus[version][1], version)
    location = resource_location(version, fmus[version][1] / "resources")
    assert raw.instantiate(location, "{00000000-0000-0000-0000-000000000000}") is None
    assert "does not match this FMU" in raw.messages[-1]
    assert raw.instantiate(None, fmus[version][2]) is None
    assert "no resource location" in raw.messages[-1]


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize(
    ("form", "ok"),
    [
        (lambda p: p.as_uri() + "/", True),  # file:///dir/ (FMI 2.0 standard form)
        (lambda p: p.as_uri(), True),  # without the trailing slash
        (lambda p: "file:" + p.as_posix() + "/", True),  # file:/dir/
        (lambda p: "file://localhost" + p.as_posix() + "/", True),
        (lambda p: re.sub("%[0-9A-F]{2}", lambda m: m[0].lower(), p.as_uri()) + "/", True),
        (lambda p: str(p) + "/", True),  # plain path (FMI 3.0 standard form)
        (lambda p: str(p), True),
        (lambda p: "file://otherhost" + p.as_posix() + "/", False),
        (lambda p: "http://example.com/resources/", False),
        (lambda p: p.as_uri() + "%G1/", False),
    ],
    ids=[
        "file-uri",
        "file-uri-no-slash",
        "file-single-slash",
        "localhost",
        "lowercase-escapes",
        "path",
        "path-no-slash",
        "remote-host",
        "http",
        "bad-escape",
    ],
)
def test_resource_location_forms(fmus, version, tmp_path, form, ok):
    """Percent-encoding is exercised by a folder name with a space and a non-ASCII letter."""
    res = _resources_copy(fmus, version, tmp_path, name="my res é")
    assert "my%20res%20%C3%A9" in res.as_uri()
    raw = RawFmu(fmus[version][1], version)
    inst = raw.instantiate(form(res), fmus[version][2])
    assert (inst is not None) == ok, raw.messages
    if inst is not None:
        raw.free(inst)
    else:
        assert raw.messages


def _harness_args(fmus, version, tmp_path) -> list[str]:
    _, folder, token = fmus[version]
    harness = compile_harness(version, tmp_path / f"harness{version}")
    location = resource_location(version, folder / "resources")
    return [str(harness), str(_library(folder, version)), location, token, "check", "200", "0.01"]


@pytest.mark.parametrize("version", [2, 3])
def test_life_cycle_in_c_two_instances_nan_reset(fmus, version, tmp_path):
    proc = subprocess.run(_harness_args(fmus, version, tmp_path), capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert '"checks": "passed"' in proc.stdout


@pytest.mark.parametrize("version", [2, 3])
def test_valgrind_finds_no_errors_and_no_leaks(fmus, version, tmp_path):
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind is not installed")
    cmd = [
        "valgrind",
        "--leak-check=full",
        "--show-leak-kinds=definite,indirect,possible",
        "--errors-for-leak-kinds=definite,indirect,possible",
        "--error-exitcode=99",
        *_harness_args(fmus, version, tmp_path),
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "ERROR SUMMARY: 0 errors from 0 contexts" in proc.stderr
    assert "All heap blocks were freed -- no leaks are possible" in proc.stderr


def test_benchmark_runs_at_small_size():
    """fmu.bench.steps at a toy size (speed targets are benchmark figures, not asserted here)."""
    report = run(n_points=40, n_modes=8, n_steps=300, repeats=3, fmi_versions=(3,))
    figures = report["fmi3"]
    assert figures["n_steps"] == 300 and np.isfinite(figures["checksum"])
    assert 0 < figures["step_us_min"] <= figures["step_us_median"]
    assert figures["resource_bytes"] == 128 + 8 * (5 * 8 + 3 * 8 * 40 + 3 * 40) + 8


def test_unpack_finds_library_and_token(fmus, tmp_path):
    library, resources, token = unpack(fmus[3][0], tmp_path / "u")
    assert library.is_file() and (resources / "jaxflex_model.bin").is_file()
    assert token == fmus[3][2]
