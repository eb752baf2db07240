"""The real cell's figures, as JSON: obstacles and via points, cup forces, stress, compliant cups.

    python -m optim.bench.cell [--cases press accuracy constraints cups convergence]
                                [-o cell_bench.json]

* press: the built-in plate (1.5 x 0.8 m, 20 modes) laid into a press opening through a via
  point: the optimised move against the ruckig move through the same via point plus decay,
  both certified against a 10 mm distance to the dies;
* accuracy: cup reactions (sum = m a on a stiff part; FE plate against the full-order
  transient), modal stress of a simply supported plate against the closed form, the von
  Mises peak against the full-order transient;
* constraints: the extra wall time of each constraint on the demo scene (FE plate, 1 m
  vertical move, 2 / 10 / 100 limits, 0.5 mm; after one untimed run that compiles), at its
  default limit and at a limit 15 % below what the unconstrained optimum reaches (active);
* cups: rigid, flat and bellows cups on the built-in plate and panel: first frequencies and
  the optimised cycle time;
* convergence: the panel's first frequencies over four meshes with rigid, flat and bellows
  cups;
* speed: the README's press commands as a user types them (``jaxflex model --scene plate``,
  then ``jaxflex optimize plate.npz --cell examples/press_cell.toml --min-distance 0.01
  --cup-safety 1.5 --max-stress --threshold 5e-4``: nominal, ``--no-plots``, ``--robust`` at
  the default grid, the active distance-and-stress run with ``--max-stress 68e6``, 85 % of
  what the unconstrained press move reaches, and a robust plan under ``--max-time 10``, which
  is refused), CPU seconds of each command's process (optim.bench.commands.timed_run), the
  compile cache warm (one untimed run first), and each answer (steps, cycle, worst case).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import fem
import optim
from fem.outputs import reaction_outputs, stress_outputs
from jaxflex.defaults import DT_S, THRESHOLD_M
from jaxflex.files import write_text_atomic
from jaxflex.geometry import Box, Cell, min_distance
from jaxflex.response import (
    CupUtilisation,
    VonMises,
    acceleration_at,
    as_move,
    output_peak,
    outputs_at,
)
from optim.bench.commands import timed_run
from optim.cell_file import load_cell
from optim.ruckig_move import kinematic_floor_move

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
CASES = ("press", "accuracy", "constraints", "cups", "convergence", "speed")
PRESS_ARGS = (*("--min-distance", "0.01", "--cup-safety", "1.5", "--threshold", "5e-4", "-q"),)
ACTIVE_STRESS_PA = 68e6  # 85 % of the 80 MPa the unconstrained press move reaches
LIMITS = optim.Limits(2.0, 10.0, 100.0)
DT = DT_S
THRESHOLD = THRESHOLD_M
GRAVITY = np.array([0.0, 0.0, -9.81])
KINDS = (None, "flat", "bellows")


def _plate_model(stiffness=None, scene: str = "plate", n_modes: int = 20, points=300, **kw):
    part, cups = fem.scene(scene, **kw)
    cups = [replace(c, stiffness=stiffness) for c in cups]
    tick = time.perf_counter()
    result = fem.modal_analysis(part, cups, n_modes=n_modes, zeta=0.02, progress=False)
    model = result.to_modal_model(points=points)
    return model, result, time.perf_counter() - tick


def press_cell() -> Cell:
    """The press-opening scene of examples/press_cell.toml (the built-in plate is picked at
    z = 0.1 m and laid 0.1 m above the lower die of a press whose opening starts at
    x = 2.2 m, through a via point)."""
    return load_cell(EXAMPLES / "press_cell.toml")


def press() -> dict:
    model, _, fe_s = _plate_model()
    cell = press_cell()
    tick, cpu = time.perf_counter(), time.process_time()
    result = optim.optimize(
        model,
        None,
        LIMITS,
        DT,
        THRESHOLD,
        search=optim.Search(progress=False),
        constraints=optim.Constraints(cell=cell, min_distance_m=0.01),
    )
    wall, cpu = time.perf_counter() - tick, time.process_time() - cpu
    (baseline,) = result.baselines.entries
    straight = as_move(kinematic_floor_move(cell.distance_m, LIMITS, DT, 3000).acc, DT)
    posed = cell.posed(model)
    return {
        "model": repr(model),
        "fe_s": fe_s,
        "optimised": {
            "cycle_time_s": result.cycle_time_s,
            "transfer_time_s": result.transfer_time_s,
            "distance": result.constraints[0],
            "wall_s": wall,
            "cpu_s": cpu,
        },
        "baseline": {
            "name": baseline.name,
            "cycle_time_s": baseline.cycle_time_s,
            "transfer_time_s": baseline.timing.transfer_time_s,
            "feasible": baseline.constraints_ok,
            "distance": baseline.constraints[0],
        },
        "kinematic_floor_s": result.baselines.kinematic_floor_s,
        "straight_move_min_distance_m": min_distance(posed, cell.obstacles, straight).distance_m,
    }


def accuracy() -> dict:
    out = {}
    steel = fem.PRESETS["steel"]
    stiff = fem.Material("stiff steel", steel.E_pa * 1e6, steel.nu, steel.rho_kg_m3)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.15, 0.45) for y in (0.1, 0.3)]
    t = np.linspace(0, 0.3, 61)
    acc = np.zeros((21, 3))
    acc[:, :] = np.outer(np.sin(2 * np.pi * np.arange(21) / 20), [10.0, -5.0, 20.0])
    acc[[0, -1]] = 0
    move = as_move(acc, DT)
    for name, part in (
        ("plate", fem.rectangular_plate(0.6, 0.4, 1e-3, stiff, 0.05)),
        ("panel", fem.curved_panel(0.6, 0.4, 1e-3, stiff, 0.1)),
    ):
        result = fem.modal_analysis(part, cups, n_modes=6, zeta=0.02)
        model = result.to_modal_model(points=10)
        forces = outputs_at(model, model.cups.reaction, move, t).reshape(len(t), 4, 6)
        expected = result.mass_kg * acceleration_at(move, t)
        error = np.abs(forces[..., :3].sum(axis=1) - expected).max()
        out[f"stiff_{name}_sum_error_rel_peak"] = float(error / np.abs(expected).max())
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, "steel", 0.025)
    damping = fem.Rayleigh.from_zeta(0.02, 40.0, 400.0)
    for n_modes in (10, 20, 40):
        result = fem.modal_analysis(part, cups, n_modes=n_modes, zeta=damping)
        model = result.to_modal_model(points=30)
        full = fem.transient_reference(
            result, move, points=model.points, extend_s=0.1, substeps=100,
            output_substeps=4,
            outputs={"cups": reaction_outputs(result), "stress": stress_outputs(result)[1]},
        )  # fmt: skip
        ours = outputs_at(model, model.cups.reaction, move, full.t_s).reshape(-1, 4, 6)
        ref = full.outputs["cups"].reshape(ours.shape)
        vm = VonMises(model.stress.n_points)
        items = np.arange(vm.n_items)
        s_ours = outputs_at(model, model.stress.stress, move, full.t_s)
        s_ref = full.outputs["stress"]
        vm_ours = vm.values(s_ours.reshape(len(full.t_s), -1, 6), items)
        vm_ref = vm.values(s_ref.reshape(len(full.t_s), -1, 6), items)
        out[f"fe_plate_{n_modes}_modes"] = {
            "force_error_rel_peak": float(
                np.abs(ours[..., :3] - ref[..., :3]).max() / np.abs(ref[..., :3]).max()
            ),
            "moment_error_rel_peak": float(
                np.abs(ours[..., 3:] - ref[..., 3:]).max() / np.abs(ref[..., 3:]).max()
            ),
            "von_mises_peak_ratio": float(vm_ours.max() / vm_ref.max()),
            "von_mises_peak_mpa": float(vm_ref.max() / 1e6),
            "transient_s": full.timings_s["integration_s"],
        }
    return out


def _peaks(model, move):
    cup = output_peak(
        model, model.cups.reaction, CupUtilisation(model.cups, 1.0), move,
        offset=model.cups.reaction.offset(GRAVITY),
    )  # fmt: skip
    stress = output_peak(
        model, model.stress.stress, VonMises(model.stress.n_points), move,
        offset=model.stress.stress.offset(GRAVITY),
    )  # fmt: skip
    return cup.value, stress.value


def constraints() -> dict:
    model, _, _ = _plate_model()
    distance = [0.0, 0.0, 1.0]
    runs = {}

    def timed(label, **constraints):
        tick, cpu = time.perf_counter(), time.process_time()
        result = optim.optimize(
            model, distance, LIMITS, DT, THRESHOLD, constraints=optim.Constraints(**constraints),
            search=optim.Search(progress=False),
        )  # fmt: skip
        runs[label] = {
            "wall_s": time.perf_counter() - tick,
            "cpu_s": time.process_time() - cpu,
            "cycle_time_s": result.cycle_time_s,
            "constraints": result.constraints,
        }
        return result

    # the first run compiles the engine's JAX functions: not part of any constraint's cost
    optim.optimize(model, distance, LIMITS, DT, THRESHOLD, search=optim.Search(progress=False))
    plain = timed("none")
    cup0, stress0 = _peaks(model, plain.move)
    # a ceiling 15 mm above the part's highest point at rest at B
    top = np.asarray(model.points)[:, 2].max() + 1.0
    ceiling = Cell(
        obstacles=(Box([0.75, 0.4, top + 0.015 + 0.05], [3.0, 3.0, 0.1], name="ceiling"),),
        end_m=distance,
    )
    timed("cups, safety 1.5 (default rating)", cup_safety=1.5)
    timed("stress, yield / 1.5", max_stress_pa="yield")
    timed("distance 10 mm, ceiling 15 mm above B", cell=ceiling, min_distance_m=0.01)
    timed("cups, active", cup_safety=1.0 / (0.85 * cup0))
    timed("stress, active", max_stress_pa=0.85 * stress0)
    return {
        "unconstrained_peaks": {
            "cup_utilisation_at_safety_1": cup0,
            "von_mises_pa": stress0,
        },
        "runs": runs,
    }


def cups() -> dict:
    out = {}
    for scene in ("plate", "panel"):
        for kind in KINDS:
            model, result, fe_s = _plate_model(kind, scene)
            tick = time.perf_counter()
            opt = optim.optimize(
                model, [0, 0, 1.0], LIMITS, DT, THRESHOLD, search=optim.Search(progress=False)
            )
            out[f"{scene}, {kind or 'rigid'}"] = {
                "freq_hz": [float(f) for f in result.freq_hz[:8]],
                "cycle_time_s": opt.cycle_time_s,
                "transfer_time_s": opt.transfer_time_s,
                "optimise_s": time.perf_counter() - tick,
                "fe_s": fe_s,
            }
    return out


def convergence(sizes=(0.05, 0.0354, 0.025, 0.0177)) -> dict:
    out = {}
    for kind in KINDS:
        rows = []
        for size in sizes:
            part, cups = fem.scene("panel", mesh_size=size)
            cups = [replace(c, stiffness=kind) for c in cups]
            tick = time.perf_counter()
            result = fem.modal_analysis(part, cups, n_modes=6, zeta=0.02, progress=False)
            rows.append(
                {
                    "mesh_size_m": size,
                    "n_dof": result.system.n_dof,
                    "freq_hz": [float(f) for f in result.freq_hz],
                    "fe_s": time.perf_counter() - tick,
                }
            )
        freqs = np.array([r["freq_hz"] for r in rows])
        changes = np.abs(np.diff(freqs, axis=0)) / freqs[1:]
        out[kind or "rigid"] = {
            "meshes": rows,
            "largest_change_between_meshes": [float(c) for c in changes.max(axis=1)],
        }
    return out


def speed() -> dict:
    """The README's press commands (module docstring), CPU seconds of each process."""
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        model = str(work / "plate.npz")
        env = dict(os.environ)
        out = {"model": timed_run(["model", "--scene", "plate", "-o", model, "-q"], env)}

        def optimize(name: str, *extra: str) -> dict:
            where = work / name
            argv = ["optimize", model, "--cell", str(EXAMPLES / "press_cell.toml"), *PRESS_ARGS]
            run = timed_run([*argv, *extra, "-o", str(where)], env)
            report = json.loads((where / "report.json").read_text(encoding="utf-8"))
            worst = report.get("worst_case") or {}
            return {
                **run,
                "n_steps": report["n_steps"],
                "cycle_time_s": report["cycle_time_s"],
                "worst_cycle_time_s": worst.get("cycle_time_s"),
                "nominal_tests": len(report["solver_stats"].get("nominal_attempts", [])),
                "tests": len(report["solver_stats"]["attempts"]),
                "constraints": {c["name"]: c["peak"] for c in report["constraints"]},
            }

        optimize("warm-up", "--max-stress", "--no-plots")  # fills the compile cache
        out["nominal"] = optimize("nominal", "--max-stress")
        out["nominal_no_plots"] = optimize("nominal_no_plots", "--max-stress", "--no-plots")
        out["robust"] = optimize("robust", "--max-stress", "--robust")
        out["active"] = optimize("active", "--max-stress", f"{ACTIVE_STRESS_PA:g}")
        out["refused"] = _refused(
            ["optimize", model, "--cell", str(EXAMPLES / "press_cell.toml"), *PRESS_ARGS,
             "--max-stress", "--robust", "--max-time", "10", "-o", str(work / "refused")],
            env,
        )  # fmt: skip
    out["nominal_no_longer_than_robust"] = out["nominal"]["n_steps"] <= out["robust"]["n_steps"]
    return out


def _refused(argv: list[str], env: dict) -> dict:
    """``jaxflex ARGV``, which the budget refuses (exit status 2): its CPU seconds and the
    message."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(
        [sys.executable, "-m", "jaxflex", *argv], capture_output=True, text=True, env=env
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"exit": proc.returncode, "cpu_s": cpu_s, "message": proc.stderr.strip()[-400:]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m optim.bench.cell", description=__doc__)
    parser.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    parser.add_argument("-o", "--output", default="cell_bench.json", help="JSON results")
    args = parser.parse_args(argv)
    runners = {
        "press": press,
        "accuracy": accuracy,
        "constraints": constraints,
        "cups": cups,
        "convergence": convergence,
        "speed": speed,
    }
    figures = {}
    for case in args.cases:
        tick = time.perf_counter()
        figures[case] = runners[case]()
        figures[case]["case_wall_s"] = time.perf_counter() - tick
        print(json.dumps({case: figures[case]}, indent=2), flush=True)
    write_text_atomic(args.output, json.dumps(figures, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
