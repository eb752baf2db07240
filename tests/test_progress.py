"""jaxflex._progress: a bar with total and ETA on a terminal, plain lines in a log (never a
carriage return), nothing when quiet; and the command line around it: --quiet on every
command, --version, warnings as one line."""

from __future__ import annotations

import io
import json
import re

import pytest
from conftest import run_jaxflex

import jaxflex
from jaxflex import _progress as progress
from jaxflex.cli import build_parser, commands


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.fixture(autouse=True)
def _loud():
    progress.set_quiet(False)
    yield
    progress.set_quiet(False)


def test_log_gets_plain_periodic_lines_and_a_closing_line():
    log = io.StringIO()
    with progress.Progress(4, "baselines", unit="move", stream=log, interval_s=0.0) as bar:
        for _ in range(4):
            bar.update(1)
            bar.set_postfix_str("n = 80 ok")
    text = log.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert len(lines) == 5  # one per update (interval 0) and the closing one
    assert lines[0].startswith("baselines: 1/4 move, ") and "left" in lines[0]
    assert re.fullmatch(r"baselines: 4/4 move in \d+\.\d s \(n = 80 ok\)", lines[-1])


def test_log_lines_are_rate_limited():
    log = io.StringIO()
    # an hour between lines: no loaded machine stretches 1000 updates that far
    with progress.Progress(None, "eigen solve", unit="solve", stream=log, interval_s=3600) as bar:
        for _ in range(1000):
            bar.update(1)
    assert log.getvalue().splitlines() == [log.getvalue().strip()]  # the closing line only
    assert log.getvalue().startswith("eigen solve: 1000 solve in ")


def test_terminal_gets_a_bar_with_total_and_time_left():
    tty = Terminal()
    with progress.Progress(10, "search", unit="test", stream=tty) as bar:
        bar.update(3)
        bar.total = 12  # the bracket changed
        bar.update(1)
    frames = tty.getvalue().split("\r")
    # count/total [elapsed<left] (tqdm redraws at most every 0.1 s: 3/12 or 4/12)
    assert any(re.search(r"search: .*\d/12 \[\d\d:\d\d<", f) for f in frames), frames


def test_quiet_shows_nothing_and_enabled_overrides():
    log = io.StringIO()
    progress.set_quiet(True)
    with progress.Progress(3, "x", stream=log, interval_s=0.0) as bar:
        bar.update(3)
    progress.step("factorisation", stream=log)
    assert log.getvalue() == ""
    with progress.Progress(1, "forced", stream=log, enabled=True) as bar:
        bar.update(1)
    assert log.getvalue().startswith("forced: 1/1 it in ")
    progress.set_quiet(False)
    with progress.Progress(1, "off", stream=log, enabled=False) as bar:
        bar.update(1)
    assert "off" not in log.getvalue()


def test_every_command_takes_the_same_quiet_flag():
    for command in commands():
        parser = build_parser(command.name)
        extra = {"sweep": [], "bench": [], "demo": []}.get(command.name, ["x"])
        if command.name == "model":
            extra = ["--scene", "plate"]
        elif command.name == "optimize":
            extra = ["m.npz", "--distance", "0", "0", "1", "--threshold", "1e-3", "-o", "o"]
        args = parser.parse_args([command.name, *extra, "--quiet"])
        assert args.quiet is True, command.name
        assert parser.parse_args([command.name, *extra]).quiet is False


def test_version():
    proc = run_jaxflex("--version")
    assert proc.returncode == 0
    assert proc.stdout.strip() == f"jaxflex {jaxflex.__version__}"


def test_bad_zeta_and_points_are_refused_before_any_finite_element_work():
    for args, option in ((["--zeta", "1.5"], "--zeta"), (["--points", "0"], "--points")):
        proc = run_jaxflex("model", "--scene", "panel", *args, "-o", "never.npz")
        assert proc.returncode == 2, proc.stderr
        assert option in proc.stderr and "Traceback" not in proc.stderr
        assert "factorisation" not in proc.stderr and "assembly" not in proc.stderr
    proc = run_jaxflex("model", "--scene", "plate", "--zeta", "1.5", "-o", "never.npz")
    assert "Rayleigh" not in proc.stderr and "1.5 % would be 0.015" in proc.stderr


def test_redirected_logs_of_model_and_sweep_have_plain_lines_only(tmp_path):
    # `optimize`, `demo`, `bench`, `export` are checked where their runs are tested
    proc = run_jaxflex(
        "model", "--scene", "plate", "--mesh-size", "0.1", "--n-modes", "4", "--points", "40",
        "-o", str(tmp_path / "m.npz"),
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "\r" not in proc.stderr
    assert re.search(r"assembly \(morley, \d+ elements\): \d+/\d+ chunk in ", proc.stderr)
    assert "factorisation of K - sigma M" in proc.stderr
    spec = {
        "name": "log",
        "part": {"width_m": 0.6, "height_m": 0.4, "mesh_size_m": 0.1},
        "model": {"n_modes": 4, "monitor_grid": [4, 3]},
        "moves": [{"name": "up", "distance_m": [0, 0, 0.3]}],
        "layouts": [{"name": "four", "cups": [[0.15, 0.1, 0.03], [0.45, 0.1, 0.03],
                                              [0.15, 0.3, 0.03], [0.45, 0.3, 0.03]]}],
    }  # fmt: skip
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    proc = run_jaxflex("sweep", str(path), "-o", str(tmp_path / "sweep"), "--serial")
    assert proc.returncode == 0, proc.stderr
    assert "\r" not in proc.stderr and re.search(r"log: 1/1 case in ", proc.stderr)
    assert "move 'up': best layout 'four'" in proc.stdout
    assert "vmax 2 m/s (default)" in proc.stdout
    quiet = run_jaxflex("sweep", str(path), "-o", str(tmp_path / "sweep"), "--serial", "-q")
    assert quiet.returncode == 0 and quiet.stderr == ""
