"""The tool chain of the FMU binaries: the C sources' folder, the FMI headers (shipped with
fmpy), the targets (this machine's, and Windows x86_64 when mingw-w64 is installed) and the
error a missing or failing compiler raises. The lowest module of fmu's build: fmu.build
compiles with it, fmu.harness and fmu.binary_check load and check what it built."""

from __future__ import annotations

import platform
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import fmpy

from jaxflex.errors import JaxflexError

C_DIR = Path(__file__).resolve().parent / "c"
WINDOWS_COMPILER = "x86_64-w64-mingw32-gcc"
MINGW_HINT = "Debian/Ubuntu: apt-get install gcc-mingw-w64-x86-64"


class FmuBuildError(JaxflexError):
    """The C compiler is missing or failed."""


@dataclass(frozen=True)
class Target:
    """One binary: platform folder names for FMI 2 / FMI 3, compiler, file suffix, flags."""

    fmi2_dir: str
    fmi3_dir: str
    compiler: str
    suffix: str
    flags: tuple[str, ...]

    def folder(self, fmi_version: int) -> str:
        return self.fmi2_dir if fmi_version == 2 else self.fmi3_dir


def fmi_headers() -> Path:
    """Directory with the FMI 2.0 and 3.0 C headers (shipped with fmpy)."""
    path = Path(fmpy.__file__).resolve().parent / "c-code"
    if not (path / "fmi2Functions.h").is_file() or not (path / "fmi3Functions.h").is_file():
        raise FmuBuildError(f"FMI C headers not found in {path}; reinstall fmpy")
    return path


def host_target(compiler: str = "gcc") -> Target:
    """The binary for this machine (Linux x86_64 or aarch64)."""
    machine = platform.machine().lower()
    if sys.platform.startswith("linux") and machine in ("x86_64", "amd64"):
        return Target("linux64", "x86_64-linux", compiler, ".so", ("-fPIC", "-shared"))
    if sys.platform.startswith("linux") and machine in ("aarch64", "arm64"):
        return Target("aarch64-linux", "aarch64-linux", compiler, ".so", ("-fPIC", "-shared"))
    raise FmuBuildError(
        f"building FMU binaries on {sys.platform}/{machine} is not supported; build from the "
        "FMU's sources/ folder with your platform's compiler instead"
    )


def windows_target() -> Target | None:
    """The Windows x86_64 DLL target when the mingw-w64 cross compiler is installed."""
    if shutil.which(WINDOWS_COMPILER) is None:
        return None
    # the same DLL from the same sources: no time stamp, no image base from the output path
    flags = ("-shared", "-static-libgcc", "-Wl,--no-insert-timestamp,--disable-auto-image-base")
    return Target("win64", "x86_64-windows", WINDOWS_COMPILER, ".dll", flags)
