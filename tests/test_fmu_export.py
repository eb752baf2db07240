"""FMU packaging: archive layout, modelDescription, sizes and token shared by XML, C config
and resource, exported symbols, sources that build on their own, files beside the FMU,
argument checks."""

from __future__ import annotations

import ctypes
import json
import math
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest
from conftest import random_model

import jaxflex
from fmu import FmuBuildError, export_fmu
from fmu.export import model_identifier
from fmu.options import Fmi
from fmu.resource import FORMAT_VERSION, decode_resource, encode_resource
from fmu.toolchain import fmi_headers
from fmu.verify import read_fmu_resource
from jaxflex.errors import InputError, ModelFileError

DT = 0.01


def smooth_profile(seed: int, n_steps: int) -> np.ndarray:
    """A random smooth rest-to-rest acceleration: a few sine harmonics per axis, m/s^2."""
    rng = np.random.default_rng(seed)
    s = np.arange(n_steps + 1) / n_steps
    harmonics = np.sin(np.pi * np.outer(s, np.arange(1, 5)))  # (n+1, 4)
    acc = harmonics @ rng.normal(scale=3.0, size=(4, 3))
    acc[[0, -1]] = 0.0
    return acc


@pytest.fixture(scope="session")
def part():
    return random_model(3, n_points=30, n_modes=6, f_min_hz=0.8, f_max_hz=150, zeta=(0.01, 0.05))


@pytest.fixture(scope="session")
def exported(part, tmp_path_factory):
    """FMI 2.0 with an embedded trajectory, FMI 3.0 without: (result, trajectory) by version.
    Linux binaries only (the Windows DLLs are checked in test_fmu_windows.py)."""
    out = tmp_path_factory.mktemp("fmu_export")
    acc = smooth_profile(1, 60)
    case = {
        "limits": {"vmax_m_s": 2.0, "amax_m_s2": 10.0, "jmax_m_s3": 100.0},
        "cycle_time_s": 1.5,
        "transfer_time_s": 0.6,
        "settle_time_s": 1.5,
        "distance_m": [0.1, 0.2, 0.3],
    }
    return {
        2: (
            export_fmu(
                part,
                out / "part2.fmu",
                jaxflex.as_move(acc, DT),
                fmi=Fmi(2, windows=False),
                threshold_m=2e-3,
                case=case,
            ),
            acc,
        ),
        3: (export_fmu(part, out / "part3.fmu", fmi=Fmi(3, windows=False)), None),
    }


def _names(path: Path) -> set[str]:
    with zipfile.ZipFile(path) as zf:
        return set(zf.namelist())


def _read(path: Path, name: str) -> bytes:
    with zipfile.ZipFile(path) as zf:
        return zf.read(name)


@pytest.mark.parametrize("version", [2, 3])
def test_fmu_validates_clean_and_compiles_warning_free(exported, version):
    from fmpy.validation import validate_fmu

    result, _ = exported[version]
    assert validate_fmu(str(result.fmu_path)) == []
    assert result.compiler_messages == ""
    assert result.platforms == (("linux64",) if version == 2 else ("x86_64-linux",))


@pytest.mark.parametrize("version", [2, 3])
def test_archive_layout(exported, version):
    result, _ = exported[version]
    ident = result.model_identifier
    plat = "linux64" if version == 2 else "x86_64-linux"
    expected = {
        "modelDescription.xml",
        f"binaries/{plat}/{ident}.so",
        "resources/jaxflex_model.bin",
        "sources/jxf_model.h",
        "sources/jxf_core.c",
        "sources/jxf_log.h",
        "sources/jxf_log.c",
        "sources/jxf_text.h",
        "sources/jxf_fmu.h",
        "sources/jxf_fmu.c",
        "sources/jxf_values.c",
        "sources/jxf_blocks.h",
        "sources/jxf_blocks.c",
        "sources/jxf_cell.h",
        "sources/jxf_cell.c",
        "sources/jxf_turning.h",
        "sources/jxf_turning.c",
        "sources/jxf_turn_angle.h",
        "sources/jxf_config.h",
        f"sources/jxf_fmi{version}.c",
    }
    if version == 3:
        expected.add("sources/buildDescription.xml")
    assert _names(result.fmu_path) == expected


def test_token_and_sizes_agree_between_xml_config_and_resource(exported, part):
    for version, (result, acc) in exported.items():
        root = ET.fromstring(_read(result.fmu_path, "modelDescription.xml"))
        token = root.get("guid" if version == 2 else "instantiationToken")
        assert re.fullmatch(r"\{[0-9a-f-]{36}\}", token)
        config = _read(result.fmu_path, "sources/jxf_config.h").decode()
        defines = dict(re.findall(r"#define (JXF_\w+) (.+)", config))
        stored = read_fmu_resource(result.fmu_path)
        n_traj = 0 if acc is None else len(acc)
        assert token == result.token == stored.token == defines["JXF_TOKEN"].strip('"')
        assert int(defines["JXF_N_POINTS"]) == stored.model.n_points == part.n_points
        assert int(defines["JXF_N_MODES"]) == stored.model.n_modes == part.n_modes
        assert int(defines["JXF_N_TRAJ"]) == n_traj
        if version == 3:  # the array outputs declare K x 3
            dims = {
                v.get("name"): [int(d.get("start")) for d in v.findall("Dimension")]
                for v in root.find("ModelVariables")
            }
            assert dims["displaced_points"] == dims["undeformed_points"] == [part.n_points, 3]
    assert exported[2][0].token != exported[3][0].token  # a fresh token per export


def test_value_references_in_config_match_model_description(exported):
    for version, (result, _) in exported.items():
        root = ET.fromstring(_read(result.fmu_path, "modelDescription.xml"))
        vrs = {(v.get("name")): int(v.get("valueReference")) for v in root.find("ModelVariables")}
        config = _read(result.fmu_path, "sources/jxf_config.h").decode()
        table = {name: int(vr) for vr, name in re.findall(r'\{(\d+)u, "(\w+)"\}', config)}
        assert table == vrs, version


def test_resource_round_trip(exported, part):
    result, acc = exported[2]
    stored = read_fmu_resource(result.fmu_path)
    for name in ("freq_hz", "zeta", "gamma", "shapes", "points"):
        np.testing.assert_array_equal(getattr(stored.model, name), getattr(part, name))
    np.testing.assert_array_equal(stored.acc, acc)
    assert stored.dt_s == DT
    assert read_fmu_resource(exported[3][0].fmu_path).acc is None


@pytest.mark.parametrize(
    "damage",
    [
        lambda b: b[:-9],  # truncated
        lambda b: b[:200] + bytes([b[200] ^ 0x40]) + b[201:],  # one bit flipped
        lambda b: b"XXXXXXXX" + b[8:],  # not our format
        lambda b: b[:8] + (FORMAT_VERSION + 1).to_bytes(4, "little") + b[12:],  # newer version
    ],
    ids=["truncated", "bit-flip", "magic", "version"],
)
def test_python_reader_rejects_damaged_resources(part, damage):
    data = encode_resource(part, "{token}")
    with pytest.raises(ModelFileError):
        decode_resource(damage(data))


def _exported_functions(header: Path, macro: str) -> set[str]:
    return set(re.findall(rf"{macro}\s+\w+TYPE\s+(\w+);", header.read_text()))


@pytest.mark.parametrize("version", [2, 3])
def test_exports_every_fmi_function_and_nothing_else(exported, version, tmp_path):
    """fmpy and other importers resolve every function of the standard; -fvisibility=hidden
    keeps the core's own symbols private."""
    if shutil.which("nm") is None:
        pytest.skip("nm (binutils) is not installed")
    result, _ = exported[version]
    plat = "linux64" if version == 2 else "x86_64-linux"
    lib = tmp_path / "lib.so"
    lib.write_bytes(_read(result.fmu_path, f"binaries/{plat}/{result.model_identifier}.so"))
    nm = subprocess.run(
        ["nm", "-D", "--defined-only", str(lib)], capture_output=True, text=True, check=True
    )
    symbols = {line.split()[-1] for line in nm.stdout.splitlines() if " T " in line}
    header = fmi_headers() / f"fmi{version}Functions.h"
    expected = _exported_functions(header, f"FMI{version}_Export")
    assert len(expected) == (44 if version == 2 else 75)  # counted in the headers
    assert symbols == expected


@pytest.mark.parametrize("version", [2, 3])
def test_sources_build_on_their_own(exported, version, tmp_path):
    """What another platform does: compile the files the FMU lists (FMI 3.0: the
    buildDescription.xml, FMI 2.0: CoSimulation/SourceFiles) with the standard headers."""
    result, _ = exported[version]
    with zipfile.ZipFile(result.fmu_path) as zf:
        zf.extractall(tmp_path)
    src = tmp_path / "sources"
    if version == 3:
        config = ET.parse(src / "buildDescription.xml").getroot().find("BuildConfiguration")
        files = [f.get("name") for f in config.iter("SourceFile")]
        libs = [f"-l{lib.get('name')}" for lib in config.iter("Library")]
    else:
        root = ET.parse(tmp_path / "modelDescription.xml").getroot()
        files = [f.get("name") for f in root.iter("File")]
        libs = ["-lm"]
    out = tmp_path / "rebuilt.so"
    cmd = ["gcc", "-std=c99", "-O2", "-fPIC", "-shared", "-fvisibility=hidden"]
    cmd += [f"-I{src}", f"-I{fmi_headers()}", *(str(src / f) for f in files), "-o", str(out)]
    subprocess.run([*cmd, *libs], check=True, capture_output=True)
    lib = ctypes.CDLL(str(out))
    version_fn = getattr(lib, f"fmi{version}GetVersion")
    version_fn.restype = ctypes.c_char_p
    assert version_fn() == f"{version}.0".encode()


def test_model_description_documents_inputs_and_capabilities(exported):
    root2 = ET.fromstring(_read(exported[2][0].fmu_path, "modelDescription.xml"))
    cs = root2.find("CoSimulation")
    assert cs.get("canInterpolateInputs") == "true"
    assert cs.get("canHandleVariableCommunicationStepSize") == "true"
    ax2 = next(v for v in root2.iter("ScalarVariable") if v.get("name") == "ax")
    assert "fmi2SetRealInputDerivatives" in ax2.get("description")
    assert "held constant" in ax2.get("description")
    root3 = ET.fromstring(_read(exported[3][0].fmu_path, "modelDescription.xml"))
    ax3 = next(v for v in root3.find("ModelVariables") if v.get("name") == "ax")
    assert "held constant" in ax3.get("description")
    names3 = {v.get("name") for v in root3.find("ModelVariables")}
    assert "use_embedded_trajectory" not in names3  # exported without a trajectory
    experiment = root2.find("DefaultExperiment")
    assert float(experiment.get("stepSize")) == DT
    assert float(experiment.get("stopTime")) >= 1.5  # covers the case's cycle time


def test_case_files_beside_the_fmu(exported):
    """The input CSV is what fmpy.simulate_fmu takes; the JSON describes the case."""
    from fmpy.util import read_csv

    result, acc = exported[2]
    signal = read_csv(str(result.input_csv))
    assert signal.dtype.names == ("time", "ax", "ay", "az")
    np.testing.assert_allclose(signal["time"], DT * np.arange(len(acc)), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(np.column_stack([signal[c] for c in ("ax", "ay", "az")]), acc)
    case = json.loads(result.case_json.read_text())
    assert case["fmu"] == "part2.fmu" and case["fmi_version"] == 2
    assert case["instantiation_token"] == result.token
    assert case["limits"] == {"vmax_m_s": 2.0, "amax_m_s2": 10.0, "jmax_m_s3": 100.0}
    assert case["threshold_m"] == 2e-3 and case["cycle_time_s"] == 1.5
    assert case["optimisation"] == {"distance_m": [0.1, 0.2, 0.3]}
    assert sorted(p.name for p in result.fmu_path.parent.iterdir()) == [
        "part2.fmu",
        "part2_case.json",
        "part2_input.csv",
        "part3.fmu",
    ]  # nothing else: temporary files are gone


def test_case_times_are_computed_when_missing(part, tmp_path):
    acc = smooth_profile(2, 40)
    threshold_m = 0.05
    result = export_fmu(part, tmp_path / "p.fmu", jaxflex.as_move(acc, DT), threshold_m=threshold_m)
    report = jaxflex.analyze_move(part, acc, DT, threshold_m)
    assert math.isclose(result.case["cycle_time_s"], report.cycle_time_s, rel_tol=1e-12)
    assert result.case["transfer_time_s"] == pytest.approx(40 * DT)
    assert result.case["limits"] is None


def test_failed_export_leaves_existing_fmu_untouched(part, tmp_path, monkeypatch):
    import fmu.export as export_module

    target = tmp_path / "keep.fmu"
    target.write_bytes(b"previous")

    def broken(*args, **kwargs):
        raise FmuBuildError("compiler exploded")

    monkeypatch.setattr(export_module, "build_binaries", broken)
    with pytest.raises(FmuBuildError, match="exploded"):
        export_fmu(part, target)
    assert target.read_bytes() == b"previous"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.fmu"]


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"fmi": 3}, "fmi"),
        ({"outputs": None}, "outputs"),
        ({"turning": True}, "turning"),
        ({"path": "part.zip"}, "path"),
        ({"threshold_m": 0.0}, "threshold_m"),
        ({"threshold_m": float("nan")}, "threshold_m"),
        ({"damping_scale": 30.0}, "damping_scale"),
        ({"damping_scale": -1.0}, "damping_scale"),
        ({"trajectory": jaxflex.Move(np.ones((5, 3)), DT)}, "trajectory acc"),
        ({"trajectory": (np.zeros((5, 3)), DT)}, "trajectory"),
        ({"trajectory": np.zeros((5, 3))}, "trajectory"),
        ({"case": {"cycle_time_s": 1.0}}, "case"),
        ({"model": "model.npz"}, "model"),
    ],
)
def test_export_rejects_bad_arguments(part, tmp_path, kwargs, field):
    args = {"model": part, "path": tmp_path / "p.fmu", **kwargs}
    if "path" in kwargs:
        args["path"] = tmp_path / kwargs["path"]
    with pytest.raises(InputError, match=re.escape(field)):
        export_fmu(**args)
    assert list(tmp_path.iterdir()) == []


def test_model_identifier_is_a_c_identifier():
    assert model_identifier(Path("part-A v2.fmu")) == "part_A_v2"
    assert model_identifier(Path("3d.fmu")) == "_3d"
