"""Sweep benchmark: throughput serial vs dask LocalCluster, per-case cost split, compiled-code
reuse, batched vs looped evaluation. JSON on stdout (and ``-o FILE``).

    python -m optim.sweep.bench.sweep           # the example spec (34 cases), 2 workers
    python -m optim.sweep.bench.sweep --spec sweep.toml --workers 2 --robust -o sweep_bench.json

Every run starts from an empty results directory (nothing skipped). Throughput counts the
computed cases over the wall time of the computation, which for dask includes starting the
cluster and each worker's imports and JIT compilation (plots are not drawn).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np

from fem.bench.emit import emit_json
from jaxflex.model import ModalModel
from jaxflex.response import ARRAY_FIELDS, as_move
from optim.limits import Limits
from optim.optimize import optimize
from optim.options import RobustSpec, Search
from optim.sweep.cases import expand, layout_job
from optim.sweep.evaluate import deviation_traces
from optim.sweep.run import Executor, run_sweep
from optim.sweep.spec import EXAMPLE, SweepSpec, load_spec, parse_spec
from optim.sweep.store import ResultStore
from optim.sweep.work import analyse_layout, payload_model


def _throughput(spec: SweepSpec, executor: str, n_workers: int | None, root: Path) -> dict:
    where = Executor(executor, n_workers=n_workers)
    run = run_sweep(spec, root / executor, executor=where, progress=False, plots=False)
    ok = [r for r in run.records.values() if r["status"] == "ok"]
    fe_by_layout = {}  # layout -> (wall, cpu) of its one FE analysis
    for case in run.cases:
        fe = run.records[case.case_id].get("fe")
        if fe:
            fe_by_layout[case.layout_id] = (fe["fe_wall_s"], fe["fe_cpu_s"])
    fe_wall, fe_cpu = np.sum(list(fe_by_layout.values()), axis=0) if fe_by_layout else (0, 0)
    opt_wall = np.array([r["opt"]["opt_wall_s"] for r in ok])
    opt_cpu = np.array([r["opt"]["opt_cpu_s"] for r in ok])
    n = max(run.computed, 1)
    return {
        "executor": executor,
        "workers": n_workers if executor == "dask" else 1,
        "cases": run.computed,
        "errors": run.n_errors,
        "wall_s": round(run.wall_s, 2),
        "cases_per_min": round(60 * run.computed / run.wall_s, 1),
        "fe_wall_s_per_layout": round(fe_wall / max(len(fe_by_layout), 1), 3),
        "fe_wall_s_per_case": round(fe_wall / n, 3),
        "fe_cpu_s_per_case": round(fe_cpu / n, 3),
        "opt_wall_s_per_case_mean": round(float(opt_wall.mean()), 3),
        "opt_wall_s_per_case_median": round(float(np.median(opt_wall)), 3),
        "opt_cpu_s_per_case_mean": round(float(opt_cpu.mean()), 3),
        "opt_wall_s_first_case": round(float(opt_wall[0]), 3),
        "run": run,
    }


def _meta_reuse(spec: SweepSpec, n_layouts: int = 4) -> dict:
    """Optimisation wall time per case with the FE model's meta kept vs stripped, interleaved
    per layout: meta is not part of the model's pytree structure, so both share the compiled
    code (they used to differ by a compilation per distinct meta)."""
    move = spec.moves[0]
    limits = Limits(move.vmax, move.amax, move.jmax)
    out: dict = {"meta_kept_s": [], "meta_stripped_s": []}
    for layout in spec.layouts[:n_layouts]:
        fe = analyse_layout(layout_job(spec, layout))
        if fe["status"] != "ok":
            continue
        kept = payload_model(fe["model"])
        stripped = ModalModel(*(getattr(kept, name) for name in ARRAY_FIELDS))
        for label, model in (("meta_kept_s", kept), ("meta_stripped_s", stripped)):
            tick = time.perf_counter()
            optimize(
                model,
                move.distance_m,
                limits,
                spec.optimization.dt_s,
                spec.optimization.threshold_m,
                search=Search(progress=False),
            )
            out[label].append(round(time.perf_counter() - tick, 3))
    out["note"] = "per distinct layout, in order; the first layout's kept run also compiles"
    return out


def _evaluation(run, repeats: int = 3) -> dict:
    """ms per case of the deviation traces of all successful cases of the first move:
    batched (one jitted group) vs loop (jaxflex.simulate per case), after a warm-up."""
    store = ResultStore(run.directory)
    move = run.spec.moves[0].name
    cases = [
        c
        for c in expand(run.spec)
        if c.move.name == move and run.records[c.case_id]["status"] == "ok"
    ]
    models = [store.load_model(c.layout_id)[0] for c in cases]
    dt_s = run.spec.optimization.dt_s
    moves = [as_move(run.records[c.case_id]["acc_m_s2"], dt_s) for c in cases]
    horizon = 1.15 * max(move.n_steps + 1 for move in moves) * dt_s
    out = {"cases": len(cases), "points": models[0].n_points, "modes": models[0].n_modes}
    for method in ("batched", "loop"):
        deviation_traces(models, moves, horizon, method=method)
        tick = time.perf_counter()
        for _ in range(repeats):
            deviation_traces(models, moves, horizon, method=method)
        out[f"{method}_ms_per_case"] = round(
            1e3 * (time.perf_counter() - tick) / (repeats * len(cases)), 3
        )
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spec", help="spec file (default: the example, jaxflex sweep --example)")
    parser.add_argument("--workers", type=int, default=2, help="LocalCluster workers (default 2)")
    parser.add_argument("--robust", action="store_true", help="robust optimisation (default grid)")
    parser.add_argument("-o", "--output", help="also write the JSON here")
    args = parser.parse_args(argv)
    spec = load_spec(args.spec) if args.spec else parse_spec(tomllib.loads(EXAMPLE))
    if args.robust:
        spec = replace(spec, optimization=replace(spec.optimization, robust=RobustSpec().as_dict()))
    report: dict = {"spec": spec.name, "cases": len(expand(spec)), "robust": args.robust}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        serial = _throughput(spec, "serial", None, root)
        local = _throughput(spec, "dask", args.workers, root)
        report["evaluation"] = _evaluation(serial["run"])
        report["meta_reuse"] = _meta_reuse(spec)
    report["serial"] = {k: v for k, v in serial.items() if k != "run"}
    report["local_cluster"] = {k: v for k, v in local.items() if k != "run"}
    report["speedup_local_cluster"] = round(local["cases_per_min"] / serial["cases_per_min"], 2)
    return emit_json(report, args.output)


if __name__ == "__main__":
    sys.exit(main())
