"""The command line as a user runs it, and how the dispatcher finds the commands."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from importlib.metadata import entry_points

import numpy as np
import pytest
from conftest import run_jaxflex

import jaxflex
import optim.sweep.cli
from jaxflex._grid import grid_time
from jaxflex._trajectory_io import read_trajectory_csv
from jaxflex.cli import BLAS_THREADS_VAR, GROUP, commands, main

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


# what no command module loads on import: its options are built and checked first
HEAVY_WORK = ("jax", "scipy", "skfem", "matplotlib", "casadi", "meshio", "gmsh", "fmpy", "dask")


def test_command_modules_import_nothing_heavy():
    for module in COMMANDS.values():
        code = f"import json, sys, {module}\n"
        code += f"print(json.dumps([m for m in {HEAVY_WORK!r} if m in sys.modules]))"
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        assert json.loads(proc.stdout) == [], module


# what OpenBLAS runs with (threadpoolctl reads it from the loaded library) after the
# dispatcher's setup, then NumPy's import, in a fresh interpreter
BLAS_THREADS = (
    "import json; from jaxflex.cli import _one_blas_thread; _one_blas_thread(); import numpy; "
    "from threadpoolctl import threadpool_info; "
    "print(json.dumps([i['num_threads'] for i in threadpool_info() if i['internal_api'] == "
    "'openblas']))"
)


@pytest.mark.parametrize(("chosen", "expected"), [(None, 1), ("2", 2)])
def test_a_command_runs_one_blas_thread_unless_the_user_chose(chosen, expected):
    env = {k: v for k, v in os.environ.items() if k != BLAS_THREADS_VAR}
    if chosen is not None:
        env[BLAS_THREADS_VAR] = chosen
    proc = subprocess.run(
        [sys.executable, "-c", BLAS_THREADS], capture_output=True, text=True, env=env
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == [expected]


# the objects frozen for the collector (gc.freeze) in a fresh interpreter after the command's
# setup: none before JAX's import, some after it, more after matplotlib.pyplot's; JAX's own
# setup (float64) still runs after its import
COLLECT_LESS = (
    "import gc, json; from jaxflex.cli import _collect_less; _collect_less(); "
    "counts = [gc.get_freeze_count()]; import jax; counts.append(gc.get_freeze_count()); "
    "import matplotlib.pyplot; counts.append(gc.get_freeze_count()); "
    "print(json.dumps([counts, bool(jax.config.jax_enable_x64)]))"
)


def test_a_command_freezes_what_jax_and_matplotlib_import_for_the_collector():
    proc = subprocess.run([sys.executable, "-c", COLLECT_LESS], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    (before, after_jax, after_pyplot), float64 = json.loads(proc.stdout)
    assert before == 0 < after_jax < after_pyplot and float64


def test_the_installed_command_and_python_m_run_the_console_entry():
    (script,) = [e for e in entry_points(group="console_scripts") if e.name == "jaxflex"]
    assert script.value == "jaxflex.cli:console"
    with open(os.path.join(os.path.dirname(jaxflex.__file__), "__main__.py")) as source:
        assert "console()" in source.read()


# `jaxflex ARGS` answered without importing JAX: (ARGS, exit status, what the answer says);
# a path that does not exist is MISSING, the model file of a test is MODEL
AT_ONCE = [
    (["--version"], 0, "jaxflex "),
    (["--help"], 0, "optimize"),
    *(([name, "--help"], 0, "usage: jaxflex " + name) for name in COMMANDS),
    (["optimize"], 2, "the following arguments are required: model"),
    (["optimize", "MODEL", "-o", "OUT", "--threshold", "x"], 2, "argument --threshold"),
    (["model", "--scene", "cube"], 2, "argument --scene: invalid choice"),
    (["export", "MODEL", "--fmi", "4"], 2, "argument --fmi: invalid choice"),
    (["bench", "--size", "huge"], 2, "argument --size: invalid choice"),
    (["demo", "--threshold", "-1"], 2, "--threshold: must be a finite number > 0"),
    (["sweep", "MISSING", "-o", "OUT"], 2, "does not exist"),
    (["sweep", "SPEC", "-o", "OUT"], 2, "spec: spec.toml is not valid TOML"),
    # cheap input checks: a zero-length move, a missing file, bad numbers
    (["optimize", "MODEL", "--distance", "0", "0", "0", "--threshold", "1e-3", "-o", "OUT"], 2,
     "the move has zero length"),
    (["optimize", "MISSING", "--distance", "0", "0", "1", "--threshold", "1e-3", "-o", "OUT"], 2,
     "does not exist"),
    (["optimize", "MODEL", "--distance", "0", "0", "1", "--threshold", "-1", "-o", "OUT"], 2,
     "--threshold (threshold_m): must be a finite number > 0"),
    (["optimize", "MODEL", "--distance", "0", "0", "1", "--threshold", "1e-3", "--amax", "0",
      "-o", "OUT"], 2, "--amax[x]: must be a finite number > 0"),
    (["optimize", "MODEL", "--distance", "0", "0", "1", "--threshold", "1e-3", "--dt", "nan",
      "-o", "OUT"], 2, "--dt (dt_s): must be a finite number > 0"),
    (["optimize", "MODEL", "--distance", "0", "0", "1", "--threshold", "1e-3", "-o", "OUT",
      "--robust", "--grid", "0", "3"], 2, "--grid N_FREQ N_ZETA (n_freq): must be an integer"),
    (["optimize", "MODEL", "--distance", "0", "0", "1", "--threshold", "1e-3", "-o", "OUT",
      "--robust", "--freq-scale", "1.2", "0.8"], 2, "--freq-scale (freq_scale): expected"),
    (["export", "MISSING", "-o", "OUT.fmu"], 2, "does not exist"),
    (["export", "MODEL", "-o", "OUT.fmu", "--threshold", "0"], 2, "--threshold: must be"),
    (["export", "MODEL", "-o", "OUT.txt"], 2, "-o/--output: the file name must end in .fmu"),
    (["export", "MODEL", "--ssp", "OUT.zip", "--trajectory", "OUT"], 2,
     "--ssp: the file name must end in .ssp"),
    (["model", "--mesh", "MISSING", "--thickness", "1e-3"], 2, "--mesh: file"),
    (["model", "--scene", "plate", "--n-modes", "0"], 2, "--n-modes (n_modes): must be an"),
    (["model", "--scene", "plate", "--plot", "OUT.txt"], 2, "--plot: the file name must end in"),
    (["model", "--scene", "plate", "--vtu", "OUT.txt"], 2, "--vtu: the file name must end in"),
    (["optimize", "MODEL", "--distance", "0", "0", "1", "--threshold", "1e-3", "-o", "OUT",
      "--cup-friction", "0.5"], 2, "--cup-friction / --cup-vacuum: only with --cup-safety"),
    (["model", "--scene", "plate", "--mesh-size", "-1"], 2, "--mesh-size (mesh_size): must be"),
    (["model", "--scene", "plate", "--E", "-5"], 2, "--E (E_pa): must be a finite number > 0"),
    (["export", "MODEL", "-o", "OUT.fmu", "--cell", "SPEC"], 2, "--cell (cell): spec.toml is not"),
    (["export", "MODEL", "-o", "OUT.fmu", "--trajectory", "SPEC"], 2, "--trajectory: "),
    (["optimize", "MODEL", "--distance", "0", "0", "1", "--threshold", "1e-3", "-o", "OUT",
      "--vpath", "-1"], 2, "--vpath (vpath): must be a finite number > 0"),
    (["animate", "MISSING"], 2, "RESULT_DIR"),
    (["animate", "OUT", "--page-points", "0"], 2, "--page-points: must be a finite number > 0"),
    (["animate", "OUT", "--after", "-1"], 2, "--after: a time >= 0 s"),
    (["optimize", "MODEL", "--distance", "0", "0", "0", "--threshold", "1e-3", "-o", "OUT",
      "--animate"], 2, "the move has zero length"),
]  # fmt: skip


def _answered_in_child(argv: list[str]) -> tuple[str, str]:
    """(``loaded: [the HEAVY_WORK modules it imported] STATUS``, all it printed) of
    `jaxflex ARGV` run in a child interpreter."""
    code = (
        "import sys\n"
        "from jaxflex.cli import main\n"
        "try:\n"
        f"    status = main({argv!r})\n"
        "except SystemExit as exc:\n"
        "    status = exc.code\n"
        f"print('loaded:', [m for m in {HEAVY_WORK!r} if m in sys.modules], status)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert "Traceback" not in proc.stderr, proc.stderr
    return proc.stdout.rstrip().rpartition("\n")[2], proc.stdout + proc.stderr


@pytest.mark.parametrize(("args", "status", "answer"), AT_ONCE)
def test_a_command_answers_without_importing_jax(tmp_path, args, status, answer):
    """--version, --help, argument errors and the cheap input checks come before any heavy
    import (a child interpreter's sys.modules, not a time), and before the model is read."""
    model = tmp_path / "model.npz"
    model.write_bytes(b"not read before the arguments are checked")
    spec = tmp_path / "spec.toml"
    spec.write_text("moves = [\n")  # a sweep spec that is no TOML
    names = {"MODEL": str(model), "MISSING": str(tmp_path / "missing"), "OUT": str(tmp_path / "o")}
    names["SPEC"] = str(spec)
    argv = [names.get(arg, arg.replace("OUT", str(tmp_path / "o"))) for arg in args]
    loaded, answered = _answered_in_child(argv)
    assert loaded == f"loaded: [] {status}", answered
    assert answer in answered


def test_a_link_in_the_animations_place_is_refused_before_any_work(tmp_path):
    """`optimize --animate` and `animate RESULT_DIR` refuse a link in place of an animation
    file (optim.result_files.check_animation_dir) before JAX loads, and leave it alone."""
    from jaxflex.files import writing
    from optim.result_files import RESULT_FILES, RESULT_KIND

    model = tmp_path / "model.npz"
    model.write_bytes(b"not read before the outputs are checked")
    result = tmp_path / "result"
    with writing(result, RESULT_KIND, RESULT_FILES) as files:  # a complete (small) set
        files.add_text("trajectory.csv", "t_s,ax,ay,az\n0,0,0,0\n")
        files.add_text("report.json", "{}")
    (result / "animation").mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("kept")
    (result / "animation" / "part.xdmf").symlink_to(victim)
    optimize = ["optimize", str(model), "--distance", "0", "0", "1", "--threshold", "1e-3"]
    for argv in ([*optimize, "-o", str(result), "--animate"], ["animate", str(result)]):
        loaded, answered = _answered_in_child(argv)
        assert loaded == "loaded: [] 2", answered
        assert "symbolic link" in answered and "part.xdmf" in answered, answered
    assert (result / "animation" / "part.xdmf").is_symlink() and victim.read_text() == "kept"


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
    # where each FMU's binary came from, as it happened (issue 35: not "with gcc" for a copy)
    fmu_lines = [line for line in proc.stdout.splitlines() if line.startswith("FMI ")]
    assert len(fmu_lines) == 2
    assert all(line.endswith(("FMU binary compiled with gcc", "FMU binary from the cache"))
               for line in fmu_lines)  # fmt: skip
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
    stiffness = ("--cup-stiffness", "1,2")
    proc = run_jaxflex("model", "--scene", "plate", *stiffness, "-o", str(tmp_path / "m"))
    assert proc.returncode == 2
    assert "error: --cup-stiffness: stiffness: expected four numbers, got 2" in proc.stderr


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
