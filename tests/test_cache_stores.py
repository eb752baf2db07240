"""The stores of jaxflex's cache beside JAX's programs (jaxflex.runtime.cache_store): the FMU
binaries gcc built (fmu.build) and the built-in scenes' FE models (fem.scenes). A later run
with the same input reuses the work; any change of input is new work; a damaged entry is
redone. The reused binary is checked by running it (fmpy against jaxflex), the reused model
against the solve it replaces."""

from __future__ import annotations

import subprocess
import zipfile

import numpy as np
import pytest
from conftest import smooth_move

import fem
import fem.scenes
import fmu.build
from fmu.export import export_fmu
from fmu.verify import verify
from jaxflex.compile_cache import ENV_VAR

DT_S = 0.01


@pytest.fixture
def compiles(monkeypatch, tmp_path):
    """A fresh cache directory and the list of compiler runs (``--version`` queries aside)."""
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "cache"))
    runs = []
    real_run = subprocess.run

    def counting_run(cmd, *args, **kwargs):
        if "--version" not in cmd:
            runs.append(cmd)
        return real_run(cmd, *args, **kwargs)

    monkeypatch.setattr(fmu.build.subprocess, "run", counting_run)
    return runs


def _export(model, folder, acc):
    """The FMI 2.0 FMU of ``model`` with the move ``acc`` at folder/part.fmu (same model
    identifier in every folder), host binary only."""
    folder.mkdir()
    return export_fmu(model, folder / "part.fmu", 2, (acc, DT_S), windows=False)


def _binary(result) -> bytes:
    with zipfile.ZipFile(result.fmu_path) as archive:
        return archive.read("binaries/linux64/part.so")


def test_the_same_fmu_is_compiled_once_and_runs_like_jaxflex(small_model, tmp_path, compiles):
    acc = smooth_move(40, DT_S)
    first = _export(small_model, tmp_path / "a", acc)
    second = _export(small_model, tmp_path / "b", acc)
    assert len(compiles) == 1
    # the same content has the same instantiation token, so the same binary is right for it
    assert second.token == first.token
    assert _binary(second) == _binary(first)
    # the copied binary, run by fmpy, answers like jaxflex (within verify's own tolerance)
    assert verify(second.fmu_path).ok
    # another move is another token (compiled into the binary): compiled again
    other = _export(small_model, tmp_path / "c", smooth_move(44, DT_S))
    assert other.token != first.token
    assert len(compiles) == 2
    assert verify(other.fmu_path).ok


def test_a_damaged_entry_is_compiled_again(small_model, tmp_path, compiles):
    acc = smooth_move(40, DT_S)
    _export(small_model, tmp_path / "a", acc)
    entries = list((tmp_path / "cache" / fmu.build.BINARY_STORE).iterdir())
    assert len(entries) == 1
    entries[0].write_bytes(b"\0" * 8 + b"not a binary")
    again = _export(small_model, tmp_path / "b", acc)
    assert len(compiles) == 2
    assert verify(again.fmu_path).ok


def test_without_the_cache_every_build_compiles(small_model, tmp_path, compiles, monkeypatch):
    monkeypatch.setenv(ENV_VAR, "off")
    acc = smooth_move(40, DT_S)
    _export(small_model, tmp_path / "a", acc)
    _export(small_model, tmp_path / "b", acc)
    assert len(compiles) == 2


def test_a_built_in_scene_is_solved_once_per_input(monkeypatch, tmp_path):
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "cache"))
    solves = []
    real_analysis = fem.scenes.modal_analysis

    def counting_analysis(*args, **kwargs):
        solves.append(kwargs)
        return real_analysis(*args, **kwargs)

    monkeypatch.setattr(fem.scenes, "modal_analysis", counting_analysis)
    solved = fem.default_model("plate", n_modes=4, cache=True)
    loaded = fem.default_model("plate", n_modes=4, cache=True)
    assert len(solves) == 1
    for field in ("freq_hz", "zeta", "gamma", "shapes", "points"):
        np.testing.assert_array_equal(getattr(loaded, field), getattr(solved, field))
    assert loaded.meta == solved.meta
    fem.default_model("plate", n_modes=4, zeta=0.03, cache=True)  # another input: solved
    fem.default_model("plate", n_modes=4)  # without cache: solved
    assert len(solves) == 3
