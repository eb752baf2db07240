"""What every reader checks before it calls a file's contents modes, and the checks of every
imported model (issue 33): eigenvalues where the solver writes them, displacement systems
turned to the basic one, UFF 2414 with its systems, non-modal files refused by name, rigid
modes recognised by what they are, impossible models refused with the figure.

The files are written here from a known model (our plate on four cups, tests/solver_files.py
and pyuff's writer) so that the answer is known independently of the readers: the same
model written in the basic system, or the FE solve itself.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from solver_files import uff55_mode, uff_2414_modes, write_op2, write_punch

from fem.imports.ansys import RstModes, from_rst_modes
from fem.imports.from_modes import from_modes
from fem.imports.imported import ImportedModes
from fem.rigid_modes import rigid_fit_residual, rigid_modes
from fem.sanity import ModelWarning
from jaxflex.errors import InputError

FLOAT64 = 1e-9  # 8-byte words: round-off of the frames' sines and cosines only
UFF_DIGITS = 2e-5  # pyuff writes dataset 2414 values as E13.5: 6 significant digits


@pytest.fixture(scope="module")
def plate(four_cup_plate):
    return four_cup_plate


def _truth(plate):
    ids = np.arange(1, len(plate.system.nodes) + 1) * 10
    return ids, plate.system.nodes, plate.node_shapes(), plate.freq_hz, plate.gamma


def test_op2_without_lama_takes_the_eigenvalues_of_its_eigenvector_headers(tmp_path, plate):
    ids, nodes, shapes, freq, gamma = _truth(plate)
    path = tmp_path / "post1.op2"
    write_op2(path, freq, ids, nodes, shapes, gamma=gamma, lama=False)
    result = from_modes(path, units="SI")
    np.testing.assert_allclose(result.freq_hz, freq, rtol=FLOAT64)
    np.testing.assert_allclose(result.shapes, shapes, atol=FLOAT64 * np.abs(shapes).max())
    assert "no LAMA table" in " ".join(result.provenance["notes"])
    assert "not stated by the file" in result.provenance["derived"]["mass_normalisation"]


def _frames(kind: str, a, b, c, points) -> np.ndarray:
    """(N, 3, 3) rows: the directions of components 1, 2, 3 of a CORD2R/CORD2C through A, B,
    C at ``points`` (the Quick Reference Guide's definition, written out here)."""
    z = (b - a) / np.linalg.norm(b - a)
    y = np.cross(z, c - a)
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    if kind == "R":
        return np.broadcast_to(np.stack([x, y, z]), (len(points), 3, 3))
    q = points - a
    phi = np.arctan2(q @ y, q @ x)
    radial = np.cos(phi)[:, None] * x + np.sin(phi)[:, None] * y
    tangential = -np.sin(phi)[:, None] * x + np.cos(phi)[:, None] * y
    return np.stack([radial, tangential, np.broadcast_to(z, radial.shape)], axis=1)


def test_op2_grids_in_displacement_systems_are_the_model_in_the_basic_system(tmp_path, plate):
    ids, nodes, shapes, freq, gamma = _truth(plate)
    rng = np.random.default_rng(3)
    systems = [
        (5, "R", np.array([0.1, 0.2, 0.0]), np.array([0.4, 0.5, 0.7]), np.array([0.9, 0.1, 0.3])),
        (7, "C", np.array([0.3, 0.2, -0.1]), np.array([0.3, 0.2, 0.9]), np.array([1.3, 0.4, 0.0])),
    ]
    cd = rng.choice([0, 5, 7], size=len(ids))
    local = shapes.copy()
    for cid, kind, a, b, c in systems:
        rows = cd == cid
        frames = _frames(kind, a, b, c, nodes[rows])
        local[rows] = np.einsum("nib,nbm->nim", frames, shapes[rows])
    path = tmp_path / "cd.op2"
    write_op2(path, freq, ids, nodes, local, gamma=gamma, cd=cd, systems=systems)
    basic = tmp_path / "basic.op2"
    write_op2(basic, freq, ids, nodes, shapes, gamma=gamma, table="BOUGV1")
    turned, reference = from_modes(path, units="SI"), from_modes(basic, units="SI")
    assert np.abs(local - shapes).max() > 0.1 * np.abs(shapes).max()  # the systems matter
    np.testing.assert_allclose(turned.shapes, reference.shapes, atol=FLOAT64 * np.abs(shapes).max())
    np.testing.assert_allclose(turned.freq_hz, reference.freq_hz, rtol=FLOAT64)
    write_op2(
        tmp_path / "lost.op2", freq, ids, nodes, local, gamma=gamma, cd=cd, systems=systems[:1]
    )
    with pytest.raises(InputError, match=r"displacement systems CD \[7\] that cannot be resolved"):
        from_modes(tmp_path / "lost.op2", units="SI")


def test_op2_with_a_large_negative_eigenvalue_is_refused(tmp_path, plate):
    ids, nodes, shapes, freq, gamma = _truth(plate)
    path = tmp_path / "neg.op2"
    write_op2(path, freq, ids, nodes, shapes, gamma=gamma, lama=False)
    data = bytearray(path.read_bytes())
    head = np.float64((2 * np.pi * freq[0]) ** 2).tobytes()
    data[data.index(head) : data.index(head) + 8] = np.float64(-1e4).tobytes()
    path.write_bytes(bytes(data))
    with pytest.raises(InputError, match=r"mode 1 has the eigenvalue -10000 .*not positive"):
        from_modes(path, units="SI")


def _uff(path, plate, analysis_type=2, rotate=True):
    """The plate's modes as datasets 2411 (nodes in a rotated Cartesian system 2 of dataset
    2420, their displacements too; pyuff's writer) and 2414 (tests/solver_files.py)."""
    import pyuff

    ids, nodes, shapes, freq, _ = _truth(plate)
    angle = 0.7
    axes = np.array(
        [[np.cos(angle), np.sin(angle), 0], [-np.sin(angle), np.cos(angle), 0], [0, 0, 1]]
    )
    origin = np.array([0.05, -0.02, 0.01])
    matrix = np.vstack([axes, origin]) if rotate else np.vstack([np.eye(3), np.zeros(3)])
    local = (nodes - matrix[3]) @ matrix[:3].T  # global = local @ axes + origin
    sets = [
        pyuff.prepare_164(
            units_code=1, units_description="SI", temp_mode=2, length=1.0, force=1.0, temp=1.0,
            temp_offset=273.15,
        ),
        pyuff.prepare_2420(
            Part_UID=1, Part_Name="plate", CS_sys_labels=[2], CS_types=[0], CS_colors=[8],
            CS_names=["turned"], CS_matrices=[matrix],
        ),
        pyuff.prepare_2411(
            node_nums=ids, def_cs=np.full(len(ids), 2), disp_cs=np.full(len(ids), 2),
            color=np.ones(len(ids), dtype=int), x=local[:, 0], y=local[:, 1], z=local[:, 2],
        ),
    ]  # fmt: skip
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    values = np.einsum("bi,nim->nbm", matrix[:3], shapes)  # components along the local axes
    with open(path, "a") as handle:
        handle.write(uff_2414_modes(freq, ids, values, analysis_type))


def test_uff_2414_modes_in_a_2420_system_are_the_model(tmp_path, plate):
    _, nodes, shapes, freq, _ = _truth(plate)
    path = tmp_path / "nx.uff"
    _uff(path, plate)
    result = from_modes(path)
    np.testing.assert_allclose(result.freq_hz, freq, rtol=UFF_DIGITS)
    np.testing.assert_allclose(result.nodes, nodes, atol=UFF_DIGITS * np.abs(nodes).max())
    np.testing.assert_allclose(result.shapes, shapes, atol=UFF_DIGITS * np.abs(shapes).max())
    assert "datasets 2414" in result.provenance["source"]
    _uff(tmp_path / "static.uff", plate, analysis_type=1)
    with pytest.raises(
        InputError, match=r"analysis types \{'static': 6\}, not normal mode"
    ) as refused:
        from_modes(tmp_path / "static.uff")
    assert "does not allow" not in str(refused.value)  # named as what it is, not as damage


def _rst(analysis: int = 2, sectors: int = 1, part_of: int = 0) -> RstModes:
    nodes = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2]])
    values = np.zeros((4, 3, 2))
    values[:, 2, 0], values[:, 2, 1] = [0, 1, 1, 0.5], [1, 0, 0.5, 1]
    return RstModes(
        np.array([1.0, 2.0]), np.arange(1, 5), nodes, np.array(["UX", "UY", "UZ"]), values,
        None, "SI", "static.rst", analysis=analysis, sectors=sectors, part_of=part_of,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("rst", "match"),
    [
        (_rst(analysis=0), r"a static analysis \(ANTYPE,STATIC\), not the modes"),
        (_rst(analysis=4), r"a transient analysis"),
        (_rst(analysis=0, sectors=15), r"static analysis .* cyclic symmetry model \(15 sectors"),
        (_rst(sectors=12), r"cyclic symmetry modal analysis \(12 sectors\)"),
        (_rst(part_of=93), r"one part of a distributed result"),
    ],
)
def test_rst_files_that_hold_no_modes_are_refused_naming_what_they_hold(rst, match):
    with pytest.raises(InputError, match=match):
        from_rst_modes(rst, gamma=np.ones((2, 3)))
    assert from_rst_modes(_rst(), gamma=np.ones((2, 3))).n_modes == 2  # a modal one is read


def test_punch_and_uff_damage_is_one_line_naming_the_line_or_the_field(tmp_path):
    path = tmp_path / "flip.pch"
    write_punch(path, [10.0], np.array([1, 2]), np.ones((2, 3, 1)))
    lines = path.read_text().splitlines()
    lines[7] = "        1x" + lines[7][10:]  # a bit flip in the grid id of line 8
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"line 8: '1x' is not a grid id"):
        from_modes(path, units="SI")


RIGID = np.array([0.036, 0.052, 0.09])


def _rigid_motion(nodes, rng, k):
    a, theta = rng.normal(size=3), rng.normal(size=3)
    return a + np.cross(theta, nodes - nodes.mean(axis=0)) * (k + 1)


def test_rigid_modes_are_recognised_by_the_gap_and_their_motion_not_a_fixed_frequency():
    rng = np.random.default_rng(1)
    nodes = rng.uniform(size=(60, 3)) * [1, 0.5, 0.02]
    freq = np.concatenate([RIGID, [4.0, 9.0, 15.0]])
    shapes = np.stack(
        [_rigid_motion(nodes, rng, k) for k in range(3)]
        + [rng.normal(size=(60, 3)) for _ in range(3)],
        axis=2,
    )
    shapes[:, :, :3] += 0.01 * rng.normal(size=(60, 3, 3))  # a solver's contamination
    assert np.all(rigid_fit_residual(nodes, shapes)[:3] < 0.05)
    assert np.all(rigid_fit_residual(nodes, shapes)[3:] > 0.5)
    np.testing.assert_array_equal(rigid_modes(freq, 0.01, nodes, shapes), [1, 1, 1, 0, 0, 0])
    # a low mode that deforms the part is no rigid motion: left to the elastic modes
    shapes[:, :, 2] = rng.normal(size=(60, 3))
    np.testing.assert_array_equal(rigid_modes(freq, 0.01, nodes, shapes), [1, 1, 0, 0, 0, 0])
    # a held part's spectrum is left alone (no gap of 10 below 1 Hz)
    assert not rigid_modes(np.array([2.0, 3.5, 9.0]), 0.01).any()


def _imported(plate, **change) -> ImportedModes:
    ids, nodes, shapes, freq, gamma = _truth(plate)
    fields = {"freq_hz": freq, "shapes": shapes.copy(), "gamma": gamma.copy()}
    fields |= {"nodes": nodes.copy(), "node_ids": ids}
    fields.update(change)
    return ImportedModes(**fields, provenance={"source": "test"})


def test_impossible_models_are_refused_with_the_figure(plate):
    _imported(plate).to_modal_model()  # the plate itself passes
    ids, nodes, shapes, freq, gamma = _truth(plate)
    zero = shapes.copy()
    zero[:, :, 2] = 0
    with pytest.raises(InputError, match=r"mode 3 .* zero at every node with participation"):
        _imported(plate, shapes=zero).to_modal_model()
    twice = ids.copy()
    twice[5] = twice[4]
    with pytest.raises(InputError, match=f"node id {twice[4]} is given 2 times"):
        _imported(plate, node_ids=twice).to_modal_model()
    with pytest.raises(InputError, match=r"all .* nodes lie at one point"):
        _imported(plate, nodes=np.zeros_like(nodes)).to_modal_model()
    with pytest.raises(InputError, match=r"sum Gamma phi, reaches .* disagree"):
        _imported(plate, gamma=gamma * 1e4).to_modal_model()  # sqrt(g) read as sqrt(kg)
    with pytest.raises(InputError, match=r"more than the part's mobile mass"):
        _imported(plate, mobile_mass_kg=np.full(3, 1e-3)).to_modal_model()
    with pytest.raises(InputError, match=r"freq_hz holds 1 value.* not finite"):
        _imported(plate, freq_hz=np.where(np.arange(freq.size) == 1, np.inf, freq)).to_modal_model()


def test_the_plate_s_response_share_is_of_order_one_and_a_slip_is_warned(plate):
    ids, nodes, shapes, _, gamma = _truth(plate)
    share = np.abs(np.einsum("ndm,md->nd", shapes, gamma)).max()
    assert 0.1 < share < 3  # six modes of a held plate: the truncated sum of R = 1
    with pytest.warns(ModelWarning, match=r"sum Gamma phi, reaches"):
        _imported(plate, gamma=gamma * 30).to_modal_model()
    doubled = np.concatenate([nodes, nodes])
    with pytest.warns(ModelWarning, match=r"nodes lie on another node"):
        _imported(
            plate, nodes=doubled, shapes=np.concatenate([shapes, shapes]),
            node_ids=np.arange(1, 2 * len(ids) + 1),
        ).to_modal_model()  # fmt: skip


def test_op2_files_no_solver_writes_are_refused(tmp_path, plate):
    # the three: shapes all zero with participation factors, a GRID given twice (the
    # second's coordinates paired with the first's shapes), all grids at one point
    ids, nodes, shapes, freq, gamma = _truth(plate)
    write_op2(tmp_path / "zero.op2", freq, ids, nodes, 0 * shapes, gamma=gamma)
    with pytest.raises(InputError, match=r"mode 1 .* zero at every node with participation"):
        from_modes(tmp_path / "zero.op2", units="SI").to_modal_model()
    twice = ids.copy()
    twice[7] = twice[3]
    write_op2(tmp_path / "twice.op2", freq, twice, nodes, shapes, gamma=gamma)
    with pytest.raises(InputError, match=f"GRID {twice[3]} is defined twice"):
        from_modes(tmp_path / "twice.op2", units="SI")
    write_op2(tmp_path / "point.op2", freq, ids, 0 * nodes, shapes, gamma=gamma)
    with pytest.raises(InputError, match="nodes lie at one point"):
        from_modes(tmp_path / "point.op2", units="SI").to_modal_model()


def test_an_rst_of_rigid_modes_only_says_that_it_leaves_no_elastic_mode():
    rst = _rst()
    rst.freq_hz = np.array([0.0, 0.0])  # pymapdl-reader's comp_hex_beam.rst: one mode at 0 Hz
    with pytest.raises(InputError, match="leaves no elastic mode to keep"):
        from_rst_modes(rst, gamma=np.ones((1, 3)), allow_rigid_modes=True)


def _uff55(path) -> str:
    import pyuff

    pyuff.UFF(str(path)).write_sets([uff55_mode()], mode="overwrite")
    return path.read_text()


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        ("  1.25000e+01", " 1.00000E+999", r"freq_hz holds 1 value\(s\) that are not finite"),
        ("  1.25000e+01  1.00000e+00", "  1.25000e+01 1.00000E+999", "generalized_mass holds"),
    ],
)
def test_a_uff_with_an_overflowing_number_is_one_line_naming_the_file(tmp_path, old, new, match):
    text = _uff55(tmp_path / "ok.uff")
    assert text.count(old) == 1, text
    (tmp_path / "big.uff").write_text(text.replace(old, new))
    with pytest.raises(InputError, match=match):
        result = from_modes(tmp_path / "big.uff", units="SI", gamma=[[0.0, 0.0, 1.0]])
        result.nodes = np.eye(3)
        result.to_modal_model()


def _flipped(data: bytes, rng) -> bytes:
    """``data`` with one to three bits flipped, cut short one time in seven."""
    out = bytearray(data)
    for _ in range(int(rng.integers(1, 4))):
        out[int(rng.integers(len(out)))] ^= 1 << int(rng.integers(8))
    return bytes(out[: int(rng.integers(len(out)))] if rng.random() < 1 / 7 else out)


def test_damaged_solver_files_are_read_or_refused_in_one_line(tmp_path, plate):
    # issue 34: a bit-flipped punch file ended in a ValueError traceback. Flipped bits in an
    # OP2 (grids in displacement systems, no LAMA), a punch file and a Universal File: each
    # case is a clear refusal, or a model whose every number is finite and passes the checks
    ids, nodes, shapes, freq, gamma = _truth(plate)
    cd = np.resize([0, 5, 7], len(ids))
    systems = [
        (5, "R", np.array([0.1, 0.2, 0.0]), np.array([0.4, 0.5, 0.7]), np.array([0.9, 0.1, 0.3])),
        (7, "C", np.array([0.3, 0.2, -0.1]), np.array([0.3, 0.2, 0.9]), np.array([1.3, 0.4, 0.0])),
    ]  # fmt: skip
    write_op2(tmp_path / "a.op2", freq, ids, nodes, shapes, gamma=gamma, lama=False, cd=cd,
              systems=systems, word=4)  # fmt: skip
    write_punch(tmp_path / "a.pch", freq, ids, shapes)
    _uff(tmp_path / "a.uff", plate)
    rng = np.random.default_rng(34)
    outcomes = {"refused": 0, "read": 0}
    for name in ("a.op2", "a.pch", "a.uff"):
        data = (tmp_path / name).read_bytes()
        for k in range(40):
            path = tmp_path / f"m{k}{Path(name).suffix}"
            path.write_bytes(_flipped(data, rng))
            try:
                result = from_modes(path, units="SI", gamma=None, nodes=None)
                result.check()
            except InputError:
                outcomes["refused"] += 1
                continue
            assert np.isfinite(result.freq_hz).all() and np.isfinite(result.shapes).all()
            outcomes["read"] += 1
    assert outcomes["refused"] > 0 and outcomes["read"] > 0, outcomes
