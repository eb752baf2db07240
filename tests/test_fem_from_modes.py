"""--from-modes: modes another solver computed, read from OP2, punch and Universal Files.

The files are written here from a known model (our own FE of a plate on four cups) with
writers of the formats (tests/solver_files.py; pyuff's own writer for the Universal File)
and read back: frequencies, shapes and participation factors must be the model's to the
precision the file was written with. Real third-party files (pyNastran's model library,
BSD-3-Clause) are read where JAXFLEX_PYNASTRAN_MODELS points to its models/ directory.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import run_jaxflex
from solver_files import write_op2, write_punch

import fem
import jaxflex
from fem.imports.from_modes import from_modes
from jaxflex.errors import InputError, JaxflexWarning

FLOAT64 = 1e-9  # files written with 8-byte words or 11 digits: round-off only
FLOAT32 = 1e-6  # 4-byte words: float32 eps 6e-8 per value, rescaling and sums add a few


@pytest.fixture(scope="module")
def plate(four_cup_plate):
    return four_cup_plate


def _truth(plate):
    return plate.system.nodes, plate.node_shapes(), plate.freq_hz, plate.gamma


def _ids(plate):
    return np.arange(1, len(plate.system.nodes) + 1) * 10


def _same_model(result, plate, rtol: float) -> None:
    nodes, shapes, freq, gamma = _truth(plate)
    np.testing.assert_allclose(result.freq_hz, freq, rtol=rtol)
    np.testing.assert_allclose(result.shapes, shapes, atol=rtol * np.abs(shapes).max())
    np.testing.assert_allclose(result.gamma, gamma, atol=rtol * np.abs(gamma).max())
    np.testing.assert_allclose(result.nodes, nodes, atol=rtol)
    # the models move alike: the same deviation for a move (the FE model's modes alone:
    # modal results carry no static response)
    acc = jaxflex._profile.jerk_limited_move([0, 0, 0.5], vmax=1, amax=5, jmax=50, dt_s=0.01).acc
    ours = jaxflex.simulate(result.to_modal_model(), acc, 0.01).deviation
    fe = plate.to_modal_model()
    modes = jaxflex.ModalModel(fe.freq_hz, fe.zeta, fe.gamma, fe.shapes, fe.points)
    theirs = jaxflex.simulate(modes, acc, 0.01).deviation
    np.testing.assert_allclose(ours, theirs, atol=10 * rtol * np.max(theirs))


def test_op2_with_participation_factors_is_the_model(tmp_path, plate):
    nodes, shapes, freq, gamma = _truth(plate)
    path = tmp_path / "plate.op2"
    write_op2(path, freq, _ids(plate), nodes, shapes, gamma=gamma, word=8)
    result = from_modes(path, units="SI")
    _same_model(result, plate, FLOAT64)
    derived = result.provenance["derived"]
    assert "mass-normalised as read" in derived["mass_normalisation"]
    assert "MPFACS" in derived["gamma"]
    assert "no exact quasi-static response" in result.provenance["static_response"]
    with pytest.raises(InputError, match="does not state its unit system"):
        from_modes(path)
    with pytest.raises(InputError, match="holds the participation factors; do not pass"):
        from_modes(path, units="SI", gamma=gamma)


def test_op2_in_max_normalisation_and_millimetres_is_rescaled(tmp_path, plate):
    # MAX normalisation: shapes x c, generalized mass c^2, Nastran's MPFACS Gamma / c; and
    # the MPA system (mm, t): shapes in mm / t^0.5, Gamma in t^0.5, coordinates in mm
    nodes, shapes, freq, gamma = _truth(plate)
    c = np.linspace(0.5, 3.0, freq.size)
    to_mm, to_t = 1e3, 1e-3
    path = tmp_path / "plate.op2"
    write_op2(
        path,
        freq,
        _ids(plate),
        nodes * to_mm,
        shapes * c * to_mm / np.sqrt(to_t),
        generalized_mass=c**2,
        gamma=gamma / c[:, None] * np.sqrt(to_t),
        word=4,
        table="BOUGV1",
    )
    result = from_modes(path, units="MPA")
    _same_model(result, plate, FLOAT32)
    assert "shapes scaled by 1/sqrt(mass)" in result.provenance["derived"]["mass_normalisation"]


def test_op2_without_participation_factors_needs_them_from_the_user(tmp_path, plate):
    nodes, shapes, freq, gamma = _truth(plate)
    path = tmp_path / "plate.op2"
    write_op2(path, freq, _ids(plate), nodes, shapes, word=8)
    result = from_modes(path, units="SI")
    with pytest.raises(InputError, match=r"holds no participation factors .*pass gamma="):
        result.to_modal_model()
    _same_model(from_modes(path, units="SI", gamma=gamma), plate, FLOAT64)
    with pytest.raises(InputError, match=r"gamma: expected finite values of shape \(6, 3\)"):
        from_modes(path, units="SI", gamma=gamma[:2])


def test_punch_with_nodes_and_gamma_from_the_user(tmp_path, plate):
    nodes, shapes, freq, gamma = _truth(plate)
    path = tmp_path / "plate.pch"
    write_punch(path, freq, _ids(plate), shapes)
    csv = tmp_path / "nodes.csv"
    np.savetxt(csv, np.column_stack([_ids(plate), nodes]), delimiter=",", fmt="%.17g")
    result = from_modes(path, units="SI", nodes=csv, gamma=gamma)
    _same_model(result, plate, FLOAT64)
    assert "not stated by the file" in result.provenance["derived"]["mass_normalisation"]
    with pytest.raises(InputError, match="punch file\\) holds no coordinates"):
        from_modes(path, units="SI", gamma=gamma).to_modal_model()


def test_free_parts_follow_one_rule(tmp_path):
    part = fem.rectangular_plate(0.6, 0.4, 1e-3, mesh_size=0.05)
    free = fem.modal_analysis(part, [], 4, allow_rigid_modes=True, progress=False)
    freq = np.concatenate([free.rigid_freq_hz, free.freq_hz])
    shapes = np.zeros((len(free.system.nodes), 3, freq.size))
    shapes[:, :, 3:] = free.node_shapes()
    path = tmp_path / "free.op2"
    ids = np.arange(1, len(free.system.nodes) + 1)
    write_op2(path, freq, ids, free.system.nodes, shapes, word=8)
    with pytest.raises(InputError, match=r"3 rigid-body mode\(s\) .*allow_rigid_modes=True"):
        from_modes(path, units="SI")
    result = from_modes(path, units="SI", allow_rigid_modes=True)
    assert result.provenance["rigid_modes"]["count"] == 3
    np.testing.assert_allclose(result.freq_hz, free.freq_hz, rtol=FLOAT64)


def test_the_command_reads_an_op2_and_says_what_it_found(tmp_path, plate):
    nodes, shapes, freq, gamma = _truth(plate)
    path = tmp_path / "plate.op2"
    write_op2(path, freq, _ids(plate), nodes, shapes, gamma=gamma, word=8)
    out = run_jaxflex(
        "model", "--from-modes", str(path), "--units", "SI", "-o", str(tmp_path / "m.npz")
    )
    assert out.returncode == 0, out.stderr
    assert "mass normalisation: generalized masses stated by the file: 1" in out.stdout
    assert "static response: none" in out.stdout
    model = jaxflex.load_model(tmp_path / "m.npz")
    np.testing.assert_allclose(model.freq_hz, freq, rtol=FLOAT64)
    refused = run_jaxflex("model", "--from-modes", str(path), "-o", str(tmp_path / "m.npz"))
    assert refused.returncode == 2 and "--units" in refused.stderr


def test_more_modes_asked_than_the_file_holds_are_named(tmp_path, plate):
    """Issue 34: --n-modes 100000 on a file of 6 modes keeps the 6 and says so (it gave 6
    without a word)."""
    nodes, shapes, freq, gamma = _truth(plate)
    path = tmp_path / "plate.op2"
    write_op2(path, freq, _ids(plate), nodes, shapes, gamma=gamma, word=8)
    with pytest.warns(JaxflexWarning, match=f"100,000 modes asked, .* holds {freq.size} elastic"):
        result = from_modes(path, units="SI", n_modes=100_000)
    assert result.freq_hz.size == freq.size
    with warnings.catch_warnings():
        warnings.simplefilter("error", JaxflexWarning)  # as many as it holds: no remark
        assert from_modes(path, units="SI", n_modes=freq.size).freq_hz.size == freq.size
    out = run_jaxflex(
        "model", "--from-modes", str(path), "--units", "SI", "--n-modes", "100000",
        "-o", str(tmp_path / "m.npz"),
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert f"warning: --n-modes (n_modes): 100,000 modes asked, '{path}' holds" in out.stderr
    assert f"all {freq.size} kept" in out.stderr
    assert jaxflex.load_model(tmp_path / "m.npz").n_modes == freq.size


MODELS = os.environ.get("JAXFLEX_PYNASTRAN_MODELS")


@pytest.mark.skipif(not MODELS, reason="JAXFLEX_PYNASTRAN_MODELS: pyNastran's models/ dir")
def test_real_op2_files_of_pynastrans_model_library():
    models = Path(MODELS)
    satk = from_modes(models / "satk/pn_mwe_s-solution_1.op2", units="MPA")
    np.testing.assert_allclose(satk.freq_hz, [89.5607, 89.5607, 1044.7596], rtol=1e-6)
    # MPFACS squared is the MEFMASS the same file holds (4.973124 t; generalized masses 1)
    assert satk.gamma[0, 2] ** 2 == pytest.approx(4.973124e3, rel=1e-5)  # t -> kg
    beam = from_modes(models / "beam_modes/beam_modes_m1.op2", units="BIN")
    f06 = [456.6603, 456.6603, 2674.588, 2674.588, 3554.923, 4507.487]  # beam_modes.f06
    np.testing.assert_allclose(beam.freq_hz[:6], f06, rtol=2e-6)
    for name, match in [
        ("elements/modes_complex_elements.op2", "CLAMA \\(complex eigenvalues\\)"),
        ("freq_sine/good_sine.op2", "no real normal modes .* frequency response"),
    ]:
        with pytest.raises(InputError, match=match):
            from_modes(models / name, units="SI")


UFF55 = 2e-5  # pyuff writes dataset 55 as E13.5: 6 significant digits, 5e-6 of each value


def _write_uff(path, sets) -> None:
    import pyuff

    uff = pyuff.UFF(str(path))
    uff.write_sets(sets, mode="overwrite")


def _uff_nodes(plate, length: float = 1.0) -> list[dict]:
    import pyuff

    nodes = plate.system.nodes / length
    units = pyuff.prepare_164(
        units_code=1 if length == 1 else 5,
        units_description="SI" if length == 1 else "mm (milli-newton)",
        temp_mode=2,
        length=1 / length,
        force=1 / length,
        temp=1.0,
        temp_offset=273.15,
    )
    grid = pyuff.prepare_15(
        node_nums=_ids(plate),
        def_cs=np.ones(len(nodes), dtype=int),
        disp_cs=np.ones(len(nodes), dtype=int),
        color=np.ones(len(nodes), dtype=int),
        x=nodes[:, 0],
        y=nodes[:, 1],
        z=nodes[:, 2],
    )
    return [units, grid]


def test_universal_file_modes_written_by_pyuff(tmp_path, plate):
    # millimetres and milli-newtons (dataset 164: length and force factors 1000, so the mass
    # unit is the kg): coordinates and shapes in mm, modal masses 1 (mass-normalised)
    import pyuff

    _, shapes, freq, gamma = _truth(plate)
    sets = _uff_nodes(plate, length=1e-3)
    for j, f in enumerate(freq):
        sets.append(
            pyuff.prepare_55(
                model_type=1, analysis_type=2, data_ch=2, spec_data_type=8, data_type=2,
                n_data_per_node=3, load_case=1, mode_n=j + 1, freq=f, modal_m=1.0,
                modal_damp_vis=0.0, modal_damp_his=0.0, node_nums=_ids(plate),
                r1=shapes[:, 0, j] * 1e3, r2=shapes[:, 1, j] * 1e3, r3=shapes[:, 2, j] * 1e3,
            )
        )  # fmt: skip
    path = tmp_path / "plate.uff"
    _write_uff(path, sets)
    with pytest.raises(InputError, match=r"datasets 55\) holds no participation factors"):
        from_modes(path).to_modal_model()
    result = from_modes(path, gamma=gamma)
    assert result.provenance["file_units"]["name"].startswith("UFF 164")
    _same_model(result, plate, UFF55)
    with pytest.raises(InputError, match=r"units: .* says otherwise"):
        from_modes(path, gamma=gamma, units="SI")


def test_universal_file_time_responses_are_identified(tmp_path, plate):
    # dataset 58: the response of 40 nodes along z to the unit hat along z, from t = dt on
    # (pyuff writes them in double precision), identified as the preprint's R1 (fem.imports.r1)
    import pyuff

    from fem.imports.r1 import hat_responses
    from jaxflex._convolution import unit_response

    dt, steps = 0.005, 600
    model = plate.to_modal_model()
    rows = np.arange(0, model.n_points, max(1, model.n_points // 40))
    r1 = unit_response(model, dt, steps)[2][:, rows]
    sets = _uff_nodes(plate)[:1]
    sets.append(_uff_nodes(plate)[1])
    for k, row in enumerate(rows):
        dataset = pyuff.prepare_58(
            func_type=1, rsp_node=int(_ids(plate)[row]), rsp_dir=3, ref_node=0, ref_dir=3,
            ord_data_type=4, num_pts=steps, abscissa_spacing=1, abscissa_min=dt,
            abscissa_inc=dt, data=r1[1:, k, 2], x=dt * np.arange(1, steps + 1),
            abscissa_spec_data_type=17, ordinate_spec_data_type=8, return_full_dict=True,
        )  # fmt: skip
        for key, value in dataset.items():  # the header fields pyuff leaves to the user
            if value is None:
                dataset[key] = (
                    "NONE" if key.startswith("id") or key.endswith(("lab", "name")) else 0
                )
        sets.append(dataset)
    path = tmp_path / "r1.uff"
    _write_uff(path, sets)
    result = from_modes(path)
    assert "first sample at t = dt" in result.layouts[0]
    g = hat_responses(model.freq_hz, model.zeta, dt, steps)
    peak = np.abs(r1).max()
    share = np.abs(model.shapes[rows, 2] * model.gamma[:, 2]).max(axis=0) * np.abs(g).max(0)
    visible = share / peak >= 1e-6
    np.testing.assert_allclose(result.freq_hz, model.freq_hz[visible], rtol=1e-6)
    assert result.to_modal_model().n_points == rows.size


def test_a_third_party_universal_file_with_one_mode():
    # pyuff's example file (tests/data/README.md): 6 values per node, no coordinates, modal
    # mass 0 (normalisation not stated); read as it is, with what is missing named
    path = Path(__file__).parent / "data" / "uff55_translation_rotation.uff"
    result = from_modes(path, units="SI", gamma=[[0.0, 0.0, 1.0]])
    assert result.freq_hz.tolist() == [97.013]
    assert result.shapes.shape == (43, 3, 1)
    first = [[0.053569, 0.020271, 0.0046623], [0.052429, 0.018285, 0.0046623]]
    np.testing.assert_allclose(result.shapes[:2, :, 0], first)  # as the file writes them
    assert "not stated by the file" in result.provenance["derived"]["mass_normalisation"]
    with pytest.raises(InputError, match=r"no coordinates \(dataset 15 or 2411\) for 43"):
        result.to_modal_model()
