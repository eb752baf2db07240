"""The FMU's Windows DLL, checked on Linux: its exports and imported DLLs (mingw-w64's
objdump) and its outputs, from the C harness (fmu/c/harness.c) cross-compiled to a Windows
executable and run under wine, beside the same harness built natively for the Linux binary.

Wine runs in ``$WINEPREFIX`` when set, otherwise in ``~/.cache/jaxflex/wine`` (created on
first use, ~10 s), with its debug output off. Paths are handed to the Windows side on wine's
``Z:`` drive, which maps the Unix root in every default prefix.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path, PureWindowsPath

import numpy as np
from fmpy import read_model_description

from fmu.harness import WINE_HINT, resource_location, unpack
from fmu.toolchain import WINDOWS_COMPILER, FmuBuildError
from jaxflex.isolated import run_child

OBJDUMP = "x86_64-w64-mingw32-objdump"
WINE_TIMEOUT_S = 600.0  # the first run creates the wine prefix
_WINE64_LOADER = Path("/usr/lib/wine/wine64")  # Debian's wine64 package without the wrapper
# DLLs present on every Windows installation (the C runtime msvcrt.dll included)
SYSTEM_DLLS = frozenset({"kernel32.dll", "msvcrt.dll", "ntdll.dll", "user32.dll", "advapi32.dll"})


def wine_command() -> list[str] | None:
    """How to start a Windows x86_64 program here (``wine64``, ``wine``, or Debian's loader),
    or None when wine is not installed."""
    for name in ("wine64", "wine"):
        if found := shutil.which(name):
            return [found]
    return [str(_WINE64_LOADER)] if _WINE64_LOADER.is_file() else None


def missing_tools() -> list[str]:
    """The tools :func:`replay` needs for the Windows DLL that are not installed."""
    missing = [tool for tool in (WINDOWS_COMPILER, OBJDUMP) if shutil.which(tool) is None]
    return missing + (["wine64"] if wine_command() is None else [])


def _wine_env() -> dict[str, str]:
    env = dict(os.environ)
    env.setdefault("WINEPREFIX", str(Path.home() / ".cache" / "jaxflex" / "wine"))
    env["WINEDEBUG"] = "-all"
    env["WINEDLLOVERRIDES"] = "mscoree,mshtml="  # no Mono / Gecko installer prompts
    if wine_command() == [str(_WINE64_LOADER)]:
        env["WINELOADER"] = str(_WINE64_LOADER)
    Path(env["WINEPREFIX"]).parent.mkdir(parents=True, exist_ok=True)
    return env


def windows_path(path: Path) -> str:
    """``path`` as the Windows side of wine sees it (``Z:\\dir\\file``)."""
    return "Z:" + str(Path(path).resolve()).replace("/", "\\")


def _objdump(dll: Path) -> str:
    if shutil.which(OBJDUMP) is None:
        raise FmuBuildError(f"{OBJDUMP} is not installed ({WINE_HINT})")
    proc = subprocess.run([OBJDUMP, "-p", str(dll)], capture_output=True, text=True)
    if proc.returncode != 0:
        raise FmuBuildError(f"{OBJDUMP} -p {dll} failed:\n{proc.stderr.strip()}")
    return proc.stdout


def dll_exports(dll: Path) -> set[str]:
    """Names the DLL exports."""
    text = _objdump(dll)
    table = text.partition("[Ordinal/Name Pointer] Table")[2]
    return set(re.findall(r"^\s*\[\s*\d+\]\s+(\w+)\s*$", table, flags=re.MULTILINE))


def dll_imports(dll: Path) -> set[str]:
    """Names of the DLLs the DLL imports (as written in its import table)."""
    return set(re.findall(r"DLL Name:\s*(\S+)", _objdump(dll)))


def run_under_wine(args: list[str], timeout_s: float = WINE_TIMEOUT_S) -> str:
    """Run a Windows program (``args[0]``: the .exe) under wine; its stdout.

    Output goes through temporary files, not pipes: wine's helper processes (wineserver,
    services) inherit the program's handles and live on for seconds after it exits, so reading
    a pipe to its end would wait for them."""
    wine = wine_command()
    if wine is None:
        raise FmuBuildError(f"wine is not installed ({WINE_HINT})")
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = run_child(  # ends with the command
            [*wine, *args],
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=err,
            env=_wine_env(),
            timeout=timeout_s,
        )
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read().decode(errors="replace"), err.read().decode(errors="replace")
    if proc.returncode != 0:
        raise FmuBuildError(
            f"{Path(args[0]).name} under wine failed (exit {proc.returncode}):\n"
            f"{stderr.strip()[-2000:]}"
        )
    return stdout


def windows_library(native_library: Path, fmi_version: int) -> Path:
    """The Windows DLL beside the Linux binary ``native_library`` of an extracted FMU."""
    folder = "win64" if fmi_version == 2 else "x86_64-windows"
    return native_library.parent.parent / folder / f"{native_library.stem}.dll"


def windows_resource_location(fmi_version: int, resources: Path) -> str:
    """What a Windows importer passes: a file URI (FMI 2.0) or a path ending in a separator
    (FMI 3.0), on wine's Z: drive."""
    path = windows_path(resources)
    return PureWindowsPath(path).as_uri() + "/" if fmi_version == 2 else path + "\\"


def _output_specs(md) -> tuple[list[str], list[tuple[str, int]]]:
    """Harness output arguments for every output of ``md`` and (name, size) per output."""
    specs, layout = [], []
    for v in md.modelVariables:
        if v.causality != "output":
            continue
        size = int(np.prod([int(d.start) for d in v.dimensions])) if v.dimensions else 1
        kind = "b" if v.type == "Boolean" else "r"
        specs.append(f"{kind}{v.valueReference}" + (f"x{size}" if size > 1 else ""))
        layout.append((v.name, size))
    return specs, layout


def replay(
    fmu_path: Path, folder: Path, harness: Path, n_steps: int, dt_s: float, *, windows: bool
) -> dict[str, np.ndarray]:
    """Extract the FMU at ``fmu_path`` into ``folder`` and run its Linux binary
    (``windows=False``; ``harness`` from :func:`fmu.harness.compile_harness`) or its Windows
    DLL (``harness`` from ``compile_harness(..., windows=True)``, run under wine) for
    ``n_steps`` steps of ``dt_s`` s, with ``use_embedded_trajectory = true`` when the FMU
    has it (inputs stay 0).
    Returns {"time": (n_steps + 1,), output name: (n_steps + 1[, size])}: every output at the
    start and after every step."""
    library, resources, token = unpack(fmu_path, folder)
    md = read_model_description(str(folder))
    fmi_version = int(md.fmiVersion[0])
    specs, layout = _output_specs(md)
    switch = next(
        (str(v.valueReference) for v in md.modelVariables if v.name == "use_embedded_trajectory"),
        "-",
    )
    if windows:
        library = windows_library(library, fmi_version)
        location = windows_resource_location(fmi_version, resources)
    else:
        location = resource_location(fmi_version, resources)
    args = [
        windows_path(library) if windows else str(library),
        location,
        token,
        "replay",
        str(n_steps),
        repr(float(dt_s)),
        switch,
        *specs,
    ]
    if windows:
        text = run_under_wine([str(harness), *args])
    else:
        proc = run_child([str(harness), *args], capture_output=True, text=True)
        if proc.returncode != 0:
            raise FmuBuildError(f"the harness failed on {library.name}:\n{proc.stderr.strip()}")
        text = proc.stdout
    table = np.array([[float(x) for x in line.split()] for line in text.splitlines() if line])
    out, column = {"time": table[:, 0]}, 1
    for name, size in layout:
        block = table[:, column : column + size]
        out[name] = block[:, 0] if size == 1 else block
        column += size
    return out
