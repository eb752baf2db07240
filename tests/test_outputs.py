"""Linear outputs in the model (cups, stresses): the file, posing, certified peaks, loads."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_model, smooth_move
from hypothesis import given, settings
from hypothesis import strategies as st

import jaxflex
from jaxflex._cell import rotation_from_degrees
from jaxflex._deviation import outputs_at
from jaxflex._loads import CupUtilisation, VonMises
from jaxflex._outputs import CupSet, LinearOutputs, StressSet, voigt_rotation
from jaxflex._peaks import output_peak, outputs_above
from jaxflex._profile import as_move

DT = 0.01


def with_outputs(model: jaxflex.ModalModel, seed: int = 1) -> jaxflex.ModalModel:
    """``model`` with two random cups and five random stress points."""
    rng = np.random.default_rng(seed)
    m = model.n_modes
    normal = rng.normal(size=(2, 3))
    cups = CupSet(
        rng.uniform(size=(2, 3)),
        normal / np.linalg.norm(normal, axis=1, keepdims=True),
        [0.03, 0.04],
        [170.0, 300.0],
        [0.5, 0.3],
        LinearOutputs(
            rng.normal(size=(12, m)) * 50, rng.normal(size=(12, m)), rng.normal(size=(12, 3))
        ),
    )
    stress = StressSet(
        rng.uniform(size=(5, 3)),
        LinearOutputs(
            rng.normal(size=(30, m)) * 1e7, np.zeros((30, m)), rng.normal(size=(30, 3)) * 1e5
        ),
    )
    return model.with_outputs(cups=cups, stress=stress)


@pytest.fixture(scope="module")
def model():
    return with_outputs(random_model(n_points=12, n_modes=5, f_min_hz=3.0, f_max_hz=40.0))


def test_model_file_keeps_the_outputs(tmp_path, model):
    path = tmp_path / "part.npz"
    model.save(path)
    back = jaxflex.load_model(path)
    for name in ("q_map", "v_map", "static_map", "a_map"):
        np.testing.assert_array_equal(
            getattr(back.cups.reaction, name), getattr(model.cups.reaction, name)
        )
        np.testing.assert_array_equal(
            getattr(back.stress.stress, name), getattr(model.stress.stress, name)
        )
    np.testing.assert_array_equal(back.cups.holding_force_n, model.cups.holding_force_n)
    with np.load(path) as data:
        assert int(data["schema_version"]) == 3


def test_version_2_files_are_read_with_their_static_response_derived(tmp_path, model):
    """Schema 2 stored the modal A = S + Q Omega^-2 Gamma instead of S: the reader derives S
    (to round-off: one matrix product) and says where the static response came from."""
    path = tmp_path / "old.npz"
    model.save(path)
    with np.load(path) as data:
        contents = {k: data[k] for k in data.files}
    contents["schema_version"] = np.asarray(2)
    for new, old, outputs in (
        ("cup_reaction_s", "cup_reaction_a", model.cups.reaction),
        ("stress_s", "stress_a", model.stress.stress),
    ):
        contents[old] = np.asarray(outputs.a_map).reshape(contents.pop(new).shape)
    np.savez(path, **contents)
    back = jaxflex.load_model(path)
    for new, old in (
        (back.cups.reaction, model.cups.reaction),
        (back.stress.stress, model.stress.stress),
    ):
        scale = np.abs(old.a_map).max()
        np.testing.assert_allclose(new.static_map, old.static_map, atol=1e-12 * scale)
        np.testing.assert_allclose(new.a_map, old.a_map, atol=1e-12 * scale)
    assert "schema 2" in back.meta["static_response"]


def test_version_1_files_are_read(tmp_path):
    plain = random_model(n_points=5, n_modes=3)
    path = tmp_path / "old.npz"
    plain.save(path)
    with np.load(path) as data:
        contents = {k: data[k] for k in data.files}
    contents["schema_version"] = np.asarray(1)
    np.savez(path, **contents)
    back = jaxflex.load_model(path)
    assert back.cups is None and back.stress is None
    np.testing.assert_array_equal(back.shapes, plain.shapes)


def test_an_incomplete_group_is_refused(tmp_path, model):
    path = tmp_path / "part.npz"
    model.save(path)
    with np.load(path) as data:
        contents = {k: data[k] for k in data.files if k != "cup_friction"}
    np.savez(path, **contents)
    with pytest.raises(jaxflex.ModelFileError, match="cup_friction"):
        jaxflex.load_model(path)


def test_outputs_are_validated(model):
    with pytest.raises(jaxflex.ModelError, match=r"cups\.reaction\.q_map"):
        model.truncate_modes(3).with_outputs(cups=model.cups)
    bad = CupSet
    with pytest.raises(jaxflex.ModelError, match=r"cups\.normal"):
        bad([[0, 0, 0]], [[0, 0, 2.0]], [0.03], [100.0], [0.5], model.cups.reaction)


def test_truncation_keeps_the_outputs_consistent(model):
    """Dropped modes respond quasi-statically: the static response stays, and the outputs at
    rest under a constant acceleration (the kept modes at q = -Omega^-2 Gamma a) equal it."""
    kept = model.truncate_modes(3)
    assert np.shape(kept.cups.reaction.q_map) == (12, 3)
    assert np.shape(kept.stress.stress.q_map) == (30, 3)
    a = np.array([0.3, -2.0, 9.81])
    omega = 2 * np.pi * np.asarray(kept.freq_hz)
    q_rest = -(np.asarray(kept.gamma) @ a) / omega**2
    for outputs, full in (
        (kept.cups.reaction, model.cups.reaction),
        (kept.stress.stress, model.stress.stress),
    ):
        np.testing.assert_array_equal(outputs.static_map, full.static_map)
        at_rest = outputs.values(np.stack([q_rest, 0 * q_rest], -1)[None], a[None])[0]
        np.testing.assert_allclose(at_rest, np.asarray(full.static_map) @ a, rtol=1e-10, atol=1e-9)


def test_posed_model_gives_the_rotated_response(model):
    """A move in the cell frame drives the posed model exactly as the move rotated back
    drives the original: deviations equal, reactions rotate as vectors, stresses as
    tensors."""
    rotation = rotation_from_degrees([20, -35, 110])
    posed = model.posed(rotation, [1.0, 2.0, 3.0])
    acc_cell = smooth_move(40, DT)
    acc_part = acc_cell @ rotation  # rows: R^T a
    t = np.linspace(0, 0.6, 31)
    a = jaxflex.simulate(model, acc_part, DT)
    b = jaxflex.simulate(posed, acc_cell, DT)
    np.testing.assert_allclose(b.deviation, a.deviation, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(
        np.asarray(posed.points), np.asarray(model.points) @ rotation.T + [1, 2, 3]
    )
    ya = outputs_at(model, model.cups.reaction, as_move(acc_part, DT), t).reshape(len(t), -1, 3)
    yb = outputs_at(posed, posed.cups.reaction, as_move(acc_cell, DT), t).reshape(len(t), -1, 3)
    np.testing.assert_allclose(yb, ya @ rotation.T, atol=1e-9 * np.abs(ya).max())
    sa = outputs_at(model, model.stress.stress, as_move(acc_part, DT), t).reshape(len(t), -1, 6)
    sb = outputs_at(posed, posed.stress.stress, as_move(acc_cell, DT), t).reshape(len(t), -1, 6)
    np.testing.assert_allclose(sb, sa @ voigt_rotation(rotation).T, atol=1e-9 * np.abs(sa).max())
    vm = VonMises(5)
    np.testing.assert_allclose(vm.values(sb, np.arange(5)), vm.values(sa, np.arange(5)), rtol=1e-9)


def _dense_max(model, outputs, functional, acc, offset, until_s):
    t = np.arange(0.0, until_s, 2e-5)
    y = outputs_at(model, outputs, as_move(acc, DT), t, offset).reshape(
        len(t), functional.n_items, -1
    )
    values = functional.values(y, np.arange(functional.n_items))
    return values.max(), t[np.unravel_index(np.argmax(values), values.shape)[0]]


def _load(model, kind: str):
    """(outputs, functional, offset under gravity) of the model's cups or stress points."""
    if kind == "cups":
        outputs, functional = model.cups.reaction, CupUtilisation(model.cups)
    else:
        outputs, functional = model.stress.stress, VonMises(model.stress.n_points)
    return outputs, functional, outputs.offset([0.0, 0.0, -9.81])


@pytest.mark.parametrize("kind", ["cups", "stress"])
def test_certified_peak_against_a_dense_grid(model, kind):
    """The certified peak is attained and bounds the supremum: a 20 us grid over the move
    and 4 s of settling (every mode decays below 1e-3 of its start by then) finds nothing
    above the bound and nothing more than the interpolation error (h^2/8 sup|y''| ~ 1e-6
    of the peak) below the value."""
    acc = smooth_move(40, DT)
    outputs, functional, offset = _load(model, kind)
    peak = output_peak(model, outputs, functional, as_move(acc, DT), offset=offset, rtol=1e-6)
    dense, when = _dense_max(model, outputs, functional, acc, offset, 4.4)
    assert peak.value <= peak.bound
    assert dense <= peak.bound
    assert peak.value >= dense * (1 - 1e-5)
    assert abs(peak.time_s - when) < 2e-3


@pytest.mark.parametrize("kind", ["cups", "stress"])
@pytest.mark.parametrize("fraction", [0.3, 0.7, 0.95])
def test_outputs_above_against_every_item_at_every_time(model, kind, fraction):
    """outputs_above (the cell's load scans) against evaluating every item at every time of
    a grid of dt / 8 during the move and 3 s after it: the same (time, item) samples lie
    above the threshold, with the same values (1e-9 of the peak: two evaluations of the
    same linear outputs in float64), and an item it leaves out never comes above it."""
    acc = smooth_move(40, DT)
    outputs, functional, offset = _load(model, kind)
    t = np.r_[np.arange(0, 40 * 8 + 1) * DT / 8, 40 * DT + np.arange(1, 301) * 0.01]
    y = outputs_at(model, outputs, as_move(acc, DT), t, offset).reshape(
        len(t), functional.n_items, -1
    )
    dense = functional.values(y, np.arange(functional.n_items))  # (T, I)
    above = fraction * dense.max()
    move = as_move(acc, DT, at_rest=True)
    items, values = outputs_above(model, outputs, functional, move, t, above, offset=offset)
    tol = 1e-9 * dense.max()
    left_out = np.setdiff1d(np.arange(functional.n_items), items)
    assert (dense[:, left_out] <= above + tol).all()
    near = np.abs(dense[:, items] - above) <= tol  # on the threshold: either side is right
    assert np.array_equal((values > above) | near, (dense[:, items] > above) | near)
    hits = values > above
    assert hits.any()
    np.testing.assert_allclose(values[hits], dense[:, items][hits], rtol=0, atol=tol)


def test_peak_of_a_static_load_is_its_limit(model):
    """A move of zeros: the outputs are the offset (gravity) forever, the peak its value."""
    acc = np.zeros((11, 3))
    outputs = model.cups.reaction
    functional = CupUtilisation(model.cups)
    offset = outputs.offset([0.0, 0.0, -9.81])
    peak = output_peak(model, outputs, functional, as_move(acc, DT), offset=offset)
    expected = functional.values(offset.reshape(1, 2, 6), np.arange(2)).max()
    assert peak.value == pytest.approx(expected, rel=1e-12)


vectors = st.lists(st.floats(-1e3, 1e3), min_size=6, max_size=6).map(np.array)


@settings(max_examples=60, deadline=None)
@given(y=vectors, e=vectors, other=vectors)
def test_cup_utilisation_cuts_and_weights(model, y, e, other):
    """u is convex and positively homogeneous: the cut at y supports it everywhere
    (u(y') >= g . y', equality at y), and the weights bound its change."""
    f = CupUtilisation(model.cups, safety=1.7)
    for item in (0, 1):
        g = f.cut(y, item)
        value = f.values(y[None, None], np.array([item]))[0, 0]
        assert g @ y == pytest.approx(value, rel=1e-9, abs=1e-12)
        assert f.values(other[None, None], np.array([item]))[0, 0] >= g @ other - 1e-9 * (
            1 + abs(g @ other)
        )
        change = abs(f.values((y + e)[None, None], np.array([item]))[0, 0] - value)
        assert change <= f.weights(np.array([item]))[0] @ np.abs(e) * (1 + 1e-9) + 1e-12


@settings(max_examples=60, deadline=None)
@given(y=vectors, e=vectors, other=vectors)
def test_von_mises_cuts_and_weights(y, e, other):
    f = VonMises(1)
    idx = np.array([0])
    value = f.values(y[None], idx)[0]
    g = f.cut(y, 0)
    assert g @ y == pytest.approx(value, rel=1e-9, abs=1e-9)
    assert f.values(other[None], idx)[0] >= g @ other - 1e-9 * (1 + abs(g @ other))
    assert abs(f.values((y + e)[None], idx)[0] - value) <= f.weights(idx)[0] @ np.abs(e) + 1e-9


def test_von_mises_closed_forms():
    f = VonMises(1)
    idx = np.array([0])
    assert f.values(np.array([[100.0, 0, 0, 0, 0, 0]]), idx)[0] == pytest.approx(100.0)
    assert f.values(np.array([[0, 0, 0, 0, 0, 50.0]]), idx)[0] == pytest.approx(50 * np.sqrt(3))
    assert f.values(np.array([[7.0, 7.0, 7.0, 0, 0, 0]]), idx)[0] == pytest.approx(0, abs=1e-12)


def test_cup_utilisation_load_cases():
    """The makers' load cases (Schmalz): a pull N alone gives S N / F_hold; a shear T alone
    S T / (mu F_hold); a peel moment M acts like a pull 4 M / r."""
    normal = np.array([[0.0, 0.0, 1.0]])
    cups = CupSet(
        [[0, 0, 0]],
        normal,
        [0.04],
        [300.0],
        [0.5],
        LinearOutputs(np.zeros((6, 1)), np.zeros((6, 1)), np.zeros((6, 3))),
    )
    f = CupUtilisation(cups, safety=1.5)
    idx = np.array([0])

    def u(*row):
        return f.values(np.array(row, dtype=float)[None, None], idx)[0, 0]

    assert u(0, 0, 100, 0, 0, 0) == pytest.approx(1.5 * 100 / 300)
    assert u(0, 0, -100, 0, 0, 0) == 0.0  # pressed on: not credited, not loaded
    assert u(30, 40, 0, 0, 0, 0) == pytest.approx(1.5 * 50 / 0.5 / 300)
    assert u(0, 0, 0, 2.0, 0, 0) == pytest.approx(1.5 * 4 * 2.0 / 0.04 / 300)
    assert u(0, 0, 0, 0, 0, 1.0) == pytest.approx(1.5 * 1.5 / (0.5 * 0.04) / 300)
