"""Calibration of the finite-element plan (fem.plan): cells, DOFs, wall time and peak memory
of modal analyses of the built-in footprint (1.5 x 0.8 m, four 40 mm cups, 20 modes) for
every formulation and several element sizes, each case in a fresh interpreter so that its
peak resident set is its own. JSON on stdout (and ``-o FILE``); the plan's figures beside the
measured ones, so the table shows how far the estimate is from the run.

    python -m benchmarks.budget -o budget.json
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

from jaxflex.atomic import write_text_atomic

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
    from fem.plan import fe_plan
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-o", "--output", help="also write the JSON here")
    parser.add_argument("--case", nargs=2, metavar=("ELEMENT", "H"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.case:  # one case, in a fresh interpreter started below
        print(json.dumps(one_case(args.case[0], float(args.case[1]))))
        return 0
    rows = []
    for element, sizes in CASES.items():
        for size in sizes:
            out = subprocess.run(
                [sys.executable, "-m", "benchmarks.budget", "--case", element, str(size)],
                capture_output=True,
                text=True,
                check=True,
            )
            rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
            print(json.dumps(rows[-1]), file=sys.stderr)
    text = json.dumps(rows, indent=2)
    print(text)
    if args.output:
        write_text_atomic(args.output, text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
