"""ModalModel validation, helpers and the versioned model file."""

from __future__ import annotations

import json
import os
import zipfile

import jax
import numpy as np
import pytest
from conftest import random_model

import jaxflex
from jaxflex import _model_file as model_file
from jaxflex._deviation import blocks_of, component_blocks


def fields(model):
    return {
        "freq_hz": np.array(model.freq_hz),
        "zeta": np.array(model.zeta),
        "gamma": np.array(model.gamma),
        "shapes": np.array(model.shapes),
        "points": np.array(model.points),
    }


@pytest.mark.parametrize(
    ("change", "field"),
    [
        (lambda f: f.update(freq_hz=f["freq_hz"] * -1), "freq_hz"),
        (lambda f: f.update(freq_hz=np.r_[0.0, f["freq_hz"][1:]]), "freq_hz"),
        (lambda f: f["freq_hz"].__setitem__(2, np.nan), "freq_hz"),
        (lambda f: f.update(zeta=f["zeta"] + 1.0), "zeta"),
        (lambda f: f.update(zeta=-f["zeta"]), "zeta"),
        (lambda f: f.update(zeta=f["zeta"][:-1]), "zeta"),
        (lambda f: f.update(gamma=f["gamma"][:, :2]), "gamma"),
        (lambda f: f["gamma"].__setitem__((0, 0), np.inf), "gamma"),
        (lambda f: f.update(shapes=f["shapes"][:, :, :-1]), "shapes"),
        (lambda f: f.update(shapes=f["shapes"][:-1]), "shapes"),
        (lambda f: f.update(points=f["points"][:, :2]), "points"),
        (lambda f: f.update(shapes="abc"), "shapes"),
    ],
)
def test_invalid_fields_are_named(small_model, change, field):
    f = fields(small_model)
    change(f)
    with pytest.raises(jaxflex.ModelError, match=f"ModalModel.{field}"):
        jaxflex.ModalModel(**f)


def test_labels_and_meta_checked(small_model):
    with pytest.raises(jaxflex.ModelError, match="labels"):
        jaxflex.ModalModel(**fields(small_model), labels=("a", "b"))
    with pytest.raises(jaxflex.ModelError, match="meta"):
        jaxflex.ModalModel(**fields(small_model), meta={"x": object()})


def test_arrays_are_read_only(small_model):
    with pytest.raises(ValueError, match="read-only"):
        small_model.freq_hz[0] = 1.0


def test_save_load_round_trip(tmp_path, small_model):
    labels = tuple(f"p{i}" for i in range(small_model.n_points))
    model = jaxflex.ModalModel(
        **fields(small_model), labels=labels, meta={"material": {"E_pa": 2.1e11}}
    )
    path = tmp_path / "part.npz"
    model.save(path)
    back = jaxflex.load_model(path)
    for name in ("freq_hz", "zeta", "gamma", "shapes", "points"):
        np.testing.assert_array_equal(getattr(back, name), getattr(model, name))
    assert back.labels == labels
    assert back.meta == {"material": {"E_pa": 2.1e11}}
    assert [p.name for p in tmp_path.iterdir()] == ["part.npz"]  # no temporary left behind


def test_failed_write_keeps_the_old_file(tmp_path, small_model, monkeypatch):
    path = tmp_path / "part.npz"
    small_model.save(path)
    before = path.read_bytes()

    def broken_savez(handle, **arrays):
        handle.write(b"partial")
        raise OSError("disk full")

    monkeypatch.setattr(model_file.np, "savez", broken_savez)
    with pytest.raises(OSError, match="disk full"):
        small_model.with_damping(0.05).save(path)
    assert path.read_bytes() == before
    assert os.listdir(tmp_path) == ["part.npz"]


def test_truncated_file(tmp_path, small_model):
    path = tmp_path / "part.npz"
    small_model.save(path)
    path.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2])
    with pytest.raises(jaxflex.ModelFileError, match="truncated or corrupt"):
        jaxflex.load_model(path)


def test_missing_file(tmp_path):
    with pytest.raises(jaxflex.ModelFileError, match="does not exist"):
        jaxflex.load_model(tmp_path / "nope.npz")


def rewrite(path, **changes):
    with np.load(path) as data:
        contents = {k: data[k] for k in data.files}
    contents.update(changes)
    for key in [k for k, v in changes.items() if v is None]:
        del contents[key]
    np.savez(path, **contents)


def test_unknown_schema_version(tmp_path, small_model):
    path = tmp_path / "part.npz"
    small_model.save(path)
    rewrite(path, schema_version=np.asarray(99))
    with pytest.raises(jaxflex.ModelFileError, match="schema version 99"):
        jaxflex.load_model(path)


@pytest.mark.parametrize("field", ["shapes", "freq_hz", "meta_json", "schema_version"])
def test_missing_field(tmp_path, small_model, field):
    path = tmp_path / "part.npz"
    small_model.save(path)
    rewrite(path, **{field: None})
    with pytest.raises(jaxflex.ModelFileError, match=field):
        jaxflex.load_model(path)


def test_other_npz_and_garbage(tmp_path):
    other = tmp_path / "other.npz"
    np.savez(other, x=np.zeros(3))
    with pytest.raises(jaxflex.ModelFileError, match="not a jaxflex modal model"):
        jaxflex.load_model(other)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"\x00" * 100)
    with pytest.raises(jaxflex.ModelFileError):
        jaxflex.load_model(garbage)


def test_invalid_data_in_file_is_reported_with_path(tmp_path, small_model):
    path = tmp_path / "part.npz"
    small_model.save(path)
    rewrite(path, zeta=np.full(small_model.n_modes, 1.5))
    with pytest.raises(jaxflex.ModelError, match=r"part\.npz.*zeta"):
        jaxflex.load_model(path)


def test_truncate_and_select(small_model):
    m3 = small_model.truncate_modes(3)
    assert m3.n_modes == 3
    np.testing.assert_array_equal(m3.freq_hz, small_model.freq_hz[:3])
    low = small_model.truncate_modes(max_freq_hz=small_model.freq_hz[1])
    assert low.n_modes == 2
    with pytest.raises(jaxflex.ModelError, match="max_freq_hz"):
        small_model.truncate_modes(max_freq_hz=0.1)
    sub = small_model.select_points([4, 1])
    np.testing.assert_array_equal(sub.shapes, small_model.shapes[[4, 1]])
    np.testing.assert_array_equal(sub.points, small_model.points[[4, 1]])
    with pytest.raises(jaxflex.ModelError, match="indices"):
        small_model.select_points([small_model.n_points])
    # truncation keeps the response of the kept modes exactly
    acc = np.zeros((11, 3))
    acc[3] = [1.0, -2.0, 0.5]
    q_all = np.asarray(jaxflex.simulate(small_model, acc, 0.01).q)
    np.testing.assert_allclose(
        np.asarray(jaxflex.simulate(m3, acc, 0.01).q), q_all[:, :3], rtol=1e-14
    )


def test_scaled_and_damped(small_model):
    np.testing.assert_allclose(
        small_model.with_frequency_scale(1.1).freq_hz, 1.1 * small_model.freq_hz
    )
    assert np.all(small_model.with_damping(0.07).zeta == 0.07)
    with pytest.raises(jaxflex.ModelError):
        small_model.with_damping(1.0)
    with pytest.raises(jaxflex.ModelError):
        small_model.with_frequency_scale(0.0)


def test_pytree_round_trip_keeps_meta(small_model):
    leaves, tree = jax.tree_util.tree_flatten(small_model)
    back = jax.tree_util.tree_unflatten(tree, leaves)
    assert back.meta == small_model.meta
    assert json.dumps(back.meta)
    assert "K=30 points" in repr(small_model)


def test_zip_is_plain_npz(tmp_path, small_model):
    """The file is a plain numpy archive without pickled objects (readable anywhere)."""
    path = tmp_path / "part.npz"
    small_model.save(path)
    with zipfile.ZipFile(path) as z:
        assert "format.npy" in z.namelist()
    with np.load(path, allow_pickle=False) as data:
        assert str(data["format"]) == "jaxflex.modal_model"


def test_derived_models_share_validated_arrays_and_point_blocks():
    """A robust grid derives many models that differ only in frequencies and damping: their
    shapes and points are the nominal model's arrays (validated once, not copied) and the
    point blocks built from them are built once."""
    nominal = random_model(3, n_points=40, n_modes=5)
    derived = nominal.with_frequency_scale(1.1).with_damping(0.03)
    assert derived.shapes is nominal.shapes and derived.points is nominal.points
    assert not derived.shapes.flags.writeable
    assert blocks_of(derived) is blocks_of(nominal)
    assert component_blocks(derived, (2,))[1] is component_blocks(nominal, (2,))[1]
    other = jaxflex.ModalModel(
        nominal.freq_hz, nominal.zeta, nominal.gamma, np.array(nominal.shapes), nominal.points
    )  # equal values in another array: its own blocks
    assert blocks_of(other) is not blocks_of(nominal)
