"""Shared fixtures: exact analytic models, small random models, the CLI as a user runs it."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

import jaxflex
from jaxflex._analytic import simply_supported_plate
from jaxflex._compile_cache import ENV_VAR as COMPILE_CACHE_VAR
from jaxflex.cli import BLAS_THREADS_VAR


def pytest_configure(config):
    """JAX's compilation cache (jaxflex._compile_cache) in a directory of this session, never
    the user's: the commands run in-process and the subprocesses (which inherit it, as the
    xdist workers do) share it, as concurrent runs of a user's commands share theirs; and
    the commands' single BLAS thread."""
    if hasattr(config, "workerinput"):
        return
    directory = tempfile.mkdtemp(prefix="jaxflex-test-jax-cache-")
    os.environ[COMPILE_CACHE_VAR] = directory
    # one OpenBLAS thread in the xdist workers (fresh interpreters started after this, which
    # load NumPy with it) and the commands' interpreters, as every jaxflex command runs
    # (jaxflex.cli): two workers on two cores would otherwise each spin a second thread
    os.environ.setdefault(BLAS_THREADS_VAR, "1")
    config.add_cleanup(lambda: shutil.rmtree(directory, ignore_errors=True))


def random_model(
    seed: int = 0,
    n_points: int = 30,
    n_modes: int = 6,
    f_min_hz: float = 2.0,
    f_max_hz: float = 80.0,
    zeta: float | tuple[float, float] = 0.02,
) -> jaxflex.ModalModel:
    """A small model with random 3-D shapes and log-spread frequencies (deterministic)."""
    rng = np.random.default_rng(seed)
    freq = np.sort(np.exp(rng.uniform(np.log(f_min_hz), np.log(f_max_hz), n_modes)))
    zeta_arr = rng.uniform(*zeta, n_modes) if isinstance(zeta, tuple) else np.full(n_modes, zeta)
    return jaxflex.ModalModel(
        freq_hz=freq,
        zeta=zeta_arr,
        gamma=rng.normal(size=(n_modes, 3)),
        shapes=rng.normal(size=(n_points, 3, n_modes)) * 0.3,
        points=rng.uniform(size=(n_points, 3)),
        meta={"source": "tests.random_model", "seed": seed},
    )


def smooth_move(n_steps: int, dt_s: float, distance=(0.3, -0.2, 1.0)) -> np.ndarray:
    """Rest-to-rest move with one sine of acceleration per axis: (n_steps + 1, 3) m/s^2."""
    duration = n_steps * dt_s
    t = np.arange(n_steps + 1) * dt_s
    shape = 2 * np.pi / duration**2 * np.sin(2 * np.pi * t / duration)
    acc = np.outer(shape, np.asarray(distance, dtype=float))
    acc[[0, -1]] = 0.0
    return acc


@pytest.fixture(scope="session")
def plate() -> jaxflex.ModalModel:
    """Simply supported 1.5 x 0.8 m x 1 mm steel plate, 12 modes, 150 points (exact)."""
    return simply_supported_plate(n_modes=12, zeta=0.02, points=150)


@pytest.fixture(scope="session")
def four_cup_plate():
    """A 0.6 x 0.4 m, 1 mm steel plate on four 30 mm cups at 50 mm, 6 modes (fem's
    ModalResult): the model the solver-file tests write and read back."""
    import fem

    part = fem.rectangular_plate(0.6, 0.4, 1e-3, mesh_size=0.05)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.12, 0.48) for y in (0.1, 0.3)]
    return fem.modal_analysis(part, cups, 6, progress=False)


@pytest.fixture(scope="session")
def turning_plate() -> jaxflex.ModalModel:
    """A 1.2 x 0.8 m, 1 mm steel plate on four cups (fem.scenes' layout), 4 modes (11.9-13.5
    Hz) at 54 points, with its rotation data, static residuals, cups and stresses (fem): the
    turning tests' part."""
    import fem
    from fem.scenes import default_gripper

    part = fem.rectangular_plate(1.2, 0.8, 1e-3, "steel", 0.1)
    result = fem.modal_analysis(part, default_gripper(1.2, 0.8), n_modes=4, zeta=0.02)
    return result.to_modal_model(points=60)


@pytest.fixture(scope="session")
def small_model() -> jaxflex.ModalModel:
    return random_model()


def run_jaxflex(*args: str, cwd=None, timeout_s: float = 600) -> subprocess.CompletedProcess:
    """``jaxflex ARGS`` in a fresh interpreter (as a user types it); text stdout/stderr."""
    return subprocess.run(
        [sys.executable, "-m", "jaxflex", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=timeout_s,
    )


# -- the fuzz and fault suite's tally: cases tried, clear errors, crashes or hangs, corrupt
# results accepted, per category, printed at the end of the run (also under xdist: every
# worker appends to one file in the session's temporary root) -------------------------------
TALLY_FILE = "fuzz-tally.jsonl"
# crashes: a traceback (an exception other than the door's own error) or a signal; hangs: no
# answer within the case's time limit
TALLY_COLUMNS = ("tried", "clear_errors", "crashes", "hangs", "corrupt_accepted")


def _session_root(basetemp: Path) -> Path:
    return basetemp.parent if basetemp.name.startswith("popen-") else basetemp


@pytest.fixture
def fuzz_tally(tmp_path_factory):
    """``record(category, tried=, clear_errors=, crashes=, hangs=, corrupt_accepted=)``."""
    path = _session_root(tmp_path_factory.getbasetemp()) / TALLY_FILE

    def record(category: str, **counts: int) -> None:
        assert set(counts) == set(TALLY_COLUMNS), counts
        with open(path, "a", encoding="utf-8") as handle:
            handle.write(json.dumps({"category": category, **counts}) + "\n")

    return record


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if hasattr(config, "workerinput"):
        return
    path = _session_root(config._tmp_path_factory.getbasetemp()) / TALLY_FILE
    if not path.is_file():
        return
    totals: dict[str, dict[str, int]] = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        entry = json.loads(line)
        row = totals.setdefault(entry.pop("category"), dict.fromkeys(TALLY_COLUMNS, 0))
        for key in TALLY_COLUMNS:
            row[key] += entry[key]
    terminalreporter.section("fuzz and fault suite")
    terminalreporter.write_line(f"{'category':34s}" + "".join(f"{c:>18s}" for c in TALLY_COLUMNS))
    for category, row in sorted(totals.items()):
        terminalreporter.write_line(
            f"{category:34s}" + "".join(f"{row[c]:>18d}" for c in TALLY_COLUMNS)
        )


@pytest.fixture(scope="session")
def serial_sweep(tmp_path_factory):
    """The shared tiny sweep (tests/sweep_cases.py) run serially: (SweepRun, table rows), the
    reference the other executors must reproduce."""
    from sweep_cases import SPEC

    from optim.sweep import load_spec, read_table, run_sweep

    directory = tmp_path_factory.mktemp("serial")
    run = run_sweep(load_spec(SPEC), directory, executor="serial", progress=False)
    return run, read_table(directory / "results.csv")
