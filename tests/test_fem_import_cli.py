"""``jaxflex model --from-ansys | --from-nastran | --from-r1`` as a user runs it."""

from __future__ import annotations

import json

import numpy as np
from ansys.mapdl.reader import examples
from conftest import random_model, run_jaxflex
from test_fem_nastran import STEEL_SI, meshio_deck

import fem
import jaxflex
from fem.imports.r1 import round_significant
from jaxflex._convolution import unit_response, write_unit_response_csv
from jaxflex.cli import main


def test_from_ansys_full_and_the_refused_pairing(tmp_path):
    out = tmp_path / "beam.npz"
    done = run_jaxflex(
        "model", "--from-ansys", examples.fullfile, "--nodes", examples.hexarchivefile,
        "--units", "BIN", "--n-modes", "6", "--points", "all", "-o", str(out),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    model = jaxflex.load_model(out)
    np.testing.assert_allclose(model.freq_hz[[0, 2, 5]], [1283.20, 5781.97, 10172.61], atol=5e-3)
    assert model.meta["input"]["full"]["sha256"] and model.n_points == 321


def test_errors_exit_2_naming_the_cause(tmp_path, capsys):
    # in-process: the same parser and error handling as the command, without a new interpreter
    args = ["model", "--from-ansys", examples.rstfile, "--full", examples.fullfile]
    assert main([*args, "--units", "BIN", "-o", str(tmp_path / "no.npz")]) == 2
    assert "constraints differ" in capsys.readouterr().err
    assert main(["model", "--from-ansys", examples.rstfile, "--thickness", "0.001"]) == 2
    assert "--thickness: not used with --from-ansys" in capsys.readouterr().err
    assert main(["model", "--from-r1", "r1.csv", "-o", str(tmp_path / "no.npz")]) == 2
    assert "--dt: the time step of the R1 file(s)" in capsys.readouterr().err
    assert main(["model", "--scene", "plate", "--units", "SI"]) == 2
    assert "--units: only with --from-ansys" in capsys.readouterr().err


def test_from_r1_writes_the_model_and_the_fit_report(tmp_path):
    truth = random_model(seed=5, n_points=8, n_modes=4, f_min_hz=3.0, f_max_hz=30.0)
    path = tmp_path / "r1_z.csv"
    write_unit_response_csv(path, round_significant(unit_response(truth, 0.01, 500)[2], 7))
    nodes = tmp_path / "nodes.csv"
    np.savetxt(nodes, truth.points, delimiter=",")
    out, report = tmp_path / "r1.npz", tmp_path / "fit.json"
    done = run_jaxflex(
        "model", "--from-r1", str(path), "--dt", "0.01", "--nodes", str(nodes),
        "--points", "all", "--report", str(report), "-o", str(out),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "R1 identification" in done.stdout
    model = jaxflex.load_model(out)
    np.testing.assert_allclose(model.freq_hz, truth.freq_hz, rtol=1e-6)  # 7-digit data
    assert json.loads(report.read_text())["n_modes"] == 4


def test_from_nastran_with_cups(tmp_path):
    part, cups = fem.scene("plate", mesh_size=0.1)
    mesh = part.mesh(cups)
    deck = meshio_deck(tmp_path / "plate.bdf", mesh.nodes_xy, "triangle", mesh.triangles, STEEL_SI)
    out = tmp_path / "deck.npz"
    cup_args = [f"{c.x},{c.y},{c.radius}" for c in cups]
    done = run_jaxflex(
        "model", "--from-nastran", str(deck), "--units", "SI", "--cups", *cup_args,
        "--n-modes", "5", "--points", "100", "--quiet", "-o", str(out),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    reference = fem.modal_analysis(part, cups, n_modes=5)
    np.testing.assert_allclose(jaxflex.load_model(out).freq_hz, reference.freq_hz, rtol=1e-6)
