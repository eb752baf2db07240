"""The Windows DLLs inside every FMU: built with mingw-w64, exporting the FMI functions and
importing only Windows system DLLs, and, run under wine by the cross-compiled C harness,
giving the Linux binary's outputs. Without mingw-w64, export says why the DLL is missing."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from conftest import random_model
from test_fmu_export import _exported_functions, smooth_profile

import jaxflex
from fmu import FmuBuildError, export_fmu
from fmu.harness import compile_harness
from fmu.options import Fmi
from fmu.source import export_source_fmu
from fmu.toolchain import fmi_headers
from fmu.windows import (
    SYSTEM_DLLS,
    dll_exports,
    dll_imports,
    missing_tools,
    replay,
)

DT = 0.01
N_STEPS = 120
WINDOWS_FOLDER = {2: "win64", 3: "x86_64-windows"}


def _dll(fmu: Path, version: int, folder: Path) -> Path:
    with zipfile.ZipFile(fmu) as zf:
        (name,) = [n for n in zf.namelist() if n.startswith(f"binaries/{WINDOWS_FOLDER[version]}/")]
        zf.extract(name, folder)
    assert name == f"binaries/{WINDOWS_FOLDER[version]}/{fmu.stem}.dll"
    return folder / name


def _check_dll(fmu: Path, version: int, folder: Path) -> None:
    """Importers resolve every function of the standard; -static-libgcc leaves only DLLs that
    every Windows installation has (kernel32 and the C runtime msvcrt)."""
    dll = _dll(fmu, version, folder)
    header = fmi_headers() / f"fmi{version}Functions.h"
    assert dll_exports(dll) == _exported_functions(header, f"FMI{version}_Export")
    imports = {name.lower() for name in dll_imports(dll)}
    assert imports and imports <= SYSTEM_DLLS


def _check_wine_equals_linux(fmu: Path, harnesses, expected: set[str], folder: Path) -> None:
    """Same C, same gcc version (12) on both sides; only the C runtime differs (msvcrt's
    exp/sin/cos/sqrt against glibc's, each within an ulp or two of the true value), so every
    output agrees to 1e-12 of its peak (measured: bit-identical)."""
    linux = replay(fmu, folder / "linux", harnesses[0], N_STEPS, DT, windows=False)
    windows = replay(fmu, folder / "windows", harnesses[1], N_STEPS, DT, windows=True)
    assert linux.keys() == windows.keys() and expected <= set(linux)
    np.testing.assert_array_equal(windows["time"], linux["time"])
    for name in set(linux) - {"time"}:
        peak = np.abs(linux[name]).max()
        assert peak > 0, name  # the move happens: an output that stays 0 checks nothing
        np.testing.assert_allclose(windows[name], linux[name], rtol=0, atol=1e-12 * peak)


@pytest.mark.parametrize("version", [2, 3])
def test_windows_dlls_export_fmi_import_system_dlls_and_run_like_linux(version, tmp_path):
    """The part (replaying its embedded move; it settles at 0.78 s) and the trajectory source
    (playing the samples), FMI ``version``: the DLL in each, its exports and imports, and its
    outputs over 120 steps of 10 ms through the FMI API, by the C harness built for Windows and
    run under wine against the same harness built for Linux on the .so."""
    missing = missing_tools()
    if missing:
        pytest.skip(f"not installed: {', '.join(missing)} (.ci/run installs them)")
    model = random_model(8, n_points=25, n_modes=5, f_min_hz=2.0, f_max_hz=200, zeta=0.03)
    acc = smooth_profile(4, 40)
    move, fmi = jaxflex.as_move(acc, DT), Fmi(version, windows=True)
    part = export_fmu(model, tmp_path / "part.fmu", move, fmi=fmi, threshold_m=1e-3)
    source = export_source_fmu(tmp_path / "source.fmu", move, version, windows=True)
    harnesses = (
        compile_harness(version, tmp_path / "harness"),
        compile_harness(version, tmp_path / "harness.exe", windows=True),
    )
    outputs = {"part": {"deviation", "settle_time", "settled"}, "source": {"ax", "ay", "az"}}
    for kind, result in (("part", part), ("source", source)):
        assert WINDOWS_FOLDER[version] in result.platforms
        assert result.compiler_messages == ""  # warning-free with both compilers
        _check_dll(result.fmu_path, version, tmp_path / kind)
        _check_wine_equals_linux(result.fmu_path, harnesses, outputs[kind], tmp_path / kind)


def test_export_without_mingw_says_why(tmp_path, monkeypatch):
    """`jaxflex export` on a machine without the cross compiler: auto skips the DLL with the
    reason and the package to install; windows=True refuses."""
    import fmu.build

    real_which = fmu.build.shutil.which
    monkeypatch.setattr(
        fmu.build.shutil,
        "which",
        lambda name: None if name == fmu.build.WINDOWS_COMPILER else real_which(name),
    )
    model = random_model(9, n_points=10, n_modes=3)
    result = export_fmu(model, tmp_path / "w.fmu", fmi=Fmi(3))
    assert result.platforms == ("x86_64-linux",)
    assert "not installed" in result.skipped["x86_64-windows"]
    assert "gcc-mingw-w64-x86-64" in result.skipped["x86_64-windows"]
    with pytest.raises(FmuBuildError, match="gcc-mingw-w64-x86-64"):
        export_fmu(model, tmp_path / "w2.fmu", fmi=Fmi(2, windows=True))
