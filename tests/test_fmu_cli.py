"""``jaxflex export``: from an optimize folder or a bare CSV, with clear errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import random_model
from test_fmu_export import smooth_profile

from fmu.ssp import read_parameters
from fmu.verify import read_fmu_resource
from jaxflex import as_move
from jaxflex._fileset import writing
from jaxflex._trajectory_io import write_trajectory_csv
from jaxflex.cli import main
from optim.result import RESULT_FILES, RESULT_KIND

DT = 0.01


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """A model file and what `jaxflex optimize -o DIR` writes: trajectory.csv, report.json."""
    root = tmp_path_factory.mktemp("fmu_cli")
    model = random_model(6, n_points=20, n_modes=5, f_min_hz=3.0, zeta=0.05)
    model.save(root / "model.npz")
    acc = smooth_profile(5, 50)
    report = {
        "distance_m": [0.0, 0.0, 1.0],
        "dt_s": DT,
        "threshold_m": 0.02,
        "limits": {"vmax_m_s": 2.0, "amax_m_s2": 10.0, "jmax_m_s3": 100.0},
        "cycle_time_s": 1.2,
        "transfer_time_s": 0.5,
        "settle_time_s": 1.2,
        "solver": {"iterations": 17},
    }
    write_result_set(root / "opt", acc, report)
    return root, acc, report


def write_result_set(folder, acc, report) -> None:
    """trajectory.csv and report.json as the one set `jaxflex optimize -o DIR` writes."""
    with writing(folder, RESULT_KIND, RESULT_FILES) as files:
        files.add("trajectory.csv", lambda path: write_trajectory_csv(path, as_move(acc, DT)))
        files.add_text("report.json", json.dumps(report))


def test_export_from_an_optimize_folder_verifies_the_fmu(inputs, capsys):
    root, acc, report = inputs
    out = root / "out" / "part.fmu"
    out.parent.mkdir(exist_ok=True)  # jaxflex writes only into existing directories
    args = ["export", str(root / "model.npz"), "--fmi", "2", "--trajectory", str(root / "opt")]
    assert main([*args, "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert "\r" not in captured.err  # stderr redirected (not a terminal): no progress frames
    text = captured.out
    assert "wrote" in text and "fmpy validation: clean" in text and text.rstrip().endswith("OK")
    assert "ecospy: " in text  # run, or not run with the reason
    stored = read_fmu_resource(out)
    np.testing.assert_allclose(stored.acc, acc, rtol=1e-15, atol=0)  # CSV round trip
    case = json.loads((root / "out" / "part_case.json").read_text())
    for key in ("limits", "cycle_time_s", "transfer_time_s", "settle_time_s", "threshold_m"):
        assert case[key] == report[key]
    assert case["optimisation"] == {"distance_m": [0.0, 0.0, 1.0]}
    assert (root / "out" / "part_input.csv").is_file()


def test_export_from_a_bare_csv_with_fmi3(inputs, tmp_path, capsys):
    root, acc, _ = inputs
    csv = tmp_path / "move.csv"
    write_trajectory_csv(csv, as_move(acc, DT))
    out = tmp_path / "p3.fmu"
    argv = ["export", str(root / "model.npz"), "--fmi", "3", "--trajectory", str(csv)]
    assert main([*argv, "--threshold", "0.03", "--no-verify", "-o", str(out)]) == 0
    assert "fmpy validation: clean" in capsys.readouterr().out
    case = json.loads((tmp_path / "p3_case.json").read_text())
    assert case["threshold_m"] == 0.03 and case["limits"] is None
    assert case["fmi_version"] == 3


def test_export_without_a_trajectory(inputs, tmp_path, capsys):
    root, _, _ = inputs
    out = tmp_path / "bare.fmu"
    assert main(["export", str(root / "model.npz"), "-o", str(out)]) == 0
    assert "fmpy validation: clean" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bare.fmu"]


@pytest.mark.parametrize(
    ("setup", "message"),
    [
        (lambda root, tmp: ["missing.npz"], "does not exist"),
        (lambda root, tmp: [str(root / "model.npz"), "--trajectory", str(tmp)], "trajectory.csv"),
        (lambda root, tmp: [str(root / "model.npz"), "--trajectory", str(tmp / "x")], "exist"),
        (
            lambda root, tmp: [str(root / "model.npz"), "--threshold", "-1"],
            "--threshold",
        ),
    ],
    ids=["no-model", "empty-folder", "no-trajectory", "bad-threshold"],
)
def test_bad_input_gives_a_clear_error(inputs, tmp_path, capsys, setup, message):
    root, _, _ = inputs
    argv = ["export", *setup(root, tmp_path), "-o", str(tmp_path / "e.fmu")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxflex export: error:") and message in err
    assert not (tmp_path / "e.fmu").exists()


def test_report_with_another_sample_step_is_refused(inputs, tmp_path, capsys):
    root, acc, report = inputs
    write_result_set(tmp_path, acc, {**report, "dt_s": 0.02})
    argv = ["export", str(root / "model.npz"), "--trajectory", str(tmp_path), "-o"]
    assert main([*argv, str(tmp_path / "e.fmu")]) == 2
    assert "do not belong together" in capsys.readouterr().err


def test_export_an_ssp_package_and_check_it_in_other_hosts(inputs, tmp_path, capsys):
    """`--ssp` alone: the package of part and trajectory source, validated and simulated in
    every host available here; the FMU export line names the engines it ran too."""
    root, _, report = inputs
    out = tmp_path / "case.ssp"
    argv = ["export", str(root / "model.npz"), "--trajectory", str(root / "opt"), "--ssp"]
    assert main([*argv, str(out), "--windows", "no", "--damping-scale", "0.5"]) == 0
    text = capsys.readouterr().out
    assert f"wrote {out}: SSP 1.0" in text and "SSP validation: clean" in text
    assert "jaxflex-master: deviation vs jaxflex.simulate" in text
    assert "fmpy: deviation vs exact zero-order hold" in text
    assert text.rstrip().endswith("OK")
    assert read_parameters(out) == {
        "part": {"threshold": report["threshold_m"], "damping_scale": 0.5}
    }
    assert [p.name for p in tmp_path.iterdir()] == ["case.ssp"]


@pytest.mark.parametrize(
    ("extra", "message"),
    [([], "give -o FILE.fmu, --ssp FILE.ssp or both"), (["--ssp", "x.ssp"], "--trajectory")],
    ids=["no-output", "ssp-without-move"],
)
def test_ssp_and_output_options_are_checked(inputs, tmp_path, capsys, extra, message):
    root, _, _ = inputs
    assert main(["export", str(root / "model.npz"), *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxflex export: error:") and message in err
