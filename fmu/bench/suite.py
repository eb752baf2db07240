"""``jaxflex bench``: the whole benchmark in one run, written to a directory.

Sections of ``bench.json`` (SI units; times in s unless the key says ms):

* ``case``, ``machine``, ``targets``, ``results``: the core speed figures
  (:mod:`fem.bench.core`; K=1099 points, M=40 modes, N=1000 steps in the full run);
* ``accuracy``: per scene (plate, panel) every accuracy-time point of every method, the
  reduced-vs-full-order FE agreement per mode count and the dominance check
  (:mod:`fem.bench.accuracy`); charts ``pareto_plate.png``, ``pareto_panel.png``;
* ``stability``: where each method breaks against omega dt (:mod:`fem.bench.stability`);
  chart ``stability.png``;
* ``nodes``: every node, no reduction (:mod:`fem.bench.nodes`): forward deviation and
  exact cycle time at full-mesh sizes (``scale``) and what voxel reduction of the monitored
  points costs in peak deviation and settle time (``reduction``);
* ``commands``: wall and CPU time of ``jaxflex optimize`` as a user runs it, with an empty
  JAX compilation cache (cold) and again (warm), and of ``jaxflex demo`` in the full run
  (:mod:`optim.bench.commands`);
* ``turning``: a warm ``jaxflex.simulate_turning`` against a warm ``jaxflex.simulate`` of
  the same samples, CPU seconds, on the built-in curved panel (:mod:`fem.bench.turning`;
  full and medium runs).

Four sizes: ``full`` (the built-in scenes, minutes), ``medium`` (small scenes, the sweeps
of the full run; about a minute), ``quick`` (CI: small scenes, a few points per sweep) and
``tiny`` (the small plate alone, for the notebook's quick mode).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

import fem
from fem.bench.accuracy import run_scene
from fem.bench.charts import pareto_chart, stability_chart
from fem.bench.core import QUICK as QUICK_CORE
from fem.bench.core import BenchCase, run_bench
from fem.bench.fe import SceneSpec
from fem.bench.nodes import format_nodes, run_reduction, run_scale
from fem.bench.stability import OMEGA_DT, run_stability
from fem.bench.turning import format_turning
from fem.bench.turning import run as run_turning
from jaxflex.errors import InputError
from jaxflex.files import make_output_dir, write_text_atomic
from jaxflex.runtime import step
from optim.bench.commands import format_commands, run_commands
from optim.bench.targets import scene_model

SMALL_PLATE = SceneSpec(
    "plate",
    mesh_size_m=0.1,
    n_modes=40,
    mode_counts=(10, 20, 40),
    n_points=300,
    voxel_sizes_m=(0.15,),
    omega1_h=0.05,
    move_s=0.6,
    rest_s=0.3,
    fe_factors=(4,),
)
QUICK_SWEEPS = {
    "dt_sweep_s": (0.01, 0.025),
    "output_per_base": 1,
    "fe_factors": (),
    "newmark_substeps": (1, 8),
}
QUICK_PLATE = replace(SMALL_PLATE, mode_counts=(10, 40), **QUICK_SWEEPS)
# A smaller curved panel (the built-in curvature) with large cups: ~7k DOFs instead of 46k+.
# It is stiff (first mode ~300 Hz), so its reference step is coarse (omega_1 h ~ 1-2): a
# plumbing check, not a figure to quote.
SMALL_PANEL = replace(
    SMALL_PLATE,
    name="panel",
    width_m=0.6,
    height_m=0.4,
    mesh_size_m=0.3,
    cup_radius_m=0.08,
    n_modes=30,
    mode_counts=(10, 30),
    n_points=200,
    voxel_sizes_m=(0.1,),
    omega1_h=1.0,
    rest_s=0.1,
)
QUICK_PANEL = replace(
    SMALL_PANEL,
    omega1_h=2.0,
    mode_counts=(30,),
    voxel_sizes_m=(),
    **{**QUICK_SWEEPS, "dt_sweep_s": (0.01,), "newmark_substeps": (1,)},
)
FULL_SCENE = SceneSpec(
    "plate",
    n_modes=120,
    mode_counts=(10, 20, 40, 80, 120),
    n_points=1000,
    voxel_sizes_m=(0.05, 0.1, 0.2),
    omega1_h=0.01,
    move_s=0.6,
    rest_s=0.6,
)
# The FE formulation as a swept parameter: one small flat plate (0.6 x 0.4 m, four 50 mm cups)
# in each element family, each against its own full-order transient.
ELEMENT_SCENES = tuple(
    SceneSpec(
        "plate",
        width_m=0.6,
        height_m=0.4,
        mesh_size_m=mesh_m,
        cup_radius_m=0.05,
        element=element,
        n_modes=120,
        mode_counts=(10, 40, 120),
        n_points=300,
        voxel_sizes_m=(),
        omega1_h=0.05,
        move_s=0.6,
        rest_s=0.3,
        dt_sweep_s=(0.01,),
    )
    for element, mesh_m in (("morley", 0.02), ("argyris", 0.05), ("hex2", 0.05))
)
SIZES = {
    # the notebook's quick mode (speed_vs_accuracy.ipynb): the small plate only, no all-node
    # section
    "tiny": {
        "core": QUICK_CORE,
        "scenes": (QUICK_PLATE,),
        "omega_dt": OMEGA_DT[::6],
        "drift_steps": (1_000, 10_000),
        "min_time_s": 0.005,
    },
    "quick": {
        "core": QUICK_CORE,
        "scenes": (QUICK_PLATE, QUICK_PANEL),
        "omega_dt": OMEGA_DT[::3],
        "drift_steps": (1_000, 10_000),
        "min_time_s": 0.01,
        "nodes": {"sizes": (1_099, 5_000), "large": None, "reduction": (("plate", 0.1),)},
        "reduction_counts": (100, 30),
        "commands": {"model": "few-mode", "repeats": 1, "demo": False},
    },
    "medium": {
        "core": QUICK_CORE,
        "scenes": (
            replace(SMALL_PLATE, mode_counts=(5, 10, 20, 40)),
            SMALL_PANEL,
        ),
        "omega_dt": OMEGA_DT,
        "drift_steps": (1_000, 10_000, 100_000),
        "min_time_s": 0.05,
        "nodes": {"sizes": (1_099, 66_308), "large": None, "reduction": (("plate", None),)},
        "reduction_counts": (1_099, 300, 100),
        "commands": {"model": "fem-plate", "repeats": 1, "demo": False},
        "turning": "panel",
    },
    "full": {
        "core": BenchCase(),
        "scenes": (
            # the built-in plate at fem's default mesh (15 mm Morley, ~30k DOFs)
            replace(FULL_SCENE, n_modes=160, mode_counts=(10, 20, 40, 80, 160)),
            # the built-in panel (geometry and cups) at a 100 mm base mesh (~46k DOFs; the
            # 25 mm default has 100k and a full-order transient of ~40 min here)
            replace(
                FULL_SCENE,
                name="panel",
                mesh_size_m=0.1,
                omega1_h=0.05,
                rest_s=0.3,
            ),
            *ELEMENT_SCENES,
        ),
        "omega_dt": OMEGA_DT,
        "drift_steps": (1_000, 10_000, 100_000),
        "min_time_s": 0.1,
        "nodes": {
            "sizes": (1_099, 66_308),
            "large": 1_000_000,
            "reduction": (("plate", None), ("panel", None)),
        },
        "reduction_counts": (1_099, 300, 100),
        # the issue's figures: the demo plate, three rounds, and the demo
        "commands": {"model": "fem-plate", "repeats": 3, "demo": True},
        "turning": "panel",
    },
}


def run_suite(
    out_dir: str | os.PathLike,
    size: str = "full",
    *,
    progress: Callable[[str], None] = step,
    fe_progress: bool | None = None,
    json_path: str | os.PathLike | None = None,
) -> dict:
    """Run every section at ``size`` ("tiny", "quick", "medium", "full"), write ``bench.json`` (or
    ``json_path``) and the PNG charts into ``out_dir``; returns the report."""
    if size not in SIZES:
        raise InputError(f"size: must be one of {list(SIZES)}, got {size!r}")
    cfg = SIZES[size]
    out = make_output_dir(out_dir)
    start = time.perf_counter()
    report = run_bench(cfg["core"], progress=progress)
    report["size"] = size
    report["accuracy"] = {}
    report["charts"] = {}
    for spec in cfg["scenes"]:
        scene = run_scene(
            spec, min_time_s=cfg["min_time_s"], progress=progress, fe_progress=fe_progress
        )
        report["accuracy"][spec.key] = scene
        chart = out / f"pareto_{spec.key}.png"
        pareto_chart(scene, chart)
        report["charts"][f"pareto_{spec.key}"] = chart.name
    progress("stability sweep (one mode against omega dt) ...")
    report["stability"] = run_stability(cfg["omega_dt"], cfg["drift_steps"])
    stability_chart(report["stability"], out / "stability.png")
    report["charts"]["stability"] = "stability.png"
    if "nodes" in cfg:  # not in the notebook's "tiny" size
        report["nodes"] = run_nodes(cfg["nodes"], cfg["reduction_counts"], progress=progress)
    if "commands" in cfg:  # not in the notebook's "tiny" size
        spec = cfg["commands"]
        model = scene_model(spec["model"])
        report["commands"] = run_commands(
            model, repeats=spec["repeats"], demo=spec["demo"], progress=progress
        )
    if "turning" in cfg:  # the built-in scene's model, from the FE store after a first run
        model = fem.default_model(cfg["turning"], progress=False, cache=True)
        report["turning"] = run_turning(model, progress=progress)
    report["wall_s"] = time.perf_counter() - start
    path = Path(json_path) if json_path is not None else out / "bench.json"
    write_text_atomic(path, json.dumps(report, indent=1, default=_json_default))
    report["json_path"] = str(path)
    return report


def run_nodes(spec: dict, counts: tuple[int, ...], *, progress: Callable[[str], None]) -> dict:
    """The all-node section: scale figures and the reduction study of each listed scene."""
    scale = run_scale(spec["sizes"], spec["large"], progress=progress)
    reduction = [
        run_reduction(name, counts, mesh_size_m=mesh, progress=progress)
        for name, mesh in spec["reduction"]
    ]
    return {"scale": scale, "reduction": reduction}


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def summary_lines(report: dict) -> list[str]:
    """The accuracy and stability findings as text lines (the CLI prints them)."""
    lines = []
    for name, scene in report.get("accuracy", {}).items():
        fe = scene["fe"]
        lines.append(
            f"{name}: {fe['formulation']}, {fe['n_dof']} DOFs, {fe['n_points']} points, "
            f"reference h = {fe['reference_h_s']:.3g} s "
            f"({fe['reference_integration_s']:.1f} s of FE integration)"
        )
        for row in scene["agreement"]:
            lines.append(
                f"  {row['n_modes']:4d} modes: deviation R^2 {row['deviation_r2']:.7f}, "
                f"L-inf {100 * row['deviation_linf_rel_peak']:.3f} % of peak; displacement "
                f"R^2 {row['displacement_r2']:.7f}, L-inf "
                f"{100 * row['displacement_linf_rel_peak']:.3f} %; settle "
                f"{1e3 * row['settle_error_s']:+.2f} ms"
                + ("  [meets target]" if row["meets_target"] else "")
            )
        dom = scene["dominance"]
        lines.append(
            f"  exact scan dominates {dom['dominated']} of {dom['other_points']} points of "
            "other methods"
            + (
                "; not: "
                + ", ".join(
                    f"{e['method']} (dt {e['dt_s']:.3g} s, {e['time_s']:.2g} s, "
                    f"err {e[dom['metric']]:.2g})"
                    for e in dom["exceptions"]
                )
                if dom["exceptions"]
                else ""
            )
        )
    if "nodes" in report:
        lines.extend(format_nodes(report["nodes"]).splitlines())
    if "commands" in report:
        lines.extend(format_commands(report["commands"]))
    if "turning" in report:
        lines.append(format_turning(report["turning"]))
    stab = report.get("stability")
    if stab:
        for key, values in stab["breaks_at_omega_dt"].items():
            text = ", ".join(f"{m} {'never' if w is None else w}" for m, w in values.items())
            lines.append(f"stability, first omega dt with {key.replace('_', ' ')}: {text}")
    return lines
