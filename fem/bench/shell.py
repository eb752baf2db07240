"""Convergence of the shell (DKT + OPT flat facets) against closed forms, published values
and the thin solid, as JSON and as the tables of docs/fem.md.

    .venv/bin/python -m fem.bench.shell [--cases leissa donnell locking bracket scene]
                                         [-o shell_bench.json]

leissa   clamped 1 m square plate, 1 mm, lambda_1..6 vs Leissa (1969), 50 ... 12.5 mm
donnell  simply supported cylindrical panel a = 0.5 m, chord 0.4 m, R = 2 m, 1 mm: the shell
         (20 ... 5 mm) and the thin solid (25 ... 8 mm, Richardson) vs Donnell's closed form
locking  the same panel at thickness/span 1/500 and 1/3000: f1..6 at 40 ... 5 mm
bracket  L-bracket 0.3 + 0.1 m (90 degree fold) x 0.2 m, 2 mm, clamped at the base's far
         edge: shell 20 ... 5 mm, thin solid 20 ... 5 mm
scene    the built-in panel with its four cups: shell at its default mesh vs the thin solid
doors    the same cylindrical panel (R = 1 m, 0.6 x 0.4 m, 1 mm) as a STEP file (gmsh) and as
         gmsh meshes of tri3, tri6, quad4, quad8, quad9 in .msh, .vtu, .inp, .stl:
         mass and the first ten free-free frequencies against the first door
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

import fem
from fem.mesh.mesh_io import sheet_from_cells
from fem.parts import part_from_mesh
from jaxflex.files import write_text_atomic
from jaxflex.reference import cylindrical_panel_frequencies_hz

CASES = ("doors", "leissa", "donnell", "locking", "bracket", "scene")
STEEL = fem.PRESETS["steel"]
LEISSA = np.array([35.985, 73.394, 73.394, 108.22, 131.58, 132.20])
PANEL = {"a": 0.5, "chord": 0.4, "radius": 2.0}


def _run(part, supports, n_modes: int, size_m: float | None = None) -> dict:
    """``size_m``: the element size of a given mesh (the part's own size otherwise)."""
    start = time.perf_counter()
    result = fem.modal_analysis(part, supports, n_modes, progress=False)
    return {
        "mesh_m": part.element_size_m if size_m is None else size_m,
        "n_dof": result.system.n_dof,
        "wall_s": round(time.perf_counter() - start, 2),
        "freq_hz": [round(float(f), 4) for f in result.freq_hz],
    }


def case_leissa() -> dict:
    bending = STEEL.bending_stiffness_nm(1e-3)
    rows = []
    for size in (0.05, 0.025, 0.02, 0.0125):
        part = fem.rectangular_plate(1.0, 1.0, 1e-3, mesh_size=size, element="shell")
        row = _run(part, fem.ClampedEdge(), 6)
        omega = 2 * np.pi * np.array(row["freq_hz"])
        lam = omega * np.sqrt(STEEL.rho_kg_m3 * 1e-3 / bending)
        row["error_pct"] = [round(float(e), 3) for e in 100 * (lam / LEISSA - 1)]
        rows.append(row)
    return {"published": LEISSA.tolist(), "shell": rows}


def donnell_hz(thickness_m: float, count: int = 6) -> np.ndarray:
    """Donnell's closed form of the simply supported panel (jaxflex._analytic)."""
    radius = PANEL["radius"]
    arc = 2 * radius * np.arcsin(PANEL["chord"] / (2 * radius))
    return cylindrical_panel_frequencies_hz(
        PANEL["a"], arc, radius, thickness_m, STEEL.E_pa, STEEL.nu, STEEL.rho_kg_m3, count
    )


def _panel(thickness_m: float, size: float | None, element: str):
    return fem.curved_panel(
        PANEL["a"], PANEL["chord"], thickness_m, mesh_size=size, radius_x=None,
        radius_y=PANEL["radius"], element=element,
    )  # fmt: skip


def case_donnell() -> dict:
    closed = donnell_hz(1e-3)
    shell = [_run(_panel(1e-3, s, "shell"), fem.SimplySupportedEdge(), 6)
             for s in (0.02, 0.0133, 0.01, 0.005)]  # fmt: skip
    solid = [_run(_panel(1e-3, s, "hex2"), fem.SimplySupportedEdge(), 6)
             for s in (0.025, 0.0167, 0.0125, 0.01)]  # fmt: skip
    fine, finer = (np.array(solid[i]["freq_hz"]) for i in (-2, -1))
    ratio = (0.0125 / 0.01) ** 2
    extrapolated = finer + (finer - fine) / (ratio - 1)
    for row in shell + solid:
        f = np.array(row["freq_hz"])
        row["vs_donnell_pct"] = [round(float(e), 3) for e in 100 * (f / closed - 1)]
        row["vs_solid_pct"] = [round(float(e), 3) for e in 100 * (f / extrapolated - 1)]
    return {
        "donnell_hz": closed.round(4).tolist(),
        "solid_richardson_hz": extrapolated.round(4).tolist(),
        "shell": shell,
        "solid": solid,
    }


def case_locking() -> dict:
    out = {}
    for ratio in (500, 3000):
        thickness = PANEL["chord"] / ratio
        rows = [_run(_panel(thickness, s, "shell"), fem.SimplySupportedEdge(), 6)
                for s in (0.04, 0.02, None, 0.01, 0.005)]  # fmt: skip
        reference = np.array(rows[-1]["freq_hz"])
        for row in rows:
            f = np.array(row["freq_hz"])
            row["vs_finest_pct"] = [round(float(e), 3) for e in 100 * (f / reference - 1)]
        out[f"1/{ratio}"] = {"donnell_hz": donnell_hz(thickness).round(4).tolist(), "rows": rows}
    return out


def _bracket(element: str, size: float):
    nb, nf, ny = round(0.3 / size), round(0.1 / size), round(0.2 / size)
    s = np.concatenate([np.linspace(-0.1, 0, nf + 1)[:-1], np.linspace(0, 0.3, nb + 1)])
    ss, yy = np.meshgrid(s, np.linspace(0, 0.2, ny + 1), indexing="ij")
    points = np.stack([np.maximum(ss, 0), yy, np.maximum(-ss, 0)], axis=-1).reshape(-1, 3)
    idx = np.arange(ss.size).reshape(ss.shape)
    quads = np.column_stack([idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(),
                             idx[:-1, 1:].ravel()])  # fmt: skip
    sheet = sheet_from_cells(points, [("quad", quads)], "bracket")
    return part_from_mesh(sheet, 2e-3, "steel", element, "bracket", {})


def case_bracket() -> dict:
    clamp = fem.ClampedEdge("x1")
    return {
        element: [_run(_bracket(element, s), clamp, 8, s) for s in (0.02, 0.01, 0.005)]
        for element in ("shell", "hex2")
    }


def case_scene() -> dict:
    out = {}
    for element in ("shell", "hex2"):
        part, cups = fem.scene("panel")
        if element == "shell":
            part = fem.curved_panel(1.5, 0.8, 1e-3, element="shell")
        out[element] = _run(part, cups, 20)
    return out


def _panel_step(path: Path) -> None:
    """The R = 1 m cylindrical panel (chord 0.6 m along x, 0.4 m along y) as a STEP surface."""
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setString("Geometry.OCCTargetUnit", "M")
        occ = gmsh.model.occ
        half = np.arcsin(0.3)
        ends = [occ.addPoint(0.3 + s * np.sin(half), 0, np.cos(half) - 1) for s in (-1, 1)]
        arc = occ.addCircleArc(ends[0], occ.addPoint(0.3, 0, -1.0), ends[1])
        occ.extrude([(1, arc)], 0, 0.4, 0)
        occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def _gmsh_mesh(step: Path, path: Path, order: int, quads: bool, serendipity: bool) -> None:
    """A 20 mm gmsh mesh of the STEP surface written to ``path`` (meshio picks the format)."""
    import gmsh
    import meshio

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setString("Geometry.OCCTargetUnit", "M")
        gmsh.model.occ.importShapes(str(step))
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.02)
        gmsh.option.setNumber("Mesh.RecombineAll", int(quads))
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", int(serendipity))
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(order)
        raw = path.with_suffix(".msh")
        gmsh.write(str(raw))
    finally:
        gmsh.finalize()
    if path.suffix != ".msh":
        mesh = meshio.read(raw)
        keep = [(b.type, b.data) for b in mesh.cells if b.dim == 2]
        options = {"binary": True} if path.suffix == ".stl" else {}
        meshio.write(path, meshio.Mesh(mesh.points, keep), **options)


def case_doors() -> dict:
    doors = {
        "tri3 .msh": (1, False, False, "a.msh"),
        "tri6 .vtu": (2, False, False, "b.vtu"),
        "quad4 .inp": (1, True, False, "c.inp"),
        "quad8 .vtu": (2, True, True, "d.vtu"),
        "quad9 .msh": (2, True, False, "e.msh"),
        "tri3 .stl": (1, False, False, "f.stl"),
    }
    out, reference = {}, None
    with tempfile.TemporaryDirectory() as tmp:
        step = Path(tmp) / "panel.step"
        _panel_step(step)
        parts = {"STEP (fem.read_cad, 20 mm)": fem.read_cad(step, 1e-3, mesh_size=0.02)}
        for name, (order, quads, serendipity, file) in doors.items():
            _gmsh_mesh(step, Path(tmp) / file, order, quads, serendipity)
            parts[name] = fem.read_mesh(Path(tmp) / file, 1e-3)
        for name, part in parts.items():
            start = time.perf_counter()
            result = fem.modal_analysis(part, [], 10, allow_rigid_modes=True, progress=False)
            row = {
                "cells": part.describe()["read"]["cells"],
                "n_dof": result.system.n_dof,
                "mass_kg": round(result.mass_kg, 6),
                "freq_hz": [round(float(f), 3) for f in result.freq_hz],
                "wall_s": round(time.perf_counter() - start, 2),
            }
            reference = reference or row
            mass = row["mass_kg"] / reference["mass_kg"] - 1
            freq = np.array(row["freq_hz"]) / np.array(reference["freq_hz"]) - 1
            row["mass_vs_first_pct"] = round(100 * mass, 4)
            row["freq_vs_first_pct_max"] = round(float(100 * np.abs(freq).max()), 3)
            out[name] = row
    exact = STEEL.rho_kg_m3 * 1e-3 * 2 * np.arcsin(0.3) * 0.4
    return {"exact_mass_kg": round(exact, 6), "doors": out}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m fem.bench.shell", description=__doc__)
    parser.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    parser.add_argument("-o", "--output", default="shell_bench.json", help="JSON file")
    args = parser.parse_args(argv)
    figures = {}
    for name in args.cases:
        start = time.perf_counter()
        figures[name] = globals()[f"case_{name}"]()
        figures[name]["case_wall_s"] = round(time.perf_counter() - start, 1)
        print(f"{name}: {json.dumps(figures[name])}", flush=True)
    write_text_atomic(args.output, json.dumps(figures, indent=2))
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
