"""The command line as a user runs it, and how the dispatcher finds the commands."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from importlib.metadata import entry_points

import numpy as np
from conftest import run_jaxflex

import jaxflex
import optim.sweep.cli
from jaxflex.cli import GROUP, commands, main
from jaxflex.grid import grid_time
from jaxflex.trajectory_io import read_trajectory_csv

# what each package contributes, in the order of `jaxflex --help`
COMMANDS = {
    "demo": "fmu.demo",
    "model": "fem.cli",
    "optimize": "optim.cli",
    "animate": "optim.animate_cli",
    "sweep": "optim.sweep.cli",
    "export": "fmu.cli",
    "bench": "fmu.bench.cli",
}
# what the packages behind the commands load on import; listing the commands loads none
HEAVY = ("fem", "optim", "fmu", "skfem", "matplotlib", "distributed", "casadi")


def test_each_package_registers_its_commands():
    assert {p.name: p.module for p in entry_points(group=GROUP)} == COMMANDS
    listed = commands()
    assert [(c.name, c.module) for c in listed] == list(COMMANDS.items())
    for command in listed:  # what the dispatcher read from the source is what the module says
        module = importlib.import_module(command.module)
        assert (
            command.name,
            command.help,
            command.order,
        ) == (module.COMMAND, module.HELP, module.ORDER)
        assert callable(module.add_arguments) and callable(module.run)


def test_help_lists_every_command_without_importing_one():
    code = (
        "import sys\n"
        "from jaxflex.cli import main\n"
        "try:\n"
        "    main(['--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        f"print('loaded:', [m for m in {HEAVY!r} if m in sys.modules])\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.rstrip().endswith("loaded: []")
    words = " ".join(proc.stdout.split())  # argparse wraps the help lines
    for command in commands():
        assert f"{command.name} {command.help}" in words


# third-party modules each command's module may load on import (the rest, e.g. matplotlib for
# the pictures, casadi for its solvers, meshio and gmsh for mesh files, is imported where used)
NEEDED = {
    "fmu.demo": {"skfem", "ruckig", "fmpy"},
    "fem.cli": {"skfem"},
    "optim.cli": {"ruckig"},
    "optim.animate_cli": {"ruckig"},
    "fmu.cli": {"skfem", "ruckig", "fmpy"},
}
OPTIONAL = ("matplotlib", "casadi", "meshio", "gmsh", "skfem", "ruckig", "fmpy", "pyuff", "dask")


def test_commands_import_heavy_modules_only_where_they_are_used():
    for module, needed in NEEDED.items():
        code = f"import json, sys, {module}\n"
        code += f"print(json.dumps([m for m in {OPTIONAL!r} if m in sys.modules]))"
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        assert set(json.loads(proc.stdout)) <= needed, module


def test_interrupted_command_exits_130(monkeypatch, capsys):
    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(optim.sweep.cli, "run", interrupted)
    assert main(["sweep", "--example"]) == 130
    assert "jaxflex sweep: interrupted" in capsys.readouterr().err


def test_output_to_a_closed_pipe_ends_quietly():
    """`jaxflex ... | head`: the reader is gone before the command writes; no traceback, the
    status a SIGPIPE kill would give."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        done = subprocess.run(
            [sys.executable, "-m", "jaxflex", "sweep", "--example"],
            stdout=write_end,
            stderr=subprocess.PIPE,
            text=True,
        )
    finally:
        os.close(write_end)
    assert (done.returncode, done.stderr) == (141, "")


def test_demo_runs_the_whole_pipeline(tmp_path):
    out = tmp_path / "demo"
    proc = run_jaxflex("demo", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "cycle" in proc.stdout and "FMI 3.0" in proc.stdout
    assert "\r" not in proc.stderr and "shortest move:" in proc.stderr  # a redirected log
    for name in (
        "model.npz",
        "optimized/trajectory.csv",
        "optimized/report.json",
        "optimized/deviation.png",
        "part_fmi2.fmu",
        "part_fmi3.fmu",
        "demo.json",
    ):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "demo.json").read_text())
    model = jaxflex.load_model(out / "model.npz")
    # the part's line is followed by the FE's estimate of its discretisation error
    stress_error = model.meta["discretisation"]["max_stress_error"]
    assert f"peak stress {100 * stress_error:.2g} %" in proc.stdout.splitlines()[1]
    move = read_trajectory_csv(out / "optimized" / "trajectory.csv")
    acc, dt_s = move.acc, move.dt_s
    # the reported cycle time is the exact one of the saved model and trajectory
    assert summary["cycle_time_s"] == jaxflex.cycle_time(model, acc, dt_s, summary["threshold_m"])
    assert summary["cycle_time_s"] >= grid_time(len(acc) - 1, dt_s)  # 0.82 s, as printed
    # both FMUs reproduce jaxflex (fmpy run inside the demo), to round-off
    assert all(f["ok"] and f["max_rel_diff"] < 1e-9 for f in summary["fmus"].values())
    assert not list(out.rglob("*.tmp"))


def test_bad_option_gives_a_clear_error(tmp_path):
    proc = run_jaxflex("demo", "-o", str(tmp_path), "--threshold", "-1")
    assert proc.returncode == 2
    assert "--threshold" in proc.stderr and "Traceback" not in proc.stderr


def test_model_takes_one_material_constant(tmp_path):
    """--E alone keeps the named material's nu, rho and yield strength: the frequencies
    scale with sqrt(E) (x10 for E x100, to the eigen solver's 1e-9), the meta says what
    changed."""
    models = {}
    for name, extra in (("steel", ()), ("stiff", ("--E", "2.1e13"))):
        path = tmp_path / f"{name}.npz"
        proc = run_jaxflex(
            "model", "--scene", "plate", "--mesh-size", "0.1", "--n-modes", "3",
            *extra, "-o", str(path), "--quiet",
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        models[name] = jaxflex.load_model(path)
    ratio = np.asarray(models["stiff"].freq_hz) / np.asarray(models["steel"].freq_hz)
    np.testing.assert_allclose(ratio, 10.0, rtol=1e-9)
    material = models["stiff"].meta["material"]
    assert material["nu"] == 0.3 and material["rho_kg_m3"] == 7850.0
    assert material["yield_pa"] == 140e6 and "E" in material["name"]
