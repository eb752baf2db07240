"""Finite-element scenes and the full-order reference of the accuracy bench.

* :class:`SceneSpec`: a part (the built-in plate or curved panel, or a smaller one for quick
  runs), its gripper, mesh, the modes to compute and the monitored points.
* :func:`knot_move`: the test move, piecewise linear with knots every 100 ms, so that it is
  the *same* profile when sampled at 10, 20 or 25 ms (the preprint's steps).
* :func:`fe_reference`: the full-order FE transient (``fem.transient_reference``, Newmark
  average acceleration) at a fine step h and at 2 h, combined by Richardson extrapolation
  (u_ref = (4 u_h - u_2h) / 3 removes Newmark's O(h^2) error); |u_ref - u_h| is reported as
  the error estimate of the plain fine run. Output every 1 ms by default.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

import fem
from jaxflex.errors import InputError
from jaxflex.response import as_move

KNOT_S = 0.1  # knot spacing of the move: a multiple of every swept dt (10, 20, 25 ms)
BASE_S = 0.005  # the move is handed to the FE transient at this step (divides 10, 20, 25 ms)


@dataclass(frozen=True)
class SceneSpec:
    """One scene of the accuracy bench (SI units).

    name: "plate" or "panel" (curved); element: fem's formulation (None: "morley" for the
    plate, "hex2" thin solid for the panel; the plate also takes "argyris" and "hex2").
    width_m, height_m: footprint; mesh_size_m: element size (None: fem's default);
    cup_radius_m: four cups at 22 %/78 % of width and height (fem.default_gripper).
    n_modes: modes computed (the largest count swept); mode_counts: counts swept.
    n_points: monitored points (voxel-reduced FE nodes); voxel_sizes_m: coarser point sets.
    omega1_h: omega_1 h of the finest FE step (the reference); move_s / rest_s: the move's
    duration and the rest after it; fe_factors: the FE method is also run at these multiples
    of the fine step (its own accuracy-time front); dt_sweep_s: sample steps swept (the
    first is the base case); newmark_substeps: Newmark steps per sample swept;
    output_per_base: reference outputs per BASE_S (5: every 1 ms); knot_s: knot spacing of
    the move (the default 100 ms suits every swept dt; shorter moves for stiff test parts);
    direction: of the move (normalised).
    """

    name: str
    width_m: float = 1.5
    height_m: float = 0.8
    mesh_size_m: float | None = None
    cup_radius_m: float = 0.04
    element: str | None = None
    n_modes: int = 80
    mode_counts: tuple[int, ...] = (10, 20, 40, 80)
    n_points: int = 1000
    voxel_sizes_m: tuple[float, ...] = (0.1, 0.2)
    omega1_h: float = 0.01
    move_s: float = 0.6
    rest_s: float = 0.6
    fe_factors: tuple[int, ...] = (4,)
    dt_sweep_s: tuple[float, ...] = (0.01, 0.02, 0.025)
    newmark_substeps: tuple[int, ...] = (1, 8)
    output_per_base: int = 5
    knot_s: float = KNOT_S
    direction: tuple[float, float, float] = (0.3, 0.0, 1.0)

    @property
    def key(self) -> str:
        """Name of the scene in reports and chart files: "plate", "plate_argyris", ..."""
        return self.name if self.element is None else f"{self.name}_{self.element}"

    def describe(self) -> dict:
        return asdict(self)


def knot_move(
    dt_s: float,
    move_s: float,
    rest_s: float,
    peak_m_s2: float = 8.0,
    knot_s: float = KNOT_S,
    direction=(0.3, 0.0, 1.0),
) -> np.ndarray:
    """Rest-to-rest move along ``direction`` sampled every ``dt_s`` (s): acceleration ramps
    up, holds, ramps down, then the mirror image (braking), each phase ``move_s`` / 6 long
    (a multiple of ``knot_s``), followed by ``rest_s`` at rest: (n+1, 3) in m/s^2."""
    phase = move_s / 6
    if abs(phase / knot_s - round(phase / knot_s)) > 1e-9 or round(phase / knot_s) < 1:
        raise InputError(f"move_s: must be a multiple of {6 * knot_s:g} s, got {move_s}")
    steps = (move_s + rest_s) / dt_s
    if abs(steps - round(steps)) > 1e-9 or abs(knot_s / dt_s - round(knot_s / dt_s)) > 1e-9:
        raise InputError(f"dt_s: {knot_s} s and the horizon must be multiples of it, got {dt_s}")
    t = np.arange(round(steps) + 1) * dt_s
    knots_t = phase * np.arange(7)
    knots_a = peak_m_s2 * np.array([0, 1, 1, 0, -1, -1, 0], dtype=float)
    shape = np.interp(t, knots_t, knots_a, right=0.0)
    unit = np.asarray(direction, dtype=float)
    acc = np.outer(shape, unit / np.linalg.norm(unit))
    acc[[0, -1]] = 0.0
    return acc


def move_of(spec: SceneSpec, dt_s: float, rest: bool = True) -> np.ndarray:
    """:func:`knot_move` of ``spec`` sampled every ``dt_s`` (with or without the rest)."""
    rest_s = spec.rest_s if rest else 0.0
    return knot_move(dt_s, spec.move_s, rest_s, knot_s=spec.knot_s, direction=spec.direction)


def build_scene(spec: SceneSpec, progress: bool | None = None):
    """Modal analysis of ``spec`` and the Rayleigh damping with 2 % at its first and 10th
    mode (pass it to ``to_modal_model(zeta=)`` and the transient so that both agree):
    (fem.ModalResult, fem.Rayleigh, seconds)."""
    start = time.perf_counter()
    factories = {"plate": (fem.rectangular_plate, "morley"), "panel": (fem.curved_panel, "hex2")}
    if spec.name not in factories:
        raise InputError(f"scene: must be 'plate' or 'panel', got {spec.name!r}")
    make, default_element = factories[spec.name]
    part = make(
        spec.width_m,
        spec.height_m,
        1e-3,
        "steel",
        spec.mesh_size_m,
        element=spec.element or default_element,
    )
    cups = fem.default_gripper(spec.width_m, spec.height_m, spec.cup_radius_m)
    result = fem.modal_analysis(part, cups, spec.n_modes, zeta=0.02, progress=progress)
    f_ref = result.freq_hz[min(10, result.n_modes) - 1]
    damping = fem.Rayleigh.from_zeta(0.02, float(result.freq_hz[0]), float(f_ref))
    return result, damping, time.perf_counter() - start


@dataclass
class Reference:
    """Full-order FE transient at the monitored points (SI units).

    t_s (T,), displacement_m (T, K, 3): Richardson-extrapolated reference; points (K, 3);
    runs: {factor: (displacement (T, K, 3), integration seconds)} for the plain Newmark runs
    at ``factor`` times the fine step h_s (factor 1 = the fine run).
    """

    t_s: np.ndarray
    displacement_m: np.ndarray
    points: np.ndarray
    h_s: float
    runs: dict
    n_dof: int

    @property
    def deviation_m(self) -> np.ndarray:
        return np.linalg.norm(self.displacement_m, axis=2).max(axis=1)


def fe_reference(result, damping, spec: SceneSpec, progress: bool | None = None) -> Reference:
    """Full-order transient of ``result`` under :func:`knot_move` at the fine step (omega_1 h
    = spec.omega1_h), at 2 h (Richardson) and at the multiples ``spec.fe_factors`` of h."""
    base = BASE_S
    acc = move_of(spec, base, rest=False)
    omega1 = 2 * np.pi * float(result.freq_hz[0])
    factors = sorted({1, 2, *spec.fe_factors})
    lcm = math.lcm(*factors) * spec.output_per_base
    substeps = lcm * max(1, math.ceil(omega1 * base / spec.omega1_h / lcm))
    runs, points = {}, None
    for factor in factors:
        run = fem.transient_reference(
            result,
            as_move(acc, base),
            damping=damping,
            points=spec.n_points if points is None else points,
            substeps=substeps // factor,
            output_substeps=spec.output_per_base,
            extend_s=spec.rest_s,
            progress=progress,
        )
        points = run.points if points is None else points
        runs[factor] = (run.displacement_m, run.timings_s["integration_s"])
        t_s = run.t_s
    extrapolated = (4 * runs[1][0] - runs[2][0]) / 3
    return Reference(
        t_s=t_s,
        displacement_m=extrapolated,
        points=points,
        h_s=base / substeps,
        runs=runs,
        n_dof=int(result.K_free.shape[0]),
    )
