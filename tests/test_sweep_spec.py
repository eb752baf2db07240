"""Sweep specification: validation errors name the field; grids expand as documented; case
ids depend on the content, not on names or order."""

from __future__ import annotations

import copy
import json
import re

import meshio
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxflex.cli import main
from jaxflex.errors import InputError
from optim.sweep.cases import expand, layout_job
from optim.sweep.run import Executor, run_sweep
from optim.sweep.spec import EXAMPLE, load_spec, parse_spec
from optim.sweep.work import analyse_layout, payload_model

BASE = {
    "part": {"width_m": 0.6, "height_m": 0.4},
    "moves": [{"name": "up", "distance_m": [0, 0, 0.5]}],
    "layouts": [{"name": "a", "cups": [[0.1, 0.1, 0.03], [0.5, 0.1, 0.03], [0.3, 0.3, 0.03]]}],
}


def _with(path: str, value):
    """BASE with the field at ``path`` ("moves.0.vmax") set to ``value``."""
    spec = copy.deepcopy(BASE)
    *parents, last = path.split(".")
    node = spec
    for key in parents:
        node = node[int(key)] if key.isdigit() else node.setdefault(key, {})
    if last.isdigit():
        node[int(last)] = value
    else:
        node[last] = value
    return spec


@pytest.mark.parametrize(
    ("path", "value", "field"),
    [
        ("part.width_m", -1.0, "part.width_m"),
        ("part.shape", "disc", "part.shape"),
        ("part.widht_m", 1.0, "part.widht_m: unknown field"),
        ("model.n_modes", 0, "model.n_modes"),
        ("model.zeta", 1.5, "model.zeta"),
        ("model.monitor_grid", [4], "model.monitor_grid"),
        ("optimization.threshold_m", "small", "optimization.threshold_m"),
        ("optimization.method", "newton", "optimization.method"),
        ("optimization.robust", {"freq_scale": [1.1, 0.9]}, "optimization.robust.freq_scale"),
        ("moves.0.vmax", [1, 2], "moves[0].vmax"),
        ("moves.0.jmax", 0, "moves[0].jmax"),
        ("moves.0.distance_m", [0, 0, 0], "moves[0].distance_m"),
        ("layouts.0.cups", [[0.1, 0.1]], "layouts[0].cups[0]"),
        ("layouts.0.cups", [{"x_m": 0.1, "y_m": 0.1}], "layouts[0].cups[0].radius_m"),
        (
            "grids",
            [{"nx": [2], "ny": [2], "inset_x": [0.6], "inset_y": [0.2], "radius_m": [0.03]}],
            "grids[0].inset_x[0]",
        ),
        (
            "grids",
            [{"nx": [2], "ny": [2], "inset_x": [0.2], "inset_y": [0.2]}],
            "grids[0].radius_m",
        ),
        ("moves", [], "moves"),
        ("layouts", [], "layouts"),
        ("colour", "red", "colour: unknown field"),
    ],
)
def test_bad_fields_are_named(path, value, field):
    with pytest.raises(InputError, match="^" + re.escape(field)):
        parse_spec(_with(path, value))


def test_duplicate_names_rejected():
    spec = _with("moves", [BASE["moves"][0], BASE["moves"][0]])
    with pytest.raises(InputError, match="moves: the name 'up' is used twice"):
        parse_spec(spec)


def test_example_parses_and_file_errors_name_the_file(tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text(EXAMPLE)
    spec = load_spec(path)
    # 1 explicit layout + 2 (nx) x 1 (ny) x 2 x 2 (insets) x 2 (radii) grid layouts, 2 moves
    assert len(spec.layouts) == 17 and len(spec.moves) == 2 and len(expand(spec)) == 34
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(_with("moves.0.amax", -3)))
    with pytest.raises(InputError, match=r"^bad\.json: moves\[0\]\.amax: must be > 0"):
        load_spec(bad)
    broken = tmp_path / "broken.json"
    broken.write_text("{")
    with pytest.raises(InputError, match=r"broken\.json is not valid JSON"):
        load_spec(broken)


def test_cli_reports_the_field_and_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(_with("model.n_modes", "many")))
    assert main(["sweep", str(bad), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "jaxflex sweep: error: bad.json: model.n_modes: expected an integer" in err
    assert main(["sweep", "--example"]) == 0
    assert "[[grids]]" in capsys.readouterr().out
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps(BASE))
    out = str(tmp_path / "out")
    for options in (
        ["--serial", "--dashboard", "0.0.0.0:8787"],
        ["--scheduler", "tcp://h:1", "--workers", "2"],
    ):
        assert main(["sweep", str(spec), "-o", out, *options]) == 2
        err = capsys.readouterr().err
        assert f"error: {options[-2]}: only for the embedded LocalCluster" in err


def test_case_ids_follow_content_not_names_or_order():
    spec = parse_spec(
        _with("moves", [{"name": "up", "distance_m": [0, 0, 0.5]}, {"distance_m": [0.3, 0, 0]}])
    )
    renamed = copy.deepcopy(spec.source)
    renamed["moves"].reverse()
    renamed["layouts"][0]["name"] = "renamed"
    ids = {c.case_id for c in expand(spec)}
    assert len(ids) == 2
    assert {c.case_id for c in expand(parse_spec(renamed))} == ids
    changed = copy.deepcopy(spec.source)
    changed["optimization"] = {"threshold_m": 1e-4}
    assert not ids & {c.case_id for c in expand(parse_spec(changed))}


@settings(max_examples=30, deadline=None)
@given(
    nx=st.lists(st.integers(1, 4), min_size=1, max_size=3, unique=True),
    ny=st.lists(st.integers(1, 3), min_size=1, max_size=2, unique=True),
    inset=st.lists(st.floats(0.05, 0.45), min_size=1, max_size=2, unique=True),
    radius=st.lists(st.floats(0.01, 0.05), min_size=1, max_size=2, unique=True),
)
def test_grid_expands_to_every_combination(nx, ny, inset, radius):
    grid = {"nx": nx, "ny": ny, "inset_x": inset, "inset_y": [0.25], "radius_m": radius}
    spec = parse_spec({**BASE, "layouts": [], "grids": [grid]})
    assert len(spec.layouts) == len(nx) * len(ny) * len(inset) * len(radius)
    width, height = BASE["part"]["width_m"], BASE["part"]["height_m"]
    for layout in spec.layouts:
        xs = sorted({c[0] for c in layout.cups})
        ys = sorted({c[1] for c in layout.cups})
        assert len(layout.cups) == len(xs) * len(ys)
        # outer cups at inset * side from each edge (a single cup: the centre)
        if len(xs) == 1:
            assert xs[0] == pytest.approx(width / 2)
        else:
            assert any(xs[0] == pytest.approx(f * width) for f in inset)
        assert xs[0] + xs[-1] == pytest.approx(width)
        assert ys[0] + ys[-1] == pytest.approx(height)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"kind": "threads"}, "executor"),
        ({"kind": "serial", "scheduler": "tcp://localhost:8786"}, "scheduler"),
        ({"scheduler": "localhost:8786"}, "scheduler: expected an address like tcp://"),
        ({"n_workers": 0}, "n_workers"),
        ({"kind": "serial", "dashboard_address": "127.0.0.1:0"}, "dashboard_address"),
        (
            {"scheduler": "tcp://127.0.0.1:8786", "dashboard_address": "0.0.0.0:8787"},
            "dashboard_address: only for the embedded LocalCluster",
        ),
    ],
)
def test_bad_run_options_are_named(tmp_path, kwargs, field):
    """Refused by optim.sweep.Executor when made, or (the scheduler's address) when the
    sweep connects, naming the field."""
    with pytest.raises(InputError, match="^" + re.escape(field)):
        executor = Executor(**kwargs)
        run_sweep(parse_spec(BASE), tmp_path, executor=executor, progress=False, plots=False)


def test_a_sweep_over_the_users_own_part_file(tmp_path):
    # a flat 0.6 x 0.4 m plate as a quad mesh on [1, 1.6] x [2, 2.4] (the part's coordinates)
    x, y = np.meshgrid(np.linspace(1.0, 1.6, 13), np.linspace(2.0, 2.4, 9), indexing="ij")
    idx = np.arange(x.size).reshape(x.shape)
    quads = np.column_stack([idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(),
                             idx[:-1, 1:].ravel()])  # fmt: skip
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    (tmp_path / "parts").mkdir()
    meshio.write(tmp_path / "parts" / "plate.vtu", meshio.Mesh(points, [("quad", quads)]))
    grid = {"name": "g", "nx": [2], "ny": [2], "inset_x": [0.25], "inset_y": [0.25],
            "radius_m": [0.03]}  # fmt: skip
    data = {
        **BASE,
        "part": {"path": "parts/plate.vtu", "thickness_m": 1e-3},
        "model": {"n_modes": 4, "monitor_grid": [6, 4]},
        "layouts": [],
        "grids": [grid],
    }
    (tmp_path / "sweep.json").write_text(json.dumps(data))
    spec = load_spec(tmp_path / "sweep.json")  # the path is relative to the spec file
    assert spec.part.path == str((tmp_path / "parts" / "plate.vtu").resolve())
    # grids in the part's footprint: insets from its bounding box [1, 1.6] x [2, 2.4]
    expected = [(1.15, 2.1, 0.03), (1.45, 2.1, 0.03), (1.15, 2.3, 0.03), (1.45, 2.3, 0.03)]
    np.testing.assert_allclose(spec.layouts[0].cups, expected, rtol=1e-12)
    case = expand(spec)[0]
    fe = analyse_layout(layout_job(spec, case.layout))
    assert fe["status"] == "ok", fe
    assert fe["fe"]["mass_kg"] == pytest.approx(7850 * 1e-3 * 0.24)
    assert payload_model(fe["model"]).n_points == 24  # the 6 x 4 grid, all on the part
    # the file's content is part of the case: a changed file makes new cases
    moved = points.copy()
    moved[0, 0] = 1.0 + 1e-4
    meshio.write(tmp_path / "parts" / "plate.vtu", meshio.Mesh(moved, [("quad", quads)]))
    assert expand(load_spec(tmp_path / "sweep.json"))[0].case_id != case.case_id
    for field, value in (("width_m", 1.0), ("shape", "plate")):
        with pytest.raises(InputError, match=rf"part\.{field}: not used with part\.path"):
            parse_spec({**data, "part": {**data["part"], field: value}}, tmp_path)
    with pytest.raises(InputError, match=r"part\.thickness_m: required with part\.path"):
        parse_spec({**data, "part": {"path": "parts/plate.vtu"}}, tmp_path)
    with pytest.raises(InputError, match=r"part\.scale: only with part\.path"):
        parse_spec({**BASE, "part": {"scale": 1e-3}})


def test_grid_values_equal_to_six_digits_are_distinct_layouts():
    # hypothesis found it: names formatted with %g made 0.05 and 0.0500001 one name, and the
    # spec was refused as naming a layout twice
    grid = {"nx": [2], "ny": [2], "inset_x": [0.05, 0.0500001], "inset_y": [0.25], "radius_m": 0.02}
    spec = parse_spec({**BASE, "layouts": [], "grids": [grid]})
    assert len({layout.name for layout in spec.layouts}) == 2
