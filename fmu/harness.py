"""The C harness (fmu/c/harness.c): a small importer that dlopen()s an exported FMU's library,
instantiates it, steps it and prints its outputs or timings. The benchmarks, the robustness
tests and the Windows checks (fmu.windows) drive FMUs through it.
"""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

from fmpy import read_model_description

from fmu.toolchain import C_DIR, WINDOWS_COMPILER, FmuBuildError, fmi_headers, host_target
from jaxflex.isolated import run_child

WINE_HINT = "Debian/Ubuntu: apt-get install gcc-mingw-w64-x86-64 wine64"

# AddressSanitizer and UndefinedBehaviorSanitizer, every finding fatal (the fuzz runs)
SANITIZE_FLAGS = (
    "-fsanitize=address,undefined",
    "-fno-sanitize-recover=all",
    "-fno-omit-frame-pointer",
    "-g",
)


def compile_harness(
    fmi_version: int,
    out_file: Path,
    *,
    windows: bool = False,
    array_points: int | None = None,
    sanitize: bool = False,
    turning: bool = False,
    distance: bool = False,
) -> Path:
    """Build fmu/c/harness.c for FMI ``fmi_version`` into ``out_file``: for this machine, or
    (``windows=True``) as a static Windows x86_64 executable with mingw-w64, run under wine
    by fmu.windows. With ``array_points`` (FMI 3.0) it also reads the displaced-points array
    output (K x 3) after every step. With ``sanitize`` it is instrumented with SANITIZE_FLAGS,
    to load an FMU library built with them. With ``turning`` its bench mode also sets the
    pose inputs of a turning part's FMU (fmu.Turning); with ``distance`` it also
    reads ``min_distance`` (an FMU with obstacles) after every step."""
    if windows and shutil.which(WINDOWS_COMPILER) is None:
        raise FmuBuildError(f"{WINDOWS_COMPILER} is not installed ({WINE_HINT})")
    compiler = WINDOWS_COMPILER if windows else host_target().compiler
    link = ["-static", "-lm"] if windows else ["-ldl", "-lm"]
    array = [f"-DHARNESS_ARRAY_POINTS={array_points}"] if array_points else []
    array += ["-DHARNESS_TURNING"] if turning else []
    array += ["-DHARNESS_DISTANCE"] if distance else []
    cmd = [
        compiler,
        *(SANITIZE_FLAGS if sanitize else ()),
        "-std=c99",
        "-O2",
        "-Wall",
        "-Wextra",
        f"-DHARNESS_FMI={fmi_version}",
        *array,
        f"-I{fmi_headers()}",
        str(C_DIR / "harness.c"),
        "-o",
        str(out_file),
        *link,
    ]
    proc = run_child(cmd, capture_output=True, text=True)  # ends with the command
    if proc.returncode != 0:
        what = "the Windows harness" if windows else "the harness"
        raise FmuBuildError(f"compiling {what} failed:\n{proc.stderr.strip()}")
    return out_file


def unpack(fmu_path: Path, folder: Path) -> tuple[Path, Path, str]:
    """Extract the FMU: (shared library, resources folder, instantiation token)."""
    with zipfile.ZipFile(fmu_path) as zf:
        zf.extractall(folder)
    md = read_model_description(str(folder))
    plat = host_target().folder(int(md.fmiVersion[0]))
    ident = md.coSimulation.modelIdentifier
    return folder / "binaries" / plat / f"{ident}.so", folder / "resources", md.guid


def resource_location(fmi_version: int, resources: Path) -> str:
    """What an importer passes: a file URI (FMI 2.0) or a path ending in '/' (FMI 3.0)."""
    return resources.resolve().as_uri() + "/" if fmi_version == 2 else f"{resources.resolve()}/"
