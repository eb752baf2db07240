"""One budget for all work (jaxflex._budget): every command takes --max-memory and --max-time,
plans its work from its inputs and refuses what does not fit, before any of it.

The hostile requests of issue 23 (fem.bench.budget.refusal_cases: robust grids of
100 000 x 100 000, a monitor grid of 10^10 points, 6.35 M sweep cases, meshes of 10^10
cells, 120 m CAD sheets, 2 000 000 triangles, 10 000 obstacles) run as commands under a hard
address-space limit (``ulimit -v``: a command that tried to go beyond its budget would die
or raise MemoryError there) and must exit with status 2 and one line saying what the work
would need, without a traceback, before any case or analysis is computed. Their times and
peak memories are what ``python -m fem.bench.budget --refusals`` reports; nothing here
asserts a time.
"""

from __future__ import annotations

import json
import time
import warnings

import numpy as np
import pytest
from conftest import random_model, run_jaxflex
from sweep_cases import SPEC

from fem.bench.budget import refusal_cases, run_limited
from jaxflex._budget import (
    Budget,
    Need,
    check_time,
    current_budget,
    format_bytes,
    format_seconds,
    make_budget,
    require,
    use_budget,
)
from jaxflex.errors import BudgetError, InputError
from optim.options import RobustSpec


@pytest.mark.slow
def test_hostile_requests_are_refused_within_a_hard_memory_limit(tmp_path, fuzz_tally):
    cases = refusal_cases(tmp_path)
    runs = {label: run_limited(argv, tmp_path) for label, argv in cases.items()}
    refused = {
        label: run
        for label, run in runs.items()
        if run.status == 2
        and "Traceback" not in run.stderr
        and "MemoryError" not in run.stderr
        and run.stderr.strip().splitlines()[-1].startswith("jaxflex ")
    }
    fuzz_tally(
        "budget refusals (ulimit -v 4 GB)",
        tried=len(runs),
        clear_errors=len(refused),
        crashes=sum(run.status < 0 or "Traceback" in run.stderr for run in runs.values()),
        hangs=0,
        corrupt_accepted=sum(run.status == 0 for run in runs.values()),
    )
    assert refused.keys() == runs.keys(), {k: r.stderr[-400:] for k, r in runs.items()}
    for label, run in runs.items():
        message = run.stderr.strip().splitlines()[-1]
        assert "memory:" in message or "time:" in message or "spans 120 m" in message, label
        assert "needs about" in message or "spans" in message, label
    # refused before the first case: no record, no stored model
    assert not list(tmp_path.glob("out_*/cases/*.json"))
    assert not list(tmp_path.glob("out_*/models/*.npz"))


def test_every_command_takes_the_budget_options():
    for command in ("model", "optimize", "sweep", "export", "demo", "bench"):
        out = run_jaxflex(command, "--help")
        assert "--max-memory GB" in out.stdout and "--max-time S" in out.stdout, command


def test_budget_options_are_checked(tmp_path):
    for option, value in (("--max-memory", "0"), ("--max-time", "-1"), ("--max-memory", "nan")):
        out = run_jaxflex("model", "--scene", "plate", "-o", str(tmp_path / "m.npz"), option, value)
        assert out.returncode == 2 and f"{option}: must be a finite number > 0" in out.stderr


def test_require_names_the_stage_its_need_and_the_budget(capsys, monkeypatch):
    import jaxflex._progress

    # not quiet, whatever a command run in-process before this test in the worker left set
    monkeypatch.setitem(jaxflex._progress._state, "quiet", False)
    small = Need("reading", 1e5, 1.0)
    big = Need("the analysis (5 cells)", 3e6, 2.0, "use a coarser mesh")
    with pytest.raises(
        BudgetError,
        match=r"memory: the analysis \(5 cells\) needs about 3 MB, "
        r"more than the budget of 1 MB \(--max-memory\); use a coarser mesh",
    ):
        require(small, big, budget=Budget(1_000_000, 10.0))  # fmt: skip
    # times add up over the stages; memory is the largest stage's
    now = time.monotonic()
    require(small, Need("b", 1e6, 8.0), budget=Budget(1_000_000, 3600.0, start_s=now))
    with pytest.raises(
        BudgetError, match=r"time: b needs about 66.7 min on this machine \(all the "
    ):
        require(small, Need("b", 0, 4000.0), budget=Budget(1_000_000, 3600.0, start_s=now))
    assert format_bytes(1.34e15) == "1,340 TB" and format_bytes(2.5e9) == "2.5 GB"
    assert "planned" not in capsys.readouterr().err  # short work goes unannounced
    # work that fits but takes a minute or more says so before it starts
    require(small, Need("b", 0, 119.0), budget=Budget(1_000_000, 3600.0, start_s=now))
    assert "planned: b: about 2 min on this machine, within the budget of 60 min" in (
        capsys.readouterr().err
    )
    assert format_seconds(30) == "30 s" and format_seconds(7200) == "2 h"


def test_the_process_budget_is_per_thread_and_the_clock_runs():
    import threading

    seen = {}
    with use_budget(make_budget(0.5, 100.0)):
        assert current_budget().memory_bytes == 500_000_000
        thread = threading.Thread(target=lambda: seen.update(m=current_budget().memory_bytes))
        thread.start()
        thread.join()
    assert seen["m"] != 500_000_000  # the other thread works under the machine's default
    with (
        use_budget(make_budget(None, 1e-9)),
        pytest.raises(BudgetError, match=r"^time: the work ran out of the budget of 1e-09 s \("),
    ):
        check_time("the work")
    with pytest.raises(InputError, match="--max-time"):
        make_budget(None, 0.0)


def test_a_spec_whose_grids_are_absurd_is_refused_while_it_is_read():
    from optim.sweep.spec import parse_spec

    spec = {**SPEC, "grids": [{**SPEC["grids"][0], "nx": list(range(1, 400)),
                                "ny": list(range(1, 400)), "radius_m": [0.01] * 100}]}  # fmt: skip
    with pytest.raises(BudgetError, match=r"cases \(at least"):
        parse_spec(spec)


def test_robust_grid_is_counted_not_built():
    spec = RobustSpec((0.9, 1.1), (0.01, 0.03), 100_000, 100_000)
    assert spec.n_scenarios == 10**10
    assert RobustSpec((1.0, 1.0), None, 50, 7).n_scenarios == 1
    assert RobustSpec().n_scenarios == len(RobustSpec().grid())


def test_a_sweep_whose_cases_all_failed_exits_non_zero(tmp_path):
    spec = {**SPEC, "layouts": [SPEC["layouts"][0]], "grids": []}  # one layout, off the part
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec), encoding="utf-8")
    out = run_jaxflex("sweep", str(path), "--serial", "--no-plots", "-o", str(tmp_path / "o"))
    assert out.returncode == 1, out.stderr
    assert "every case failed (2 errors)" in out.stderr and "off part" in out.stderr


def test_an_optimisation_that_cannot_fit_the_time_budget_is_refused(tmp_path):
    """A lone 0.01 Hz mode: its search needs moves of up to 30 s (3 000 LP steps), about
    2 min of LPs: refused under --max-time 30 once the baselines bracket it."""
    model = random_model(n_points=4, n_modes=1, f_min_hz=0.01, f_max_hz=0.01)
    path = tmp_path / "lone.npz"
    model.save(path)
    out = run_jaxflex(
        "optimize", str(path), "--distance", "0", "0", "1", "--threshold", "5e-4",
        "--max-time", "30", "-o", str(tmp_path / "o"),
    )  # fmt: skip
    assert out.returncode == 2, out.stderr
    assert "time: the search" in out.stderr and "3000 steps" in out.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("solver", ["highs", "casadi", "casadi-highs"])
def test_a_linear_program_stops_at_the_time_budget(solver):
    """--max-time holds inside one LP, whichever back end (the solver's time limit is the
    budget left): a dense LP of 1 000 rows and 500 variables (more than the 10 ms left for
    each) ends in a BudgetError naming its size and the budget, not after the LP; with the
    budget's time it solves."""
    from optim.lp import LinearProgram, SparseMatrix, solve_lp

    rng = np.random.default_rng(0)
    matrix = rng.uniform(0.0, 1.0, (1000, 500))
    lp = LinearProgram(
        cost=-rng.uniform(0.5, 1.0, 500),  # maximise: the rows bind
        matrix=SparseMatrix.from_dense(matrix),
        row_lo=np.full(1000, -np.inf),
        row_hi=matrix @ np.full(500, 0.5),  # x = 0.5 is feasible
        var_lo=np.zeros(500),
        var_hi=np.ones(500),
    )
    with (
        use_budget(make_budget(None, 0.01)),
        pytest.raises(
            BudgetError,
            match=r"time: a linear program of the search \(1000 rows, 500 variables\) ran out "
            r"of the budget of 0.01 s \(--max-time\)",  # as check_time names the budget
        ),
    ):
        solve_lp(lp, solver)
    assert solve_lp(lp, solver).status == "optimal"


def test_entries_below_the_tolerance_are_dropped_before_highs():
    """The search's residual rows carry entries down to 1e-20 (modes decayed over a long
    settling; HiGHS stalled on such a program for minutes, `--robust --freq-scale 0.5 2`):
    an entry whose largest contribution |a_ij| max|x_j| is below 1e-15 is dropped, the
    others kept, and the program's solution is that of the program without them."""
    from optim.lp import LinearProgram, SparseMatrix, _negligible_dropped, solve_lp

    rng = np.random.default_rng(1)
    matrix = rng.uniform(0.1, 1.0, (40, 20)) * (rng.uniform(size=(40, 20)) < 0.5)
    tiny = np.zeros_like(matrix)
    tiny[matrix == 0] = 5e-20  # below: dropped
    tiny[tuple(np.argwhere(matrix == 0)[0])] = 1e-14  # x reaches 10: up to 1e-13, kept
    bounds = np.full(20, 10.0)

    def program(a):
        return LinearProgram(
            cost=-np.ones(20), matrix=SparseMatrix.from_dense(a), row_lo=np.full(40, -np.inf),
            row_hi=np.full(40, 5.0), var_lo=-bounds, var_hi=bounds,
        )  # fmt: skip

    kept = _negligible_dropped(program(matrix + tiny)).toarray()
    assert np.array_equal(kept, matrix + (tiny == 1e-14) * tiny)
    # an unbounded variable keeps its entries, however small, and a stored zero is no nan
    free = program(matrix)
    rows, cols = np.nonzero(matrix[2:])  # rows 0 and 1: in the last column 1e-30, a stored 0
    free.matrix = SparseMatrix.from_entries(
        np.r_[0, 1, rows + 2],
        np.r_[19, 19, cols],
        np.r_[1e-30, 0.0, matrix[2:][rows, cols]],
        matrix.shape,
    )
    free.var_lo, free.var_hi = np.r_[-bounds[1:], -np.inf], np.r_[bounds[1:], np.inf]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # 0 * inf would warn "invalid value"
        kept = _negligible_dropped(free).toarray()
    assert kept[0, -1] == 1e-30 and free.matrix.nnz == kept.astype(bool).sum() + 1
    for solver in ("highs", "casadi", "casadi-highs"):  # every back end gets the same matrix
        with_tiny = solve_lp(program(matrix + tiny), solver)
        without = solve_lp(program(matrix), solver)
        assert with_tiny.status == without.status == "optimal"
        assert with_tiny.objective == pytest.approx(without.objective, abs=1e-9)


def test_more_modes_than_dofs_are_said_and_solved_densely():
    """--n-modes 100000 on a plate of a few hundred DOFs: a warning names both numbers and
    the lowest modes come from a dense solve (equal to the iterative solve's first ones)."""
    import fem

    part = fem.rectangular_plate(0.6, 0.4, 1e-3, mesh_size=0.2)
    supports = fem.SimplySupportedEdge("all")
    with pytest.warns(UserWarning, match=r"n_modes: 100000 modes asked .* free DOFs"):
        dense = fem.modal_analysis(part, supports, n_modes=100_000)
    iterative = fem.modal_analysis(part, supports, n_modes=6)
    assert dense.n_modes > 6
    # both solve the same eigenproblem to machine precision (relative 1e-10, measured 1e-13)
    np.testing.assert_allclose(dense.freq_hz[:6], iterative.freq_hz, rtol=1e-10)


def test_a_sweep_is_planned_in_full_before_its_first_case(tmp_path):
    """A spec of 1 000 moves (5 000 cases at 0.3 s or more each, optim.sweep.plan.MIN_CASE_S:
    12.5 min on two workers) is refused under --max-time 300 before any case or model
    is written; ``model.n_modes = 100000`` on a mesh of about 5 000 DOFs is refused naming
    the field (the FE would give fewer after a dense solve of every DOF)."""
    moves = [{"name": f"m{i}", "distance_m": [0, 0, 0.2 + 0.001 * i]} for i in range(1000)]
    many = tmp_path / "many.json"
    many.write_text(json.dumps({**SPEC, "moves": moves}), encoding="utf-8")
    modes = tmp_path / "modes.json"
    modes.write_text(json.dumps({**SPEC, "model": {**SPEC["model"], "n_modes": 100_000}}))
    for path, match in ((many, "time: the sweep's 5 layout(s) x 1000 move(s) = 5,000 cases"),
                        (modes, "model.n_modes: 100,000 modes asked, more than the part's mesh "
                                "has DOFs")):  # fmt: skip
        out_dir = tmp_path / f"out_{path.stem}"
        out = run_jaxflex("sweep", str(path), "--serial", "--max-time", "300", "-o", str(out_dir))
        assert out.returncode == 2, out.stderr
        assert match in out.stderr and "Traceback" not in out.stderr
        assert not list(out_dir.glob("cases/*.json")) and not list(out_dir.glob("models/*"))


def test_a_stiff_parts_cup_constraints_are_planned_before_the_baselines(monkeypatch):
    """A steel plate made 10^6 times stiffer (kHz modes): certifying its cups on every
    baseline samples each kHz period 16 times (optim.budget.families_need); under a 2 s
    budget the optimisation is refused naming the constraints, before any baseline runs."""
    import fem
    import optim
    import optim.stages
    from fem.materials import Material
    from optim.budget import FAMILY_POWER, families_need
    from optim.cell_setup import prepare_cell

    def no_baselines(*args, **kwargs):
        raise AssertionError("the baselines ran before the plan refused the work")

    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.1, 0.3) for y in (0.08, 0.22)]
    models = {}
    for name, e_pa in (("steel", 210e9), ("stiff", 2.1e17)):
        part = fem.rectangular_plate(0.4, 0.3, 1e-3, Material(name, e_pa, 0.3, 7850.0, 140e6),
                                     0.1)  # fmt: skip
        models[name] = fem.modal_analysis(part, cups, n_modes=3).to_modal_model(points=12)
    need = {}
    for name, model in models.items():
        families = prepare_cell(model, [0, 0, 1], cup_safety=1.5).families
        need[name] = families_need(families, model, 69, 0.01, 1).time_s
    # frequencies scale with sqrt(E): 1 000 times the samples, the time as their power fitted
    ratio = models["stiff"].freq_hz.max() / models["steel"].freq_hz.max()
    assert ratio == pytest.approx(1000.0, rel=1e-6)
    assert need["stiff"] / need["steel"] == pytest.approx(ratio**FAMILY_POWER, rel=1e-9)
    monkeypatch.setattr(optim.stages, "compute_baselines", no_baselines)
    limits = optim.Limits(vmax=2.0, amax=10.0, jmax=100.0)
    with (
        use_budget(make_budget(None, 2.0)),
        pytest.raises(
            BudgetError, match=r"time: the cell's constraints \(cup utilisation\) on 18 baselines"
        ),
    ):
        optim.optimize(
            models["stiff"],
            (0, 0, 1),
            limits,
            0.01,
            5e-4,
            constraints=optim.Constraints(cup_safety=1.5),
        )
