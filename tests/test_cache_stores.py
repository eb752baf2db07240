"""The stores of jaxflex's cache beside JAX's programs (jaxflex.runtime.cache_store): the FMU
binaries gcc built (fmu.build) and the FE models (fem.model_store). A later run with the
same input reuses the work; any change of input is new work; every damage an entry can
suffer (issue 34: cut, halved, flipped, swapped, foreign, a FIFO or a link in its place, a
valid entry that is not the one asked for) is a miss, and the result is byte-identical to a
run with an empty cache. JAX's own store: tests/test_compile_cache.py."""

from __future__ import annotations

import contextlib
import ctypes.util
import os
import re
import shutil
import subprocess
import sys
import threading
import zipfile
from pathlib import Path

import meshio
import numpy as np
import pytest
from conftest import smooth_move

import fem
import fem.modal
import fem.model_store
import fmu.build
import jaxflex
from fmu.binary_check import check_library, fmi_functions
from fmu.export import export_fmu
from fmu.options import Fmi
from fmu.toolchain import FmuBuildError
from jaxflex._compile_cache import ENV_VAR, SUFFIX, FileStore, encode_entry, fetch
from jaxflex.cli import main

DT_S = 0.01
# a FIFO in an entry's place must not block a read: a test that waits longer has failed
NO_BLOCK_S = 60.0


def _libm() -> Path:
    """The C maths library this process loaded (a valid shared library, not an FMU)."""
    for line in Path("/proc/self/maps").read_text().splitlines():
        if re.search(r"/libm[.-][^/]*\.so", line) or line.endswith("/libm.so.6"):
            return Path(line.split()[-1])
    return Path(ctypes.util.find_library("m") or "libm.so.6")


# damages of an entry's file, each (name, how): how(path, files) damages the entry at ``path``
# (``files``: every entry file of its store, their bytes: the source of a swap)
def _cut(size):
    return lambda path, files: path.write_bytes(path.read_bytes()[:size])


def _flip(path, files):
    data = bytearray(path.read_bytes())
    for i in range(len(data) // 2, len(data), max(1, len(data) // 7)):
        data[i] ^= 0x5A
    path.write_bytes(bytes(data))


def _swap(path, files):
    other = next(data for name, data in files.items() if name != path.name)
    path.write_bytes(other)


def _replace_with(source):
    return lambda path, files: path.write_bytes(Path(source()).read_bytes())


def _fifo(path, files):
    path.unlink()
    os.mkfifo(path)


def _dev_zero(path, files):
    path.unlink()
    path.symlink_to("/dev/zero")


FILE_DAMAGES = {
    "cut to 64 bytes": _cut(64),
    "half": lambda path, files: _cut(len(path.read_bytes()) // 2)(path, files),
    "flipped bytes": _flip,
    "another key's entry": _swap,
    "libm.so": _replace_with(_libm),
    "/bin/true": _replace_with(lambda: shutil.which("true")),
    "FIFO": _fifo,
    "link to /dev/zero": _dev_zero,
}


def _entries(folder: Path) -> dict[str, bytes]:
    return {
        p.name: p.read_bytes() for p in folder.iterdir() if p.name.endswith(SUFFIX) and p.is_file()
    }


def _damage(folder: Path, key_file: str, how) -> None:
    """Damage the entry ``key_file`` of the store ``folder``; a swap needs another entry: a
    valid entry of another key is written first."""
    files = _entries(folder)
    if len(files) < 2:
        other = "0" * 64
        (folder / f"{other}{SUFFIX}").write_bytes(encode_entry(other, b"another entry"))
        files = _entries(folder)
    how(folder / key_file, files)


def _get_without_blocking(store: FileStore, key: str):
    found = []
    reader = threading.Thread(target=lambda: found.append(store.get(key)), daemon=True)
    reader.start()
    reader.join(NO_BLOCK_S)
    assert not reader.is_alive(), "the read blocked"
    return found[0]


@pytest.mark.parametrize("damage", FILE_DAMAGES)
def test_a_damaged_entry_is_a_miss_and_replaced(tmp_path, damage):
    store = FileStore(tmp_path, max_bytes=1 << 20)
    key = "a" * 64
    value = os.urandom(5000)
    store.put(key, value)
    assert store.get(key) == value
    _damage(tmp_path, f"{key}{SUFFIX}", FILE_DAMAGES[damage])
    assert _get_without_blocking(store, key) is None
    store.put(key, value)  # whatever is in the entry's place is replaced, not written through
    assert store.get(key) == value
    assert Path("/dev/zero").is_char_device()


def test_entries_above_the_store_size_are_not_read(tmp_path):
    store = FileStore(tmp_path, max_bytes=1000)
    key = "b" * 64
    (tmp_path / f"{key}{SUFFIX}").write_bytes(encode_entry(key, b"x" * 5000))
    assert store.get(key) is None


def test_concurrent_runs_make_an_entry_once(tmp_path):
    """Two runs wanting the same entry at once: one makes it (the lock file), the other waits
    and takes it from the store."""
    store = FileStore(tmp_path)
    made, results = [], []
    started = threading.Event()

    def make():
        made.append(1)
        started.set()
        threading.Event().wait(1.0)  # the other run arrives while this one works
        return "value", b"value"

    def run():
        results.append(fetch(store, "k" * 64, make, lambda entry: entry.decode(), "test entry"))

    first = threading.Thread(target=run)
    first.start()
    started.wait(NO_BLOCK_S)
    second = threading.Thread(target=run)
    second.start()
    first.join(NO_BLOCK_S)
    second.join(NO_BLOCK_S)
    assert len(made) == 1
    assert sorted(results) == [("value", False), ("value", True)]


# ---- fmu-binaries -------------------------------------------------------------------------


@pytest.fixture
def compiles(monkeypatch, tmp_path):
    """A fresh cache directory and the list of compiler runs (``--version`` queries aside)."""
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "cache"))
    runs = []
    real_run = fmu.build.run_child  # the compiler runs as a child that ends with the command
    compilers = ("gcc", fmu.build.WINDOWS_COMPILER)

    def counting_run(cmd, *args, **kwargs):
        if Path(cmd[0]).name in compilers and "--version" not in cmd:
            runs.append(cmd)
        return real_run(cmd, *args, **kwargs)

    monkeypatch.setattr(fmu.build, "run_child", counting_run)
    return runs


def _export(model, folder, acc, fmi_version=2, name="part.fmu"):
    """The FMU of ``model`` with the move ``acc`` at folder/name, host binary only."""
    folder.mkdir(exist_ok=True)
    move = jaxflex.as_move(acc, DT_S)
    return export_fmu(model, folder / name, move, fmi=Fmi(fmi_version, windows=False))


def _members(result) -> dict[str, bytes]:
    """Every member of the written FMU, the model description's generation time left out
    (the time of the export, the only thing two exports of the same input differ in)."""
    with zipfile.ZipFile(result.fmu_path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    xml = members["modelDescription.xml"].decode()
    members["modelDescription.xml"] = re.sub(r'generationDateAndTime="[^"]*"', "", xml).encode()
    return members


def _binary(result) -> bytes:
    folder = fmu.build.host_target().folder(result.fmi_version)
    with zipfile.ZipFile(result.fmu_path) as archive:
        return archive.read(f"binaries/{folder}/{result.model_identifier}.so")


def test_the_same_fmu_is_compiled_once_under_any_name(small_model, tmp_path, compiles):
    acc = smooth_move(40, DT_S)
    first = _export(small_model, tmp_path / "a", acc)
    second = _export(small_model, tmp_path / "b", acc)
    assert len(compiles) == 1 and second.from_cache == ("linux64",)
    # the same content has the same instantiation token, so the same binary is right for it
    assert second.token == first.token
    assert _members(second) == _members(first)
    # another file name (another model identifier) is the same binary: not compiled again
    renamed = _export(small_model, tmp_path / "c", acc, name="press line 3.fmu")
    assert len(compiles) == 1 and renamed.model_identifier == "press_line_3"
    assert _binary(renamed) == _binary(first)
    # another move is another token (compiled into the binary): compiled again
    other = _export(small_model, tmp_path / "d", smooth_move(44, DT_S))
    assert other.token != first.token
    assert len(compiles) == 2


# contents of a store entry whose envelope is valid (the key and hash are right) but whose
# binary is wrong: caught when it is unpacked or when the binary is checked in the FMU
CONTENT_DAMAGES = {
    "holding its ELF header only": lambda binary, other: binary[:64],
    "holding half the binary": lambda binary, other: binary[: len(binary) // 2],
    "holding flipped bytes": lambda binary, other: (
        binary[:4096] + bytes(b ^ 0x5A for b in binary[4096:])
    ),
    "holding the other FMI version's binary": lambda binary, other: other,
    "holding libm.so": lambda binary, other: _libm().read_bytes(),
    "holding /bin/true": lambda binary, other: Path(shutil.which("true")).read_bytes(),
}


@pytest.fixture(scope="module")
def built_fmu(small_model, tmp_path_factory):
    """The FMI 2.0 FMU of the test move built with an empty cache (the reference: its
    members), the cache that build filled, and the FMI 3.0 binary of the same input (the
    other version's binary)."""
    folder = tmp_path_factory.mktemp("reference")
    previous = os.environ.get(ENV_VAR)
    try:
        os.environ[ENV_VAR] = str(folder / "cache")
        acc = smooth_move(40, DT_S)
        reference = _export(small_model, folder / "2", acc)
        os.environ[ENV_VAR] = "off"
        other = _export(small_model, folder / "3", acc, 3)
        return _members(reference), folder / "cache", _binary(other)
    finally:
        os.environ[ENV_VAR] = previous


@pytest.mark.parametrize("damage", [*FILE_DAMAGES, *CONTENT_DAMAGES])
def test_a_damaged_fmu_binary_is_a_miss(small_model, tmp_path, compiles, built_fmu, damage):
    reference, filled, other_version = built_fmu
    shutil.copytree(filled, tmp_path / "cache")  # the entry of this FMU's binary
    store = tmp_path / "cache" / fmu.build.BINARY_STORE
    (entry,) = _entries(store)
    if damage in FILE_DAMAGES:
        _damage(store, entry, FILE_DAMAGES[damage])
    else:  # a valid entry of this key holding the wrong binary
        binary = fmu.build._unpack(_entry_value(store, entry))[1]
        wrong = CONTENT_DAMAGES[damage](binary, other_version)
        FileStore(store).put(entry.removesuffix(SUFFIX), fmu.build._pack("", wrong))
    acc = smooth_move(40, DT_S)
    again = _export(small_model, tmp_path / "b", acc)
    assert len(compiles) == 1 and again.from_cache == ()
    assert _members(again) == reference
    replaced = _export(small_model, tmp_path / "c", acc)  # the entry was replaced
    assert len(compiles) == 1 and replaced.from_cache == ("linux64",)
    assert _members(replaced) == reference


def test_the_binary_check_refuses_what_is_not_the_fmu(small_model, tmp_path, compiles):
    """The check itself (fmu.binary_check) on the staged FMU: the built library passes; the
    other FMI version's, libm.so and /bin/true do not."""
    acc = smooth_move(40, DT_S)
    result = _export(small_model, tmp_path / "a", acc)
    folder = tmp_path / "staged"
    with zipfile.ZipFile(result.fmu_path) as archive:
        archive.extractall(folder)
    library = folder / "binaries" / fmu.build.host_target().folder(2) / "part.so"
    check_library(folder, library, 2, step=True)
    other = _binary(_export(small_model, tmp_path / "b", acc, 3))
    for wrong, why in (
        (other, "lacks"),
        (_libm().read_bytes(), "lacks"),
        (Path(shutil.which("true")).read_bytes(), "does not load"),
    ):
        library.write_bytes(wrong)
        with pytest.raises(FmuBuildError, match=why):
            check_library(folder, library, 2, step=True)
    assert len(fmi_functions(2)) == 44 and len(fmi_functions(3)) > 44


def test_without_the_cache_every_build_compiles(small_model, tmp_path, compiles, monkeypatch):
    monkeypatch.setenv(ENV_VAR, "off")
    acc = smooth_move(40, DT_S)
    _export(small_model, tmp_path / "a", acc)
    _export(small_model, tmp_path / "b", acc)
    assert len(compiles) == 2


# ---- fe-models ----------------------------------------------------------------------------

# `jaxflex model` of a coarse plate: a second run copies the model from the store
MODEL_ARGS = ("model", "--scene", "plate", "--mesh-size", "0.1", "--n-modes", "3", "-q")


def _model(path: Path, *extra: str) -> Path:
    assert main([*MODEL_ARGS, *extra, "-o", str(path)]) == 0
    return path


def _fields(path: Path) -> dict:
    """The model file's arrays and meta, the FE timings left out (wall times of the solve, of
    the discretisation estimate's second analysis and of a sizing's analyses)."""
    with np.load(path) as archive:
        arrays = {name: archive[name] for name in archive.files}
    timings = r'"timings_s": \{[^}]*\}|"(modal_analysis_s|time_s)": [-+.0-9eE]+'
    meta = re.sub(timings, "", str(arrays.pop("meta_json")))
    return {name: (a.dtype.str, a.shape, a.tobytes()) for name, a in arrays.items()} | {
        "meta": meta
    }


@pytest.fixture(scope="module")
def reference_model(tmp_path_factory):
    """The coarse plate's model file from an empty cache, and another valid model."""
    folder = tmp_path_factory.mktemp("reference-model")
    with _cache_off():
        other = _model(folder / "other.npz", "--zeta", "0.03")
        return _fields(_model(folder / "model.npz")), other.read_bytes()


@contextlib.contextmanager
def _cache_off():
    """Runs without jaxflex's cache (a module fixture cannot use monkeypatch)."""
    previous = os.environ.get(ENV_VAR)
    os.environ[ENV_VAR] = "off"
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop(ENV_VAR, None)
        else:
            os.environ[ENV_VAR] = previous


def _counted(monkeypatch, module, name: str) -> list:
    """The calls of ``module.name`` from now on (their keyword arguments), in a list."""
    calls = []
    real = getattr(module, name)

    def counting(*args, **kwargs):
        calls.append(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(module, name, counting)
    return calls


def _store_fe(monkeypatch, tmp_path) -> tuple[Path, list]:
    """A fresh cache at tmp_path/cache and the list of FE solves."""
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "cache"))
    solves = _counted(monkeypatch, fem.modal, "modal_analysis")
    return tmp_path / "cache" / fem.model_store.MODEL_STORE, solves


def test_model_is_served_from_the_store_as_solved(monkeypatch, tmp_path, capsys, reference_model):
    _, solves = _store_fe(monkeypatch, tmp_path)
    first = _model(tmp_path / "first.npz")
    second = _model(tmp_path / "second.npz")
    assert len(solves) == 1
    assert "FE model from the cache" in capsys.readouterr().out
    assert second.read_bytes() == first.read_bytes()
    assert _fields(second) == reference_model[0]  # the arrays of a solve with an empty cache
    _model(tmp_path / "other.npz", "--n-modes", "4")  # another input: solved
    assert len(solves) == 2


@pytest.mark.parametrize("damage", [*FILE_DAMAGES, "another valid model"])
def test_a_damaged_fe_model_is_a_miss(monkeypatch, tmp_path, reference_model, damage):
    reference, other_model = reference_model
    store, solves = _store_fe(monkeypatch, tmp_path)
    _model(tmp_path / "first.npz")
    (entry,) = _entries(store)
    if damage in FILE_DAMAGES:
        _damage(store, entry, FILE_DAMAGES[damage])
    else:  # a valid entry of this key holding another model (the damping differs)
        FileStore(store).put(entry.removesuffix(SUFFIX), other_model)
    again = _model(tmp_path / "again.npz")
    assert len(solves) == 2
    assert _fields(again) == reference


def test_a_built_in_scene_is_solved_once_per_input(monkeypatch, tmp_path):
    store, solves = _store_fe(monkeypatch, tmp_path)
    solved = fem.default_model("plate", n_modes=4, cache=True)
    loaded = fem.default_model("plate", n_modes=4, cache=True)
    assert len(solves) == 1
    for field in ("freq_hz", "zeta", "gamma", "shapes", "points"):
        np.testing.assert_array_equal(getattr(loaded, field), getattr(solved, field))
    assert loaded.meta == solved.meta
    (entry,) = _entries(store)
    other = fem.default_model("plate", n_modes=4, zeta=0.03, cache=True)  # another input
    assert len(solves) == 2
    # another valid model (the demo's case: a plate of other modes) under this key: a miss
    other_entry = next(name for name in _entries(store) if name != entry)
    FileStore(store).put(entry.removesuffix(SUFFIX), _entry_value(store, other_entry))
    again = fem.default_model("plate", n_modes=4, cache=True)
    assert len(solves) == 3
    np.testing.assert_array_equal(again.shapes, solved.shapes)
    assert float(other.zeta[0]) == 0.03 and float(again.zeta[0]) == 0.02
    fem.default_model("plate", n_modes=4)  # without cache: solved
    assert len(solves) == 4


def _entry_value(store: Path, name: str) -> bytes:
    """The content of the entry file ``name`` of ``store``."""
    return FileStore(store).get(name.removesuffix(SUFFIX))


def test_a_model_from_the_store_shows_what_its_solve_printed(monkeypatch, tmp_path, capsys):
    """A mesh too coarse for its cups: the run that finds the model in the store reads the
    same file (its content is in the key) and shows the same summary and warnings."""
    from test_fem_mesh_import import _plate_blocks

    _, solves = _store_fe(monkeypatch, tmp_path)
    points, blocks = _plate_blocks(n=(16, 10))
    mesh = tmp_path / "coarse.msh"
    meshio.write(mesh, meshio.Mesh(points, blocks), file_format="gmsh22", binary=False)
    args = ["model", "--mesh", str(mesh), "--thickness", "1e-3", "--n-modes", "3", "-q"]
    args += ["--cups", "0.3,0.2,0.08", "1.2,0.2,0.08", "0.75,0.6,0.08"]
    outputs = []
    for name in ("first", "second"):
        assert main([*args, "-o", str(tmp_path / f"{name}.npz")]) == 0
        outputs.append(capsys.readouterr())
    assert len(solves) == 1
    first, second = outputs
    warnings = [line for line in first.err.splitlines() if "warning" in line]
    assert warnings and [line for line in second.err.splitlines() if "warning" in line] == warnings
    assert "FE model from the cache" in second.out
    summary = first.out.split("wrote ")[0]
    assert "triangle" in summary and summary in second.out
    assert (tmp_path / "second.npz").read_bytes() == (tmp_path / "first.npz").read_bytes()
    points, blocks = _plate_blocks(n=(16, 12))  # another mesh in the same file: solved again
    meshio.write(mesh, meshio.Mesh(points, blocks), file_format="gmsh22", binary=False)
    assert main([*args, "-o", str(tmp_path / "third.npz")]) == 0
    assert len(solves) == 2


def test_two_runs_at_once_solve_a_model_once(tmp_path):
    """Two `jaxflex model` processes started together on an empty cache: one solves, the
    other waits for its entry (the lock file) and copies it; both models are the same file."""
    env = {**os.environ, ENV_VAR: str(tmp_path / "cache")}
    runs = [
        subprocess.Popen(
            [sys.executable, "-m", "jaxflex", *MODEL_ARGS, "-o", str(tmp_path / f"{i}.npz")],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        for i in range(2)
    ]
    outputs = [run.communicate(timeout=600) for run in runs]
    assert [run.returncode for run in runs] == [0, 0], outputs
    assert sum("FE model from the cache" in out for out, _ in outputs) == 1
    assert (tmp_path / "0.npz").read_bytes() == (tmp_path / "1.npz").read_bytes()


# a sizing of the coarse plate on two meshes (the tolerance is not met: exit status 1, which
# the run served from the store gives too), with its report and the part's picture
SIZING_BASE = (
    *("model", "--scene", "plate", "--tolerance", "5%", "--threshold", "5e-4"),
    *("--mesh-sizes", "0.2", "0.1", "--max-modes", "30", "-q"),
)
SIZING_ARGS = (*SIZING_BASE, "--distance", "0", "0", "1")


def _sized(folder: Path, name: str, *extra: str) -> tuple[int, dict[str, Path]]:
    files = {
        "model": folder / f"{name}.npz",
        "report": folder / f"{name}.json",
        "plot": folder / f"{name}.png",
    }
    argv = [*SIZING_ARGS, *extra, "-o", str(files["model"]), "--report", str(files["report"])]
    return main([*argv, "--plot", str(files["plot"])]), files


def _counting_work(monkeypatch) -> list:
    """The FE work of `jaxflex model` (solve or sizing), counted."""
    import fem.cli

    return _counted(monkeypatch, fem.cli, "_solved_or_sized")


@pytest.fixture(scope="module")
def sized_without_cache(tmp_path_factory):
    """The sizing's files from a run with the cache off."""
    folder = tmp_path_factory.mktemp("sized-reference")
    with _cache_off():
        return _sized(folder, "reference")


def test_a_sizing_is_served_with_its_report_picture_and_exit_status(
    monkeypatch, tmp_path, capsys, sized_without_cache
):
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "cache"))
    work = _counting_work(monkeypatch)
    status, first = _sized(tmp_path, "first")
    solved_out = capsys.readouterr()
    again, second = _sized(tmp_path, "second")
    served = capsys.readouterr()
    assert len(work) == 1
    reference_status, reference = sized_without_cache
    assert status == again == reference_status == 1  # 5 % is not met on these two meshes
    assert "FE model from the cache" in served.out and "not met" in served.err
    # what the sizing printed (its candidates and summary) is shown again
    assert solved_out.out.split("wrote ")[0] in served.out
    for role in ("model", "report", "plot"):
        assert second[role].read_bytes() == first[role].read_bytes(), role
    assert _fields(second["model"]) == _fields(reference["model"])  # as with no cache
    # another input of the sizing is new work: the threshold, the move
    _sized(tmp_path, "threshold", "--threshold", "4e-4")
    assert len(work) == 2
    _sized(tmp_path, "limits", "--vmax", "1.5")
    assert len(work) == 3


def test_a_sizing_for_a_trajectory_file_is_keyed_by_its_content(monkeypatch, tmp_path):
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "cache"))
    work = _counting_work(monkeypatch)
    acc = jaxflex.jerk_limited_move([0, 0, 1.0], vmax=2, amax=10, jmax=100, dt_s=DT_S).acc
    trajectory = tmp_path / "move.csv"
    jaxflex.files.write_trajectory_csv(trajectory, jaxflex.as_move(acc, DT_S))
    argv = [*SIZING_BASE, "--trajectory", str(trajectory)]
    for name in ("first", "second"):
        main([*argv, "-o", str(tmp_path / f"{name}.npz")])
    assert len(work) == 1
    slower = jaxflex.jerk_limited_move([0, 0, 1.0], vmax=1.5, amax=10, jmax=100, dt_s=DT_S).acc
    jaxflex.files.write_trajectory_csv(trajectory, jaxflex.as_move(slower, DT_S))
    main([*argv, "-o", str(tmp_path / "third.npz")])
    assert len(work) == 2


def test_pictures_are_served_with_the_model(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "cache"))
    work = _counting_work(monkeypatch)
    for name in ("first", "second"):
        pictures = ["--plot", str(tmp_path / f"{name}.png"), "--vtu", str(tmp_path / f"{name}.vtu")]
        _model(tmp_path / f"{name}.npz", *pictures)
    assert len(work) == 1
    assert "FE model from the cache" in capsys.readouterr().out
    for suffix in ("npz", "png", "vtu"):
        assert (tmp_path / f"second.{suffix}").read_bytes() == (
            tmp_path / f"first.{suffix}"
        ).read_bytes()
    _model(tmp_path / "third.npz", "--vtu", str(tmp_path / "third.xdmf"))  # another format
    assert len(work) == 2
    assert (tmp_path / "third.xdmf").read_bytes().lstrip().startswith(b"<")
