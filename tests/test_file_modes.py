"""Files the user gets keep the user's permissions: 0666 minus the umask, like any program's
new file (a colleague or a build server can read them), never the 0600 of a private temporary
file; a stricter umask is honoured. Atomic writes still leave nothing behind on failure."""

from __future__ import annotations

import contextlib
import os
import stat

import pytest
from conftest import random_model, smooth_move

import jaxflex
from fmu import export_fmu
from fmu.options import Fmi
from jaxflex._atomic import atomic_open, atomic_path, write_text_atomic


@contextlib.contextmanager
def umask(mask: int):
    old = os.umask(mask)
    try:
        yield
    finally:
        os.umask(old)


def _modes(folder) -> dict[str, int]:
    return {p.name: stat.S_IMODE(p.stat().st_mode) for p in folder.iterdir()}


@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_atomic_writes_get_the_umask_mode(tmp_path, mask, mode):
    with umask(mask):
        write_text_atomic(tmp_path / "a.json", "{}")
        with atomic_open(tmp_path / "b.bin", "wb") as handle:
            handle.write(b"\0")
        with atomic_path(tmp_path / "c.vtu", suffix=".vtu") as name:
            assert name.endswith(".vtu")
            with open(name, "w") as handle:  # a writer that opens by name, like meshio
                handle.write("x")
    assert _modes(tmp_path) == {"a.json": mode, "b.bin": mode, "c.vtu": mode}


def test_model_fmu_and_case_files_are_readable_by_others(tmp_path):
    model = random_model(2, n_points=8, n_modes=3)
    with umask(0o022):
        model.save(tmp_path / "model.npz")
        move = jaxflex.as_move(smooth_move(20, 0.01), 0.01)
        export_fmu(model, tmp_path / "part.fmu", move, fmi=Fmi(windows=False))
    modes = _modes(tmp_path)
    assert set(modes) == {"model.npz", "part.fmu", "part_input.csv", "part_case.json"}
    assert set(modes.values()) == {0o644}


def test_failed_atomic_write_leaves_nothing(tmp_path):
    (tmp_path / "keep.txt").write_text("old")
    with pytest.raises(RuntimeError), atomic_open(tmp_path / "keep.txt", "w") as handle:
        handle.write("new")
        raise RuntimeError("interrupted")
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "x.vtu", ".vtu"):
        raise RuntimeError("interrupted")
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]
    assert (tmp_path / "keep.txt").read_text() == "old"
