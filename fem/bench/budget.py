"""The budget (jaxflex._budget) measured.

* Calibration of the finite-element plan (fem.mesh.plan): cells, DOFs, wall time and peak memory
  of modal analyses of the built-in footprint (1.5 x 0.8 m, four 40 mm cups, 20 modes) for
  every formulation and several element sizes, each case in a fresh interpreter so that its
  peak resident set is its own; the plan's figures beside the measured ones, so the table
  shows how far the estimate is from the run.
* ``--refusals``: the hostile requests of issue 23 (:func:`refusal_cases`), each a command
  run under a hard address-space limit (``ulimit -v``, :data:`LIMIT_BYTES`) with
  ``--max-memory`` :data:`BUDGET_GB`: its exit status, the first words of its message, its
  wall time and peak resident set (tests/test_budget.py asserts the refusals, not the
  figures).

JSON on stdout (and ``-o FILE``)::

    python -m fem.bench.budget -o budget.json
    python -m fem.bench.budget --refusals -o refusals.json
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fem.bench.emit import emit_json
from jaxflex.defaults import THRESHOLD_M

CASES = {
    "morley": (0.03, 0.015, 0.0075, 0.005),
    "argyris": (0.1, 0.05, 0.025),
    "shell": (0.04, 0.02, 0.01, 0.007),
    "hex2": (0.05, 0.025, 0.0125),
}
N_MODES = 20


def one_case(element: str, mesh_size_m: float) -> dict:
    """Run one analysis in this process: counts, plan and measurement."""
    import fem
    from fem.mesh.plan import fe_plan
    from fem.scenes import default_gripper

    if element == "hex2":
        part = fem.curved_panel(1.5, 0.8, 1e-3, "steel", mesh_size_m)
    else:
        part = fem.rectangular_plate(1.5, 0.8, 1e-3, "steel", mesh_size_m, element=element)
    supports = default_gripper(1.5, 0.8)
    plan = fe_plan(part, N_MODES, supports)
    base_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    tick = time.perf_counter()
    result = fem.modal_analysis(part, supports, n_modes=N_MODES, progress=False)
    wall = time.perf_counter() - tick
    peak_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    stats = result.system.stats
    return {
        "element": element,
        "mesh_size_m": mesh_size_m,
        "n_elements": int(stats["n_elements"]),
        "n_dof": int(stats["n_dof"]),
        "wall_s": round(wall, 2),
        "peak_mb": round((peak_kb - base_kb) / 1024, 1),
        "plan_cells": plan.cells,
        "plan_dof": plan.n_dof,
        "plan_s": round(plan.time_s, 2),
        "plan_mb": round(plan.memory_bytes / 2**20, 1),
    }


BUDGET_GB = 1.0
# the address space a refusal may map: the interpreter with JAX, NumPy's and XLA's thread
# pools (~1.8 GB, measured) and the memory budget on top
LIMIT_BYTES = int(3e9 + BUDGET_GB * 1e9)
REFUSAL_TIMEOUT_S = 600.0


@dataclass(frozen=True)
class Run:
    """A command's exit status, output and cost: wall time (s), peak resident set (MB)."""

    status: int
    stdout: str
    stderr: str
    wall_s: float
    peak_mb: float


def run_limited(argv: list[str], cwd: str | os.PathLike, limit_bytes: int = LIMIT_BYTES) -> Run:
    """``jaxflex ARGV --max-memory BUDGET_GB`` in a fresh interpreter whose address space is
    limited to ``limit_bytes`` (RLIMIT_AS, set in the child before it starts)."""

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit_bytes, limit_bytes))

    command = [sys.executable, "-m", "jaxflex", *argv, "--max-memory", str(BUDGET_GB), "-q"]
    start = time.perf_counter()
    proc = subprocess.Popen(
        command, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=limit
    )
    out: dict[str, bytes] = {}
    readers = [
        threading.Thread(target=lambda n=name, s=stream: out.__setitem__(n, s.read()))
        for name, stream in (("stdout", proc.stdout), ("stderr", proc.stderr))
    ]
    for reader in readers:
        reader.start()
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        if time.perf_counter() - start > REFUSAL_TIMEOUT_S:
            proc.kill()
        time.sleep(0.05)
    wall = time.perf_counter() - start
    for reader in readers:
        reader.join()
    proc.returncode = os.waitstatus_to_exitcode(status)
    return Run(
        proc.returncode,
        out["stdout"].decode("utf-8", "replace"),
        out["stderr"].decode("utf-8", "replace"),
        wall,
        usage.ru_maxrss / 1024,
    )


def _spec(folder: Path, name: str, **changes) -> str:
    spec = {
        "name": name,
        "part": {"width_m": 0.6, "height_m": 0.4, "mesh_size_m": 0.05},
        "model": {"n_modes": 6, "monitor_grid": [8, 6]},
        "optimization": {"threshold_m": 1e-4},
        "moves": [{"name": "up", "distance_m": [0, 0, 0.5]}],
        "layouts": [{"name": "three", "cups": [[0.1, 0.1, 0.03], [0.5, 0.1, 0.03],
                                               [0.3, 0.3, 0.03]]}],
        **changes,
    }  # fmt: skip
    path = folder / f"{name}.json"
    path.write_text(json.dumps(spec), encoding="utf-8")
    return str(path)


def _sheet_step(path: Path, width_m: float, height_m: float) -> str:
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        # given in m, written in mm; set each time: OpenCASCADE keeps the unit of an earlier
        # gmsh session of the process (tests/sheet_parts.py sets it too)
        gmsh.option.setString("Geometry.OCCTargetUnit", "M")
        gmsh.model.occ.addRectangle(0, 0, 0, width_m, height_m)
        gmsh.model.occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return str(path)


def _triangle_mesh(path: Path, n_triangles: int) -> str:
    """A flat 1.2 x 0.8 m sheet of about ``n_triangles`` triangles, binary gmsh .msh."""
    import meshio

    n = int(np.sqrt(n_triangles / 2 / 1.5))
    x, y = np.meshgrid(np.linspace(0, 1.2, int(1.5 * n) + 1), np.linspace(0, 0.8, n + 1))
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    idx = np.arange(points.shape[0]).reshape(x.shape)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]
    tris = np.concatenate([np.column_stack([a.ravel(), b.ravel(), c.ravel()]),
                           np.column_stack([a.ravel(), c.ravel(), d.ravel()])])  # fmt: skip
    meshio.write(path, meshio.Mesh(points, [("triangle", tris)]), file_format="gmsh22")
    return str(path)


def refusal_cases(folder: Path) -> dict[str, list[str]]:
    """The hostile requests of issue 23 as command lines (files made in ``folder``); each
    must be refused before its work with a message saying what it would need."""
    from jaxflex.reference import simply_supported_plate

    model = folder / "plate.npz"
    simply_supported_plate(n_modes=12, zeta=0.02, points=150).save(model)
    cups = ["--cups", "0.3,0.2,0.04", "0.9,0.2,0.04", "0.6,0.6,0.04"]
    boxes = [{"type": "box", "centre_m": [5 + 0.01 * i, 0, 0], "size_m": [0.005] * 3}
             for i in range(10_000)]  # fmt: skip
    cell = {"part": {"start_m": [0, 0, 0.5], "thickness_m": 1e-3}, "path": {"end_m": [0, 0, 1.5]},
            "obstacles": boxes}  # fmt: skip
    (folder / "boxes.json").write_text(json.dumps(cell), encoding="utf-8")
    big = _triangle_mesh(folder / "obstacle.msh", 2_000_000)
    meshed = {**cell, "obstacles": [{"type": "mesh", "path": "obstacle.msh"}]}
    (folder / "mesh_obstacle.json").write_text(json.dumps(meshed), encoding="utf-8")
    insets = [0.05 * k for k in range(1, 10)]
    grid = {"name": "g", "nx": list(range(2, 30)), "ny": list(range(2, 30)),
            "inset_x": insets, "inset_y": insets,
            "radius_m": [0.01, 0.02, 0.03, 0.04]}  # 28 x 28 x 9 x 9 x 4: 254 016  # fmt: skip
    wide = {**grid, "radius_m": [0.001 * k for k in range(1, 26)]}  # 1 587 600 x 4 moves
    moves = [{"name": f"m{i}", "distance_m": [0, 0, 0.2 + 0.1 * i]} for i in range(4)]
    return {
        "sweep: robust grid 100 000 x 100 000": [
            "sweep", _spec(folder, "robust", optimization={
                "threshold_m": 1e-4, "robust": {"n_freq": 100_000, "n_zeta": 100_000}}),
            "--serial", "-o", str(folder / "out_robust"),
        ],
        "optimize --robust --grid 100000 100000": [
            "optimize", str(model), "--distance", "0", "0", "1", "--threshold", f"{THRESHOLD_M:g}",
            "--robust", "--grid", "100000", "100000", "-o", str(folder / "opt"),
        ],
        "sweep: monitor grid 100 000 x 100 000": [
            "sweep", _spec(folder, "monitor", model={"n_modes": 6,
                                                     "monitor_grid": [100_000, 100_000]}),
            "--serial", "-o", str(folder / "out_monitor"),
        ],
        "sweep: grids of 6.35 M cases": [
            "sweep", _spec(folder, "grids", layouts=[], grids=[wide], moves=moves),
            "--serial", "-o", str(folder / "out_grids"),
        ],
        "model --scene plate --mesh-size 1e-5": [
            "model", "--scene", "plate", "--mesh-size", "1e-5", "-o", str(folder / "m.npz"),
        ],
        "model --cad: 1.2 m sheet at --mesh-size 1e-4": [
            "model", "--cad", _sheet_step(folder / "sheet.step", 1.2, 0.8), "--thickness",
            "1e-3", "--mesh-size", "1e-4", *cups, "-o", str(folder / "m.npz"),
        ],
        "model --cad: 120 m sheet at 5 cm": [
            "model", "--cad", _sheet_step(folder / "huge.step", 120, 80), "--thickness", "1e-3",
            "--mesh-size", "0.05", *cups, "-o", str(folder / "m.npz"),
        ],
        "model --mesh: 2 000 000 triangles": [
            "model", "--mesh", big, "--thickness", "1e-3", *cups, "-o", str(folder / "m.npz"),
        ],
        "optimize --cell: 10 000 boxes": [
            "optimize", str(model), "--cell", str(folder / "boxes.json"), "--min-distance",
            "0.01", "--threshold", f"{THRESHOLD_M:g}", "--max-time", "20", "-o",
            str(folder / "opt"),
        ],
        "optimize --cell: a 2 000 000-triangle obstacle": [
            "optimize", str(model), "--cell", str(folder / "mesh_obstacle.json"),
            "--min-distance", "0.01", "--threshold", f"{THRESHOLD_M:g}", "-o", str(folder / "opt"),
        ],
        "sweep: grid of 254 016 layouts": [
            "sweep", _spec(folder, "layouts", layouts=[], grids=[grid]), "--serial",
            "-o", str(folder / "out_layouts"),
        ],
    }  # fmt: skip


def refusals() -> list[dict]:
    """Each refusal case run under the limit: label, status, message, wall s, peak MB."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, argv in refusal_cases(Path(tmp)).items():
            run = run_limited(argv, tmp)
            last = (run.stderr.strip().splitlines() or [""])[-1]
            rows.append(
                {"case": label, "status": run.status, "message": last[:160],
                 "wall_s": round(run.wall_s, 2), "peak_mb": round(run.peak_mb, 1)}
            )  # fmt: skip
            print(json.dumps(rows[-1]), file=sys.stderr)
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-o", "--output", help="also write the JSON here")
    parser.add_argument("--refusals", action="store_true", help="the refusal cases instead")
    parser.add_argument("--case", nargs=2, metavar=("ELEMENT", "H"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.case:  # one case, in a fresh interpreter started below
        print(json.dumps(one_case(args.case[0], float(args.case[1]))))
        return 0
    if args.refusals:
        return emit_json(refusals(), args.output)
    rows = []
    for element, sizes in CASES.items():
        for size in sizes:
            out = subprocess.run(
                [sys.executable, "-m", "fem.bench.budget", "--case", element, str(size)],
                capture_output=True,
                text=True,
                check=True,
            )
            rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
            print(json.dumps(rows[-1]), file=sys.stderr)
    return emit_json(rows, args.output)


if __name__ == "__main__":
    sys.exit(main())
