"""FMU speed at C level: one communication step and one instantiation.

A small C harness (fmu/c/harness.c) dlopen()s the exported FMU's library like an importer,
times many instantiations and a long run of communication steps (back-to-back 1 s moves;
inputs and input derivatives set and the scalar outputs read every step; timed in chunks of
100 steps, so the median is robust against other processes on the machine), and prints the
figures as JSON.

    python -m fmu.bench.steps            # K = 1099 points, M = 40 modes, FMI 2.0 and 3.0
    python -m fmu.bench.steps --scene plate  # the default model: every node of the plate
    python -m fmu.bench.steps --scene plate --cell examples/press_cell.toml  # + min_distance
    python -m fmu.bench.steps --windows  # also: the Windows DLL under wine (fmu.windows)
    python -m fmu.bench.steps --hosts    # also: FMU and SSP in other hosts (fmu.crosscheck)
    python -m fmu.bench.steps --points 66308 --fmi 3 --array  # every node, read each step
    python -m fmu.bench.steps --turning  # a turning part: the pose inputs set every step too

The synthetic model (random shapes without spatial order) is the worst case of the pruned
evaluation of the scalar outputs (jxf_blocks.c): no block's bound excludes it, so every
point is evaluated; a real part's smooth mode shapes let most blocks be skipped.

Targets (docs/design.md): one step <= 30 us for the synthetic K = 1099, M = 40 (the
preprint's FMU: 0.85 ms per 10 ms step) and <= 20 us for the plate at every node (7 854
points, 20 modes and the static residual); instantiation with a ~1 MB resource <= 10 ms.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import fem
from fmu.crosscheck import crosscheck_fmu, crosscheck_ssp
from fmu.export import export_fmu
from fmu.harness import compile_harness, resource_location, unpack
from fmu.options import CellOutputs, Fmi, Turning
from fmu.ssp import export_ssp
from fmu.windows import (
    replay,
    run_under_wine,
    windows_library,
    windows_path,
    windows_resource_location,
)
from jaxflex.defaults import DT_S, THRESHOLD_M
from jaxflex.geometry import Cell
from jaxflex.model import ModalModel
from jaxflex.response import RotationalInertia, as_move
from jaxflex.runtime import step
from optim.cell_file import load_cell

STEP_TARGET_US = 30.0
SCENE_STEP_TARGET_US = 20.0  # the built-in plate at every node (issue 32)
INSTANTIATE_TARGET_US = 10_000.0
PREPRINT_STEP_US = 850.0


def bench_model(n_points: int, n_modes: int, seed: int = 0, turning: bool = False) -> ModalModel:
    """A model of the benchmark size: frequencies 2-400 Hz, random shapes and participation
    (``turning``: and random inertia shape integrals of a 1 kg part)."""
    rng = np.random.default_rng(seed)
    rotation = None
    if turning:
        integrals = rng.normal(size=(n_modes, 3, 3)) * 0.1
        rotation = RotationalInertia(integrals, 1.0, np.zeros(3), np.eye(3) * 0.1)
    return ModalModel(
        freq_hz=np.geomspace(2.0, 400.0, n_modes),
        zeta=np.full(n_modes, 0.02),
        gamma=rng.normal(size=(n_modes, 3)),
        shapes=rng.normal(size=(n_points, 3, n_modes)) * 0.05,
        points=rng.uniform(size=(n_points, 3)),
        meta={"source": "fmu.bench.steps"},
        rotation=rotation,
    )


def _export_s(model: ModalModel, path: Path, version: int, windows: bool) -> float:
    t0 = time.perf_counter()
    export_fmu(model, path, fmi=Fmi(version, windows=windows))
    return time.perf_counter() - t0


def smooth_move(dt_s: float, duration_s: float = 1.0) -> np.ndarray:
    """A rest-to-rest move of about 1 m: one sine period of acceleration per axis, m/s^2."""
    t = dt_s * np.arange(round(duration_s / dt_s) + 1)
    acc = np.outer(2 * np.pi / duration_s**2 * np.sin(2 * np.pi * t / duration_s), [0.3, -0.2, 1.0])
    acc[[0, -1]] = 0.0
    return acc


def host_figures(model: ModalModel, version: int, folder: Path, dt_s: float) -> dict[str, Any]:
    """The SSP package of ``model`` moved by :func:`smooth_move` (threshold 0.5 mm) and the
    part FMU inside it, run in every available host: max |deviation - jaxflex| / peak per
    host (see fmu.crosscheck for which reference each host gets)."""
    folder.mkdir(parents=True, exist_ok=True)
    move = as_move(smooth_move(dt_s), dt_s)
    ssp = export_ssp(model, folder / "case.ssp", move, fmi=Fmi(version), threshold_m=THRESHOLD_M)
    with zipfile.ZipFile(ssp.ssp_path) as zf:
        part = Path(zf.extract("resources/part.fmu", folder))
    figures: dict[str, Any] = {"n_steps": None}
    for kind, report in (("fmu", crosscheck_fmu(part)), ("ssp", crosscheck_ssp(ssp.ssp_path))):
        figures["n_steps"] = report.n_steps
        figures[kind] = {
            r.host: {"reference": r.reference, "max_rel_diff": r.max_rel_diff} for r in report.runs
        }
        figures[f"{kind}_skipped"] = report.skipped
    return figures


def windows_figures(
    model: ModalModel, version: int, folder: Path, n_steps: int, dt_s: float, repeats: int
) -> dict[str, Any]:
    """The Windows DLL beside the Linux binary: export time without and with it (median of 3
    each, alternating), the harness's step and instantiation timing of the DLL under wine, and
    the largest difference between the outputs of a replayed 1 s move (300 steps) on the two
    platforms, relative to each output's peak."""
    folder.mkdir(parents=True, exist_ok=True)
    times = {False: [], True: []}
    for k in range(3):
        for dll in (False, True):
            times[dll].append(_export_s(model, folder / f"t{k}{int(dll)}.fmu", version, dll))
    linux_s, with_dll_s = (statistics.median(times[dll]) for dll in (False, True))
    move = as_move(smooth_move(dt_s), dt_s)
    result = export_fmu(model, folder / "move.fmu", move, fmi=Fmi(version, windows=True))
    harnesses = (
        compile_harness(version, folder / "harness"),
        compile_harness(version, folder / "harness.exe", windows=True),
    )
    linux = replay(result.fmu_path, folder / "linux", harnesses[0], 300, dt_s, windows=False)
    win = replay(result.fmu_path, folder / "windows", harnesses[1], 300, dt_s, windows=True)
    rel = {
        name: float(np.abs(win[name] - linux[name]).max() / max(np.abs(linux[name]).max(), 1e-300))
        for name in linux
        if name != "time"
    }
    library, resources, token = unpack(result.fmu_path, folder / "bench")
    args = [
        windows_path(windows_library(library, version)),
        windows_resource_location(version, resources),
        token,
        "bench",
        str(n_steps),
        repr(dt_s),
        str(repeats),
    ]
    timing = json.loads(run_under_wine([str(harnesses[1]), *args]))
    return {
        "export_s_linux_only": linux_s,
        "export_s_with_dll": with_dll_s,
        "dll_export_overhead_s": with_dll_s - linux_s,
        "replay_max_rel_diff_windows_vs_linux": max(rel.values()),
        "replay_rel_diff_by_output": rel,
        "wine": timing,
    }


CALLGRIND_STEPS = (300, 1300)  # two runs; their difference is the cost of 1000 steps


def instructions_per_step(harness_cmd: list[str], dt_s: float) -> float:
    """The mean number of instructions of one step of the harness's bench (inputs set, step,
    scalar outputs read), counted by valgrind's callgrind: two runs of CALLGRIND_STEPS
    steps, the difference over the difference of steps (instantiation and warm-up cancel).
    ``harness_cmd``: the harness, library, resource location and token."""
    counts = []
    for n_steps in CALLGRIND_STEPS:
        with tempfile.TemporaryDirectory(prefix="jaxflex_callgrind_") as tmp:
            cmd = [
                "valgrind", "--tool=callgrind", f"--callgrind-out-file={tmp}/out",
                *harness_cmd, "bench", str(n_steps), repr(dt_s), "1",
            ]  # fmt: skip
            proc = subprocess.run(cmd, capture_output=True, text=True, check=True)
        counts.append(int(re.search(r"Collected : (\d+)", proc.stderr).group(1)))
    return (counts[1] - counts[0]) / (CALLGRIND_STEPS[1] - CALLGRIND_STEPS[0])


@dataclass(frozen=True)
class Extras:
    """What a benchmark run adds to the plain FMU's step and instantiation times: a turning
    part's FMU with its pose inputs set every step (``turning``), FMI 3.0 reading the
    displaced points of every node after each step (``read_array``), the Windows DLL
    (``windows``: :func:`windows_figures`), other hosts (``hosts``: :func:`host_figures`),
    instructions per step (``instructions``: :func:`instructions_per_step`); ``turning`` is not
    for ``windows`` or ``hosts`` (they replay an embedded move)."""

    turning: bool = False
    read_array: bool = False
    windows: bool = False
    hosts: bool = False
    instructions: bool = False


NO_EXTRAS = Extras()


def run(
    n_points: int = 1099,
    n_modes: int = 40,
    n_steps: int = 20_000,
    dt_s: float = DT_S,
    repeats: int = 50,
    fmi_versions: tuple[int, ...] = (2, 3),
    progress: Callable[[str], None] | None = None,
    *,
    scene: str | None = None,
    cell: Cell | None = None,
    extras: Extras = NO_EXTRAS,
) -> dict[str, Any]:
    """Export a K x M model (``scene``: the built-in part of ``jaxflex model --scene``
    instead, every node; ``cell``: posed in it, with the distance outputs, ``min_distance``
    read every step), time ``n_steps`` steps of ``dt_s`` s and ``repeats`` instantiations
    with the C harness; figures per FMI version, with the ``extras`` asked for."""
    say = progress or (lambda msg: None)
    if scene is None:
        model = bench_model(n_points, n_modes, turning=extras.turning)
    else:
        say(f"the {scene} scene's model (jaxflex model --scene {scene})")
        model = fem.default_model(scene, cache=True)
    report: dict[str, Any] = {
        "command": f"{Path(sys.executable).name} -m fmu.bench.steps",
        "scene": scene,
        "n_points": model.n_points,
        "n_modes": model.n_modes,
        "static_residual": model.static_residual is not None,
        "dt_s": dt_s,
        "reads_displaced_points_array": extras.read_array,
        "reads_min_distance": cell is not None,
        "turning": extras.turning,
        "targets": {
            "step_us": STEP_TARGET_US if scene is None else SCENE_STEP_TARGET_US,
            "instantiate_us": INSTANTIATE_TARGET_US,
            "preprint_step_us": PREPRINT_STEP_US,
        },
    }
    with tempfile.TemporaryDirectory(prefix="jaxflex_fmu_bench_") as tmp:
        for version in fmi_versions:
            say(f"FMI {version}.0: export K={model.n_points}, M={model.n_modes}")
            folder = Path(tmp) / f"fmi{version}"
            folder.mkdir()
            timing = (n_steps, dt_s, repeats)
            figures = _step_figures(model, version, folder, cell, extras, timing, say)
            figures["meets_targets"] = (
                figures["step_us_median"] <= report["targets"]["step_us"]
                and figures["instantiate_us_median"] <= INSTANTIATE_TARGET_US
            )
            if extras.windows:
                say(f"FMI {version}.0: the Windows DLL (export times, replay, wine timing)")
                figures["windows"] = windows_figures(
                    model, version, folder / "windows", n_steps, dt_s, repeats
                )
            if extras.hosts:
                say(f"FMI {version}.0: FMU and SSP package in other hosts")
                figures["hosts"] = host_figures(model, version, folder / "hosts", dt_s)
            report[f"fmi{version}"] = figures
    return report


def _step_figures(model, version: int, folder: Path, cell, extras: Extras, timing, say) -> dict:
    """The harness's step and instantiation figures of ``model``'s FMI ``version`` FMU
    (``timing``: steps, step in s, instantiations), built and run in ``folder``."""
    n_steps, dt_s, repeats = timing
    result = export_fmu(
        model,
        folder / "bench.fmu",
        fmi=Fmi(version),
        outputs=CellOutputs(cell),
        turning=Turning() if extras.turning else None,
    )
    library, resources, token = unpack(result.fmu_path, folder / "fmu")
    array = model.n_points if extras.read_array and version == 3 else None
    harness = compile_harness(
        version, folder / "harness", array_points=array, turning=extras.turning,
        distance=cell is not None,
    )  # fmt: skip
    say(f"FMI {version}.0: {repeats} instantiations, {n_steps} steps")
    location = resource_location(version, resources)
    cmd = [str(harness), str(library), location, token, "bench", str(n_steps), repr(dt_s)]
    proc = subprocess.run([*cmd, str(repeats)], capture_output=True, text=True, check=True)
    figures = json.loads(proc.stdout)
    if extras.instructions:
        say(f"FMI {version}.0: instructions per step (callgrind)")
        figures["instructions_per_step"] = instructions_per_step(cmd[:4], dt_s)
    figures["resource_bytes"] = result.resource_bytes
    figures["speedup_vs_preprint"] = PREPRINT_STEP_US / figures["step_us_median"]
    return figures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m fmu.bench.steps", description=__doc__.split("\n")[0]
    )
    parser.add_argument(
        "--points", type=int, default=1099, help="monitored points K (default 1099)"
    )
    parser.add_argument("--modes", type=int, default=40, help="modes M (default 40)")
    parser.add_argument(
        "--steps", type=int, default=20_000, help="timed communication steps (default 20000)"
    )
    parser.add_argument(
        "--fmi", type=int, nargs="+", choices=(2, 3), default=[2, 3], help="FMI versions (2 3)"
    )
    parser.add_argument(
        "--windows",
        action="store_true",
        help="also time exports with the Windows DLL and run the DLL under wine (needs "
        "gcc-mingw-w64-x86-64 and wine64)",
    )
    parser.add_argument(
        "--hosts",
        action="store_true",
        help="also run the FMU and an SSP package with a 1 s move in ecospy, libcosimpy and "
        "fmpy's SSP runner against jaxflex",
    )
    parser.add_argument(
        "--array",
        action="store_true",
        help="FMI 3.0: also read the displaced points of every node (K x 3 array) each step",
    )
    parser.add_argument(
        "--turning",
        action="store_true",
        help="a turning part's FMU (export_fmu(turning=fmu.Turning())): the pose inputs set every "
        "step",
    )
    parser.add_argument(
        "--scene",
        choices=("plate", "panel"),
        help="the built-in part's model at every node (jaxflex model --scene) instead of the "
        "synthetic K x M model",
    )
    parser.add_argument(
        "--cell",
        help="cell file (TOML or JSON, as for jaxflex optimize): the part posed in it with its "
        "distance outputs, min_distance read every step",
    )
    parser.add_argument(
        "--instructions",
        action="store_true",
        help="also count the instructions of a step with valgrind's callgrind (the mean over "
        "1000 steps: repeatable where timings are not, on a loaded machine)",
    )
    args = parser.parse_args(argv)
    if args.turning and (args.windows or args.hosts):
        parser.error("--turning: not with --windows or --hosts (they replay an embedded move)")
    extras = Extras(
        turning=args.turning,
        read_array=args.array,
        windows=args.windows,
        hosts=args.hosts,
        instructions=args.instructions,
    )
    for name in ("points", "modes", "steps"):
        if getattr(args, name) < 1:
            parser.error(f"--{name}: must be at least 1, got {getattr(args, name)}")
    report = run(
        n_points=args.points,
        n_modes=args.modes,
        n_steps=args.steps,
        fmi_versions=tuple(args.fmi),
        progress=step,
        scene=args.scene,
        cell=None if args.cell is None else load_cell(args.cell),
        extras=extras,
    )
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
