"""Shared fixtures: exact analytic models, small random models, the CLI as a user runs it."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import jaxflex
from jaxflex.analytic import simply_supported_plate


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


@pytest.fixture(scope="session")
def serial_sweep(tmp_path_factory):
    """The shared tiny sweep (tests/sweep_cases.py) run serially: (SweepRun, table rows), the
    reference the other executors must reproduce."""
    from sweep_cases import SPEC

    from optim.sweep import parse_spec, read_table, run_sweep

    directory = tmp_path_factory.mktemp("serial")
    run = run_sweep(parse_spec(SPEC), directory, executor="serial", progress=False)
    return run, read_table(directory / "results.csv")
