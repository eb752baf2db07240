"""The cell's FMU outputs: distance to the obstacles, cup utilisation, von Mises stress.

The FMU evaluates them in C from its exact modal state, the exact path (integrated from its
inputs) and the model's linear output maps; here they are compared with jaxflex's own
evaluation (jaxflex._collision, jaxflex._loads) at every communication point of the embedded
move: the same float64 arithmetic in another order, so they agree to ~1e-12 of the peak.
"""

from __future__ import annotations

import numpy as np
import pytest
from fmpy.validation import validate_fmu

import fem
import jaxflex
from fmu import export_fmu
from fmu.master import Session
from fmu.options import CellOutputs, Fmi
from jaxflex import as_move
from jaxflex._cell import Box, Cell, HalfSpace, TriangleMesh, rotation_from_degrees
from jaxflex._collision import distances, positions_at
from jaxflex._deviation import outputs_at
from jaxflex._loads import CupUtilisation, VonMises

DT = 0.01


@pytest.fixture(scope="module")
def case():
    part = fem.rectangular_plate(0.4, 0.3, 1e-3, "steel", 0.05)
    cups = [fem.SuctionCup(x, y, 0.03) for x in (0.1, 0.3) for y in (0.08, 0.22)]
    model = fem.modal_analysis(part, cups, n_modes=5, zeta=0.02).to_modal_model(points=20)
    cell = Cell(
        obstacles=(
            Box([1.0, 0.1, 0.2], [0.3, 0.4, 0.2], rotation_from_degrees([0, 0, 20]), "post"),
            HalfSpace([0, 0, 1], -0.05, "floor"),
            TriangleMesh([[1.5, -1, -1], [1.5, 1, -1], [1.5, 0, 2]], [[0, 1, 2]], "wall"),
        ),
        start_m=[0.0, 0.0, 0.3],
        end_m=[0.8, 0.2, 0.5],
        rotation=rotation_from_degrees([0, 0, 10]),
    )
    acc = jaxflex.jerk_limited_move(cell.distance_m, 2.0, 10.0, 100.0, DT).acc
    return model, cell, acc


def _reference(model, cell, acc, t):
    posed = cell.posed(model)
    g = cell.gravity_m_s2
    points = positions_at(posed, as_move(acc, DT), t, g)  # with the static residual's D a(t)
    dist = distances(cell.obstacles, points.reshape(-1, 3))[0].reshape(points.shape[:2])
    dist -= 0.5 * posed.meta["part"]["thickness_m"]  # the skins
    cups = CupUtilisation(posed.cups, 1.7)
    y = outputs_at(posed, posed.cups.reaction, as_move(acc, DT), t, posed.cups.reaction.offset(g))
    util = cups.values(y.reshape(len(t), -1, 6), np.arange(cups.n_items))
    vm = VonMises(posed.stress.n_points)
    y = outputs_at(posed, posed.stress.stress, as_move(acc, DT), t, posed.stress.stress.offset(g))
    stress = vm.values(y.reshape(len(t), -1, 6), np.arange(vm.n_items))
    return dist, util, stress


@pytest.mark.parametrize("version", [2, 3])
def test_cell_outputs_match_jaxflex(case, tmp_path, version):
    model, cell, acc = case
    result = export_fmu(
        model, tmp_path / f"cell{version}.fmu", jaxflex.as_move(acc, DT),
        fmi=Fmi(version, windows=False), outputs=CellOutputs(cell, cup_safety=1.7, stress=True),
    )  # fmt: skip
    assert result.compiler_messages == ""
    assert validate_fmu(str(result.fmu_path)) == []
    assert (result.counts.cups, result.counts.obstacles) == (4, 3)
    n = acc.shape[0] + 20
    got = []
    with Session(result.fmu_path) as session:
        session.start(0.0, {"use_embedded_trajectory": True})
        for k in range(n):
            session.step(k * DT, DT)
            row = [session.get(name) for name in ("min_distance", "cup_utilisation", "max_stress")]
            if version == 3:
                row += [session.get(name) for name in ("point_distances", "cup_utilisations")]
                row += [session.get("point_stresses")]
            got.append(row)
    t = DT * np.arange(1, n + 1)
    dist, util, stress = _reference(model, cell, acc, t)
    scalars = np.array([r[:3] for r in got])
    np.testing.assert_allclose(scalars[:, 0], dist.min(axis=1), rtol=0, atol=1e-12)
    np.testing.assert_allclose(scalars[:, 1], util.max(axis=1), rtol=1e-10)
    np.testing.assert_allclose(scalars[:, 2], stress.max(axis=1), rtol=1e-10)
    if version == 3:
        np.testing.assert_allclose(np.array([r[3] for r in got]), dist, rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.array([r[4] for r in got]), util, rtol=1e-10)
        np.testing.assert_allclose(np.array([r[5] for r in got]), stress, rtol=1e-10, atol=1e-3)


def test_without_a_cell_the_fmu_has_no_cell_outputs(case, tmp_path):
    """A model without cups, no cell, no stress: the FMU is what it was."""
    model = case[0]
    plain = jaxflex.ModalModel(model.freq_hz, model.zeta, model.gamma, model.shapes, model.points)
    result = export_fmu(plain, tmp_path / "plain.fmu", fmi=Fmi(windows=False))
    with Session(result.fmu_path) as session:
        assert not {"min_distance", "cup_utilisation", "max_stress"} & set(session.variables)


def test_a_move_optimised_elsewhere_is_not_exported_in_the_cell(tmp_path):
    """export --cell refuses the move of a result optimised without that cell (none, or
    another one) before any build, naming the cell it was made for; the move made in the
    cell passes that check (it is the same file, by report.json's inputs.cell)."""
    from conftest import random_model, run_jaxflex

    from fmu.move_cell import check_move_cell
    from optim.cell_file import load_cell

    model = tmp_path / "m.npz"
    random_model(n_points=8, n_modes=3).save(model)
    cells = {}
    for name, end_x in (("a", 0.5), ("b", 0.6)):
        cells[name] = tmp_path / f"{name}.toml"
        cells[name].write_text(
            f"[part]\nstart_m = [0.0, 0.0, 0.1]\n[path]\nend_m = [{end_x}, 0.0, 0.3]\n"
        )
    common = ["--threshold", "1e-3", "--no-plots"]
    made_in_a = run_jaxflex("optimize", str(model), "--cell", str(cells["a"]), *common,
                            "-o", str(tmp_path / "ra"))  # fmt: skip
    no_cell = run_jaxflex("optimize", str(model), "--distance", "0.5", "0", "0.2", *common,
                          "-o", str(tmp_path / "rn"))  # fmt: skip
    assert made_in_a.returncode == 0 and no_cell.returncode == 0, made_in_a.stderr
    for result, cell, said in (("ra", "b", "optimised in another cell"),
                               ("rn", "a", "optimised without a cell")):  # fmt: skip
        fmu = tmp_path / f"{result}{cell}.fmu"
        out = run_jaxflex("export", str(model), "--trajectory", str(tmp_path / result),
                          "--cell", str(cells[cell]), "-o", str(fmu))  # fmt: skip
        assert out.returncode == 2 and said in out.stderr and "Traceback" not in out.stderr
        assert not fmu.exists()
    check_move_cell(tmp_path / "ra" / "report.json", cells["a"], load_cell(cells["a"]))
