"""``jaxflex model --tolerance``: the sized model, the summary, the report and the errors."""

from __future__ import annotations

import json

import pytest

import jaxflex
from jaxflex._profile import jerk_limited_move
from jaxflex._trajectory_io import write_trajectory_csv
from jaxflex.cli import main

# The full plate scene on a coarse sequence (70, 50, 35 mm): seconds, converges at 10 %
# (100 mm, with cups of 33 mm for their 40 mm radius, is not yet converging regularly)
SIZED = ["model", "--scene", "plate", "--tolerance", "10%", "--threshold", "1e-3",
         "--mesh-sizes", "0.07", "0.05", "0.035", "--quiet"]  # fmt: skip


def test_tolerance_writes_the_sized_model_and_report(tmp_path, capsys):
    move = tmp_path / "move.csv"
    write_trajectory_csv(move, jerk_limited_move((0, 0, 0.3), 2.0, 10.0, 100.0, 0.01))
    out, report = tmp_path / "m.npz", tmp_path / "sizing.json"
    code = main([*SIZED, "--trajectory", str(move), "-o", str(out), "--report", str(report)])
    text = capsys.readouterr().out
    data = json.loads(report.read_text())
    assert code == (0 if data["met"] else 1)
    assert data["met"], text
    model = jaxflex.load_model(out)
    choice = data["choice"]
    assert (model.n_modes, model.n_points) == (choice["n_modes"], choice["n_points"])
    assert choice["mesh_size_m"] in (0.07, 0.05)  # never the finest: that one is the reference
    assert model.meta["sizing"]["choice"] == choice  # the model carries its own report
    assert data["error"]["linf"] <= 0.1 and data["error"]["settle_ok"]
    # the summary explains the choice: effective mass, error estimate, cost
    for phrase in ("chosen:", "effective mass", "estimated error", "tolerance met", "DOFs"):
        assert phrase in text, phrase
    assert {row["stage"] for row in data["candidates"]} == {"mesh", "points", "modes", "final"}


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ([], "--tolerance: give the move"),
        (
            ["--distance", "0", "0", "1", "--tolerance", "0"],
            "--tolerance (tolerance): must be a finite number > 0",
        ),
        (
            ["--distance", "0", "0", "1", "--tolerance", "50%"],
            "--tolerance (tolerance): a fraction in (0, 0.5)",
        ),
        (["--distance", "0", "0", "1", "--tolerance", "1"], "did you mean 0.01"),
        (["--distance", "0", "0", "1", "--n-modes", "5"], "--n-modes: chosen by --tolerance"),
        (["--distance", "0", "0", "1", "--vmax", "1", "2"], "--vmax: give one value or three"),
    ],
)
def test_tolerance_input_errors(tmp_path, capsys, extra, message):
    argv = ["model", "--scene", "plate", "--threshold", "1e-3", "-o", str(tmp_path / "m.npz")]
    if "--tolerance" not in extra:
        argv += ["--tolerance", "1%"]
    assert main([*argv, *extra]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "m.npz").exists()


def test_sizing_options_need_tolerance(tmp_path, capsys):
    argv = ["model", "--scene", "plate", "--distance", "0", "0", "1", "-o", str(tmp_path / "m")]
    assert main(argv) == 2
    assert "--distance: only with --tolerance" in capsys.readouterr().err
