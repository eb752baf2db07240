"""Wall time of the imports at the preprint's size, as JSON.

    python -m fem.bench.imports [--nodes 66308] [--steps 1000] [--imports r1 nastran]
                                 [--dir DIR] [-o imports_bench.json]

* R1: the built-in plate meshed finely enough for ``--nodes`` nodes (every mode below 40 Hz,
  zeta 0.02), R1 of ``--nodes`` of its nodes over ``--steps`` steps of 10 ms written as a
  Table 2 CSV with 7 significant digits (~2.8 GB at the preprint's size), then timed:
  reading the CSV and identifying the model (fem.from_r1), with its errors.
* Nastran: the same plate mesh as a bulk-data deck (meshio's writer: GRID* large field,
  CTRIA3) with its cups, then timed: fem.from_nastran (fem.imports.nastran.bdf read, our plate,
  20 modes).
ANSYS files of that size cannot be made here (no MAPDL); the .full import is read + our
eigen solve, which fem.bench.solves times.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import meshio
import numpy as np

import fem
import jaxflex
from fem.imports.nastran.bdf import read_bulk
from fem.imports.r1 import round_significant
from jaxflex.defaults import DT_S
from jaxflex.files import write_text_atomic
from jaxflex.reference import convolve_unit_response, unit_response
from jaxflex.response import jerk_limited_move

IMPORTS = ("r1", "nastran")


def _plate_with_nodes(n_nodes: int):
    size = 0.015
    while True:
        part, cups = fem.scene("plate", mesh_size=size)
        mesh = part.mesh(cups)
        if len(mesh.nodes_xy) >= n_nodes:
            return part, cups, mesh
        size *= 0.9 * np.sqrt(len(mesh.nodes_xy) / n_nodes)


def write_plate_deck(path: Path, mesh) -> None:
    """The plate mesh as a deck: GRIDs and CTRIA3 by meshio, 1 mm steel added as cards."""
    xyz = np.column_stack([mesh.nodes_xy, np.zeros(len(mesh.nodes_xy))])
    ones = np.ones(len(mesh.triangles), dtype=int)
    cells = [("triangle", mesh.triangles)]
    meshio.write(path, meshio.Mesh(xyz, cells, cell_data={"nastran:ref": [ones]}), "nastran")
    cards = "PSHELL  1       1       1.-3    1\nMAT1    1       2.1+11          .3      7850.\n"
    text = path.read_text()
    path.write_text(text.removesuffix("ENDDATA\n") + cards + "ENDDATA\n")


def run(n_nodes: int, n_steps: int, workdir: Path, imports=IMPORTS) -> dict:
    """Figures of the ``imports`` ("r1", "nastran") at ``n_nodes`` nodes."""
    out: dict = {"n_nodes": n_nodes, "n_steps": n_steps}
    part, cups, mesh = _plate_with_nodes(n_nodes)
    tick = time.perf_counter()
    result = fem.modal_analysis(part, cups, None, max_freq_hz=40.0, progress=False)
    out["fe_modes_s"] = time.perf_counter() - tick
    out["fe_nodes"] = len(mesh.nodes_xy)
    if "r1" in imports:
        out.update(_r1_import(result, n_nodes, n_steps, workdir))
    if "nastran" in imports:
        out.update(_nastran_import(result, mesh, cups, workdir))
    return out


def _r1_import(result, n_nodes: int, n_steps: int, workdir: Path) -> dict:
    out: dict = {}
    nodes = result.system.nodes
    keep = np.sort(np.random.default_rng(0).choice(len(nodes), n_nodes, replace=False))
    model = result.to_modal_model(points=nodes[keep])
    r1 = round_significant(unit_response(model, DT_S, n_steps)[2], 7)
    table = np.transpose(r1, (1, 0, 2)).reshape(n_nodes, -1)
    csv_path = workdir / "r1_z.csv"
    tick = time.perf_counter()
    np.savetxt(csv_path, table, fmt="%.7g", delimiter=",")
    out["r1_write_s"] = time.perf_counter() - tick
    out["r1_csv_bytes"] = csv_path.stat().st_size
    nodes_path = workdir / "nodes.csv"
    np.savetxt(nodes_path, model.points, delimiter=",")
    del table

    tick = time.perf_counter()
    identified = fem.from_r1(csv_path, DT_S, "z", nodes=nodes_path)
    out["r1_import_s"] = time.perf_counter() - tick
    out["r1_identification_timings_s"] = identified.fit.timings_s
    out["r1_modes"] = identified.n_modes
    out["r1_fit_residual_peak"] = identified.fit.residual_peak
    tick = time.perf_counter()
    reduced = identified.to_modal_model(points=1000)
    out["r1_model_1000_points_s"] = time.perf_counter() - tick
    true_f = model.freq_hz
    match = [np.argmin(np.abs(true_f - f)) for f in identified.freq_hz]
    out["r1_freq_rel_err_max"] = float(np.max(np.abs(identified.freq_hz / true_f[match] - 1)))
    out["r1_zeta_rel_err_max"] = float(np.max(np.abs(identified.zeta / model.zeta[match] - 1)))
    move = jerk_limited_move([0, 0, 1.0], vmax=2, amax=10, jmax=100, dt_s=DT_S)
    direct = convolve_unit_response(r1[None], move.acc, axes=(2,))
    full = identified.to_modal_model()
    modal = np.asarray(jaxflex.simulate(full, move, displacement=True).displacement)
    out["r1_profile_err_of_peak"] = float(
        np.abs(modal[: move.n_steps + 1] - direct).max() / np.abs(direct).max()
    )
    out["r1_reduced_points"] = reduced.n_points
    return out


def _nastran_import(result, mesh, cups, workdir: Path) -> dict:
    out: dict = {}
    deck_path = workdir / "plate.bdf"
    write_plate_deck(deck_path, mesh)
    out["nastran_deck_bytes"] = deck_path.stat().st_size
    tick = time.perf_counter()
    read_bulk(deck_path)
    out["nastran_read_s"] = time.perf_counter() - tick
    tick = time.perf_counter()
    solved = fem.from_nastran(deck_path, units="SI", cups=cups, n_modes=20, progress=False)
    out["nastran_import_s"] = time.perf_counter() - tick
    out["nastran_grids"] = len(mesh.nodes_xy)
    shared = min(solved.n_modes, result.n_modes)  # the FE run keeps the modes below 40 Hz
    out["nastran_modes_compared"] = shared
    out["nastran_freq_rel_err_vs_fem"] = float(
        np.max(np.abs(solved.freq_hz[:shared] / result.freq_hz[:shared] - 1))
    )
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m fem.bench.imports", description=__doc__)
    parser.add_argument("--nodes", type=int, default=66308, help="R1 rows / deck grids")
    parser.add_argument("--steps", type=int, default=1000, help="R1 time steps of 10 ms")
    parser.add_argument("--dir", help="where to write the R1 CSV and the deck (default: temp)")
    parser.add_argument(
        "--imports", nargs="+", choices=IMPORTS, default=list(IMPORTS), help="what to time"
    )
    parser.add_argument("-o", "--output", default="imports_bench.json", help="JSON results")
    args = parser.parse_args(argv)
    if args.nodes < 100 or args.steps < 100:
        parser.error("--nodes and --steps: at least 100")
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        figures = run(args.nodes, args.steps, Path(tmp), args.imports)
    text = json.dumps(figures, indent=2)
    write_text_atomic(args.output, text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
