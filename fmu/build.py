"""Compiling the FMU binaries with gcc (and mingw-w64 for Windows, when installed).

A binary is built once per input: the store ``fmu-binaries`` of jaxflex's cache
(jaxflex.runtime.cache_store) keeps it under a key that hashes the compiler's identity
(``--version``), the command's flags, every C file and header of the sources folder and
fmpy's FMI headers; a later build of the same input copies it (a changed model data header
or source is a new key; the FMU's file name is not in it: the instantiation token the
sources carry is derived from the content alone, fmu.archive.content_token). The store
checks every entry it returns (jaxflex._compile_cache); two runs building the same binary at
once build it once. Whether compiled or copied, every binary is checked in the FMU before
the FMU is reported built (fmu.binary_check: it loads, exports every FMI function, and one
step of the part agrees with the engine); a copied binary that fails is compiled again.
``JAXFLEX_COMPILE_CACHE=off`` turns the store off.
"""

from __future__ import annotations

import functools
import hashlib
import shutil
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from fmu.toolchain import (
    MINGW_HINT,
    WINDOWS_COMPILER,
    FmuBuildError,
    Target,
    fmi_headers,
    host_target,
    windows_target,
)
from jaxflex.isolated import run_child
from jaxflex.runtime import cache_fetch, cache_pack_text, cache_store, cache_unpack_text

# every FMU: the instance (life cycle, checks, logging) and one FMI binding per version, over
# the core interface jxf_model_* (fmu/c/jxf_fmu.h) that one of the cores implements
# (logging: jxf_log.c, used by the instance and every core alike)
INSTANCE_FILES = ("jxf_fmu.h", "jxf_log.h", "jxf_text.h", "jxf_fmu.c", "jxf_log.c")
BINDING_FILE = {2: "jxf_fmi2.c", 3: "jxf_fmi3.c"}
# the part: its state (jxf_model.h), the core (jxf_core.c) and the modules it calls down into
PART_CORE = (
    "jxf_model.h",
    "jxf_core.c",
    "jxf_values.c",
    "jxf_blocks.h",
    "jxf_blocks.c",
    "jxf_cell.h",
    "jxf_cell.c",
    "jxf_turning.h",
    "jxf_turning.c",
    "jxf_turn_angle.h",
)
SOURCE_CORE = ("jxf_source.c", "jxf_turn_angle.h")  # the trajectory source (fmu.source)
CFLAGS = ("-std=c99", "-O2", "-fvisibility=hidden", "-Wall", "-Wextra")
BINARY_STORE = "fmu-binaries"  # jaxflex.runtime.cache_store of the built binaries
BINARY_STORE_BYTES = 256 * 1024**2


@dataclass
class BuildReport:
    """Platforms built (folder names under binaries/), skipped ones with the reason, and
    the compiler messages (empty when the build is warning-free)."""

    platforms: list[str] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)
    messages: str = ""
    from_cache: list[str] = field(default_factory=list)  # platforms whose binary was copied

    def written(self) -> dict:
        """The fields of :class:`WrittenFmu` this report fills."""
        return {
            "platforms": tuple(self.platforms),
            "skipped": dict(self.skipped),
            "compiler_messages": self.messages,
            "from_cache": tuple(self.from_cache),
        }


@dataclass(frozen=True, kw_only=True)
class WrittenFmu:
    """An FMU written (the part's or the trajectory source's). ``platforms`` are folder
    names under binaries/; ``skipped`` maps platforms that were not built to the reason."""

    fmu_path: Path
    fmi_version: int
    token: str
    model_identifier: str
    platforms: tuple[str, ...]
    skipped: dict[str, str] = field(default_factory=dict)
    compiler_messages: str = ""
    from_cache: tuple[str, ...] = ()  # platforms whose binary came from the cache


def sources_for(fmi_version: int, core: tuple[str, ...] = PART_CORE) -> tuple[str, ...]:
    """C files of an FMU with ``core`` (the part's, or SOURCE_CORE) copied into its sources/
    folder (besides the generated header: jxf_config.h or jxf_source_data.h)."""
    return (*core, *INSTANCE_FILES, BINDING_FILE[fmi_version])


def compiled_files(fmi_version: int, core: tuple[str, ...] = PART_CORE) -> tuple[str, ...]:
    """The C files of :func:`sources_for` that are compiled (the headers are included)."""
    return tuple(name for name in sources_for(fmi_version, core) if name.endswith(".c"))


def compile_library(
    target: Target,
    sources_dir: Path,
    fmi_version: int,
    out_file: Path,
    c_files: Sequence[str] | None = None,
    extra_flags: Sequence[str] = (),
    *,
    use_store: bool = True,
) -> tuple[str, bool]:
    """Compile the sources in ``sources_dir`` (``c_files``, default: the part FMU's) into
    ``out_file`` (``extra_flags`` added, e.g. fmu.harness.SANITIZE_FLAGS), or copy the binary
    of the same input from the store; returns (the compiler's messages, True if copied).
    ``use_store`` False compiles whatever the store holds, and replaces it."""
    if shutil.which(target.compiler) is None:
        raise FmuBuildError(f"C compiler {target.compiler!r} not found on PATH (install gcc)")
    out_file.parent.mkdir(parents=True, exist_ok=True)
    names = tuple(c_files or compiled_files(fmi_version))
    flags = (*CFLAGS, *extra_flags, *target.flags)
    binaries = cache_store(BINARY_STORE, BINARY_STORE_BYTES)
    key = _build_key(target.compiler, flags, names, sources_dir)

    def compiled() -> tuple[str, bytes]:
        messages = _run_compiler(target, sources_dir, flags, names, out_file)
        return messages, _pack(messages, out_file.read_bytes())

    def copied(entry: bytes) -> str:
        messages, binary = _unpack(entry)
        out_file.write_bytes(binary)
        out_file.chmod(0o755)
        return messages

    if binaries is not None and not use_store:
        messages, entry = compiled()
        binaries.put(key, entry)
        return messages, False
    return cache_fetch(binaries, key, compiled, copied, f"FMU binary ({out_file.name})")


def _run_compiler(target: Target, sources_dir: Path, flags, names, out_file: Path) -> str:
    """Run ``target``'s compiler on the files ``names`` of ``sources_dir`` into
    ``out_file``; its messages."""
    c_files = [str(sources_dir / name) for name in names]
    cmd = [
        target.compiler,
        *flags,
        f"-I{sources_dir}",
        f"-I{fmi_headers()}",
        *c_files,
        "-o",
        str(out_file),
        "-lm",
    ]
    proc = run_child(cmd, capture_output=True, text=True)  # ends with the command
    if proc.returncode != 0:
        raise FmuBuildError(f"compiling the FMU failed ({' '.join(cmd)}):\n{proc.stderr.strip()}")
    return proc.stderr.strip()


@functools.cache
def _compiler_identity(compiler_path: str) -> bytes:
    """The compiler's path and what its ``--version`` prints (a new compiler, a new key)."""
    proc = subprocess.run([compiler_path, "--version"], capture_output=True)
    return compiler_path.encode() + b"\0" + proc.stdout


@functools.cache
def _headers_digest() -> bytes:
    """The hash of fmpy's FMI headers (the build includes them)."""
    digest = hashlib.sha256()
    for path in sorted(fmi_headers().glob("*.h")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.digest()


def _build_key(compiler: str, flags, c_files, sources_dir: Path) -> str:
    """The store key of a build: the compiler, the flags, the files compiled and every C file
    and header of ``sources_dir`` (the build may include any) and the FMI headers."""
    identity = _compiler_identity(shutil.which(compiler) or compiler)
    digest = hashlib.sha256(identity + _headers_digest())
    digest.update("\0".join((*flags, "|", *c_files)).encode())
    for path in sorted(sources_dir.iterdir()):
        if path.suffix in (".c", ".h"):
            digest.update(b"\0" + path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def _pack(messages: str, binary: bytes) -> bytes:
    """A store entry: the compiler's messages and the binary."""
    return cache_pack_text(messages, binary)


def _unpack(entry: bytes) -> tuple[str, bytes]:
    """(messages, binary) of a store entry written by :func:`_pack`; ValueError if it is not
    one (the binary an ELF or PE file)."""
    messages, binary = cache_unpack_text(entry)
    if binary[:4] != b"\x7fELF" and binary[:2] != b"MZ":
        raise ValueError("not a compiled binary")
    return messages, binary


def build_binaries(
    sources_dir: Path,
    binaries_dir: Path,
    fmi_version: int,
    model_identifier: str,
    windows: bool | None = None,
    c_files: Sequence[str] | None = None,
) -> BuildReport:
    """Build the host binary and, when ``windows`` is None (auto) or True, the Windows DLL,
    from ``c_files`` in ``sources_dir`` (default: the part FMU's).

    ``windows=True`` without the mingw-w64 compiler is an error; with None the DLL is skipped
    and the reason recorded in the report.
    """
    report = BuildReport()
    targets = [host_target()]
    cross = windows_target() if windows is not False else None
    if cross is not None:
        targets.append(cross)
    elif windows is None:
        report.skipped["x86_64-windows"] = f"{WINDOWS_COMPILER} is not installed ({MINGW_HINT})"
    elif windows:
        raise FmuBuildError(
            f"a Windows DLL was requested but {WINDOWS_COMPILER} is not installed ({MINGW_HINT})"
        )
    messages = []
    for target in targets:
        folder = target.folder(fmi_version)
        out = binaries_dir / folder / f"{model_identifier}{target.suffix}"
        built = (target, sources_dir, fmi_version, out, c_files)
        text, copied = compile_library(*built)
        if copied:
            try:
                _check(target, out, binaries_dir.parent, fmi_version, part=c_files is None)
            except FmuBuildError:  # a wrong binary in the cache: compiled again, replaced
                text, copied = compile_library(*built, use_store=False)
        if not copied:
            _check(target, out, binaries_dir.parent, fmi_version, part=c_files is None)
        if text:
            messages.append(f"[{folder}] {text}")
        report.platforms.append(folder)
        if copied:
            report.from_cache.append(folder)
    report.messages = "\n".join(messages)
    return report


def _check(target: Target, library: Path, folder: Path, fmi_version: int, *, part: bool):
    """fmu.binary_check of the binary ``library`` in the FMU staged in ``folder``: the host
    library loaded (a part's also stepped), a Windows DLL's export table."""
    from fmu.binary_check import check_dll, check_library

    if target.suffix == ".dll":
        check_dll(library, fmi_version)
    else:
        check_library(folder, library, fmi_version, step=part)
