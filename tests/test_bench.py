"""fem.bench and jaxflex bench (fmu.bench.suite): metrics against hand-computed values, the
methods against each other, the test move, and a quick run of the whole bench (JSON with
every method, PNG charts)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import random_model, run_jaxflex, smooth_move

from fem.bench.accuracy import dominance, pareto_front
from fem.bench.fe import knot_move
from fem.bench.methods import METHODS, prepare, stable_substeps
from fem.bench.metrics import compare, curve_errors, settle_from_samples
from fem.bench.turning import format_turning, swivel
from fem.bench.turning import run as turning_bench
from jaxflex._profile import as_move
from jaxflex._turning import simulate_turning
from jaxflex.errors import InputError


def test_curve_errors_hand_computed():
    ref = np.array([0.0, 1.0, 2.0, 1.0])
    est = np.array([0.0, 1.1, 2.0, 0.9])
    # residuals (0, .1, 0, -.1): sum of squares 0.02; mean(ref) = 1, spread 1 + 0 + 1 + 0 = 2
    out = curve_errors(ref, est)
    assert out["r2"] == pytest.approx(1 - 0.02 / 2, abs=1e-14)
    assert out["rmse_m"] == pytest.approx(np.sqrt(0.02 / 4), rel=1e-12)
    assert out["linf_rel_peak"] == pytest.approx(0.1 / 2.0, rel=1e-12)
    diverged = curve_errors(ref, [0.0, np.inf, np.nan, 1.0])
    assert diverged["r2"] == -np.inf and diverged["linf_rel_peak"] == np.inf
    with pytest.raises(InputError, match="curve_errors"):
        curve_errors(ref, est[:3])


def test_settle_from_samples_hand_computed():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    # last sample above 2 is t = 1 (value 3), next is 1: crossing at 1 + (3 - 2) / (3 - 1)
    assert settle_from_samples(t, [0.0, 3.0, 1.0, 0.5], 2.0) == pytest.approx(1.5)
    assert settle_from_samples(t, [0.0, 1.0, 1.0, 0.5], 2.0) == 0.0  # never above
    assert settle_from_samples(t, [0.0, 1.0, 1.0, 2.5], 2.0) == 3.0  # ends above: not settled
    assert settle_from_samples(t, [0.0, np.nan, 1.0, 0.5], 2.0) == np.inf


def test_compare_sampled_and_dense_errors():
    """A 50 Hz oscillation sampled every 10 ms is zero at every sample: the sampled curve
    of a method that returns zeros has no error at its samples, but the dense comparison on
    the fine reference grid sees the whole amplitude."""
    t_ref = np.linspace(0.0, 0.2, 2001)
    ref = np.abs(np.sin(2 * np.pi * 50 * t_ref))
    t = np.arange(21) * 0.01
    out = compare(t_ref, ref, t, np.zeros_like(t), threshold_m=0.5, settle_ref_s=0.1995)
    assert out["samples_linf_rel_peak"] < 1e-12
    assert out["linf_rel_peak"] == pytest.approx(1.0, abs=1e-6)
    assert out["settle_time_s"] == 0.0 and out["settle_error_s"] == pytest.approx(-0.1995)


def test_pareto_front_and_dominance():
    pts = [
        {"method": "scan64", "time_s": 1.0, "e": 0.1},
        {"method": "scan64", "time_s": 2.0, "e": 0.01},
        {"method": "newmark", "time_s": 1.5, "e": 0.2},  # dominated by (1, 0.1)
        {"method": "newmark", "time_s": 0.5, "e": 0.5},  # faster than every scan point
        {"method": "newmark", "time_s": 3.0, "e": np.inf},  # diverged: dominated
    ]
    front = pareto_front(pts, key="e")
    assert [(p["time_s"], p["e"]) for p in front] == [(0.5, 0.5), (1.0, 0.1), (2.0, 0.01)]
    for p in pts:
        p.update(sweep="modes", n_modes=1, dt_s=0.01, substeps=1)
    dom = dominance(pts, key="e")
    assert dom["other_points"] == 3 and dom["dominated"] == 2
    assert [e["time_s"] for e in dom["exceptions"]] == [0.5]


def test_methods_agree_where_exact_and_converge_where_not():
    model = random_model(seed=3, n_points=20, n_modes=5, f_min_hz=2.0, f_max_hz=30.0)
    dt_s = 0.01
    move = as_move(np.concatenate([smooth_move(60, dt_s), np.zeros((40, 3))]), dt_s)
    exact = np.asarray(prepare("scan64", model, move)())
    # the convolution of R1 is the same linear map: equal to round-off
    conv = np.asarray(prepare("convolution", model, move)())
    np.testing.assert_allclose(conv, exact, rtol=0, atol=1e-10 * exact.max())
    # float32: coefficient round-off ~6e-8 amplified over 100 steps
    f32 = np.asarray(prepare("scan32", model, move)(), dtype=float)
    assert np.abs(f32 - exact).max() < 1e-4 * exact.max()

    def err(method, substeps):
        dev = np.asarray(prepare(method, model, move, substeps)())
        return np.abs(dev - exact).max() / exact.max()

    # Newmark and central difference are second order: halving h quarters the error
    # (the deviation is a max over points, smooth almost everywhere: ratio within 3..5)
    for method in ("newmark", "central_difference"):
        coarse, fine = err(method, 8), err(method, 16)
        assert 3.0 < coarse / fine < 5.0, (method, coarse, fine)
    s = stable_substeps(model, 0.05)
    assert 2 * np.pi * model.freq_hz.max() * 0.05 / s <= 1.8 + 1e-12
    with pytest.raises(InputError, match="method"):
        prepare("euler", model, move)


def test_knot_move_is_one_profile_at_every_swept_dt():
    fine = knot_move(0.005, 0.6, 0.3)
    t_fine = 0.005 * np.arange(len(fine))
    for dt_s in (0.01, 0.02, 0.025):
        acc = knot_move(dt_s, 0.6, 0.3)
        t = dt_s * np.arange(len(acc))
        assert t[-1] == pytest.approx(0.9)
        for axis in (0, 2):  # the piecewise-linear profiles coincide everywhere
            np.testing.assert_allclose(
                np.interp(t_fine, t, acc[:, axis]), fine[:, axis], atol=1e-12
            )
    np.testing.assert_array_equal(fine[[0, -1]], 0.0)
    np.testing.assert_allclose(np.linalg.norm(fine.max(axis=0)), 8.0)  # peak 8 m/s^2
    with pytest.raises(InputError, match="move_s"):
        knot_move(0.01, 0.5, 0.3)
    with pytest.raises(InputError, match="dt_s"):
        knot_move(0.03, 0.6, 0.3)


def test_turning_bench_reports_both_calls(turning_plate):
    """The turning section (fem.bench.turning) on the tests' plate: both calls timed in CPU
    seconds, their ratio and the target's verdict reported (figures only: no time assert),
    the turning response the same as simulate_turning's."""
    result = turning_bench(turning_plate, repeats=2, progress=lambda _: None)
    assert result["n_points"] == turning_plate.n_points and result["n_samples"] == 181
    assert result["simulate_cpu_s"] >= 0 and result["simulate_turning_cpu_s"] >= 0
    assert result["meets_target"] == (result["ratio"] <= result["target_ratio"])
    expected = simulate_turning(turning_plate, swivel())
    assert result["peak_deviation_m"] == expected.deviation_m.max()
    assert result["neglected_bound_m"] == expected.neglected_bound_m
    assert "simulate_turning" in format_turning(result)


@pytest.mark.slow
def test_quick_bench_writes_every_method_and_chart(tmp_path):
    """One quick run through the CLI, as a user runs it (CI size; a single test so that
    parallel workers do not repeat it)."""
    out = tmp_path / "bench"
    proc = run_jaxflex("bench", "--quick", "-o", str(out), timeout_s=900)
    assert proc.returncode == 0, proc.stderr
    assert "\r" not in proc.stderr and "reduced methods: " in proc.stderr  # a redirected log
    saved = json.loads((out / "bench.json").read_text())
    assert set(saved["accuracy"]) == {"plate", "panel"}
    for name, scene in saved["accuracy"].items():
        methods = {p["method"] for p in scene["points"]}
        assert methods == {*METHODS, "fe_newmark"}, name
        png = (out / f"pareto_{name}.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
        # the exact scan and the convolution are the same linear map: identical errors
        by_config = {}
        for p in scene["points"]:
            if p["method"] in ("scan64", "convolution"):
                key = (p["sweep"], p["n_modes"], p["n_points"], p["dt_s"])
                by_config.setdefault(key, []).append(p["samples_linf_rel_peak"])
        assert all(abs(a - b) < 1e-9 for a, b in by_config.values())
        assert scene["dominance"]["other_points"] > 0
    assert (out / "stability.png").read_bytes()[:4] == b"\x89PNG"
    stab = saved["stability"]["breaks_at_omega_dt"]
    assert stab["error_above_1pct"]["scan64"] is None  # exact at every omega dt
    assert stab["error_above_100pct"]["central_difference"] is not None
    assert stab["settle_error_above_5ms"]["analyze_move"] is None
    # the core speed section
    core = saved["results"]
    assert core["convolution_vs_scan_max_rel_diff"] < 1e-10
    assert core["float32_max_rel_error"] < 1e-4
    assert np.isfinite(core["forward_ms"]) and core["forward_ms"] > 0
    assert core["cycle_time_smooth_s"] >= core["cycle_time_s"]
    # the all-node section: every size timed on the named device, the reduction study's
    # reference row is every node of the mesh and the reductions have fewer points
    nodes = saved["nodes"]
    assert nodes["scale"]["device"].startswith("cpu")
    assert [r["n_points"] for r in nodes["scale"]["forward"]] == [1_099, 5_000]
    assert all(r["forward_ms"] > 0 and r["peak_rss_mb"] > 0 for r in nodes["scale"]["forward"])
    assert nodes["scale"]["cycle_time"]["cycle_time_s"] > 0
    rows = nodes["reduction"][0]["rows"]
    assert rows[0]["n_points"] == nodes["reduction"][0]["mesh_nodes"]
    assert rows[0]["peak_error_rel"] == 0.0 and rows[0]["settle_error_s"] == 0.0
    assert all(r["n_points"] < rows[0]["n_points"] for r in rows[1:])
    # a subset of points never sees more than all of them
    assert all(r["peak_deviation_m"] <= rows[0]["peak_deviation_m"] * (1 + 1e-12) for r in rows)
    assert not list(out.rglob("*.tmp"))
    # whole commands from outside, cold and warm (figures only: no wall-clock assert); the
    # warm run loads what the cold one compiled and gives the same answer
    (run,) = saved["commands"]["optimize"]["rounds"]
    assert run["cache_entries"] > 0
    assert run["cold"]["answer"].startswith("best move: ")
    assert run["warm"]["answer"] == run["warm_no_plots"]["answer"] == run["cold"]["answer"]
    assert all(run[k]["cpu_s"] > 0 for k in ("cold", "warm", "warm_no_plots"))
    # the start-up figures (issue 32) and the cost of the cache's checks, one per JAX entry
    startup = saved["commands"]["startup"]
    assert set(startup) == {"version", "argument_error", "zero_length_move"}
    assert all(figures["cpu_s"] > 0 for figures in startup.values())
    assert saved["commands"]["cache_checks"]["jax"]["entries"] == run["cache_entries"]
    assert "commands (load average" in proc.stdout

    # FE-agreement target on the plate: the built-in plate (1.5 x 0.8 m, 4 cups) on a 100 mm
    # Morley mesh, 40 modes against its own full-order FE transient (Richardson-extrapolated
    # Newmark). docs/design.md: R^2 >= 0.99999, L-inf <= 0.2 % of the peak, settle time within
    # 10 ms (measured: deviation R^2 0.9999929, 0.12 %, displacement 0.19 %, settle 0.06 ms).
    row = next(r for r in saved["accuracy"]["plate"]["agreement"] if r["n_modes"] == 40)
    assert row["meets_target"], row
    assert saved["accuracy"]["plate"]["fe"]["reference_self_error"]["max_error_rel_peak"] < 2e-3
