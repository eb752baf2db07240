"""ANSYS import on the real MAPDL files shipped by ansys-mapdl-reader (nobody here wrote them).

``file.full``: matrices of a 321-node hexahedral beam (one end held, 63 DOFs); ``file.rst``:
a 6-mode modal result of a differently constrained run of the same mesh; ``HexBeam.cdb``: the
mesh with coordinates. The material (E = 16.9e6, density 4.14e-4) is titanium in inches
and lbf s^2/in, so the files are read as BIN units.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp
from ansys.mapdl.reader import examples, read_binary

import fem
from fem.imports.ansys import RstModes, from_rst_modes, read_full
from fem.imports.units import UNIT_SYSTEMS
from jaxflex.errors import InputError

BIN = UNIT_SYSTEMS["BIN"]
FULL_FIRST_SIX_HZ = [1283.20, 1283.20, 5781.97, 6919.40, 6919.40, 10172.61]
RST_HZ = [7366.50, 7366.50, 11504.90, 17285.70, 17285.70, 20137.19]


def dense_reference():
    """The .full's matrices as the reader gives them (upper triangles, empty constrained rows),
    symmetrised and reduced here independently of fem.imports.ansys, and solved densely."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, k_upper, m_upper = read_binary(examples.fullfile).load_km(sort=True)
    k, m = k_upper.toarray(), m_upper.toarray()
    k, m = k + np.triu(k, 1).T, m + np.triu(m, 1).T
    free = np.flatnonzero(np.abs(k).sum(axis=1) > 0)
    k, m = k[np.ix_(free, free)], m[np.ix_(free, free)]
    values, vectors = scipy.linalg.eigh(k, m)
    return np.sqrt(values) / (2 * np.pi), vectors, k, m


@pytest.fixture(scope="module")
def full_modes():
    return fem.from_ansys(examples.fullfile, units="BIN", n_modes=6, nodes=examples.hexarchivefile)


def dof_vectors(result, mats):
    """Mode vectors over the free DOFs of ``mats`` (file units) from the node shapes."""
    free = np.flatnonzero(~mats.constrained)
    row = {int(n): i for i, n in enumerate(result.node_ids)}
    rows = np.array([row[int(n)] for n in mats.node_ids[free]])
    cols = np.array([["UX", "UY", "UZ"].index(label) for label in mats.labels[free]])
    return result.shapes[rows, cols, :] / BIN.shape_to_si, free


def test_full_modes_equal_a_dense_solve_of_the_same_matrices(full_modes):
    freq_dense, _, _, _ = dense_reference()
    # 1e-6 is the target; shift-invert Lanczos (ARPACK to machine precision) and LAPACK's
    # eigh agree to 2e-10 here (measured; eigenvalue spread ~1e4 of a 900-DOF problem)
    np.testing.assert_allclose(full_modes.freq_hz, freq_dense[:6], rtol=1e-6)
    # the published values of this example, to the 0.01 Hz they are printed with
    np.testing.assert_allclose(full_modes.freq_hz, FULL_FIRST_SIX_HZ, atol=0.005)


def test_full_modes_are_mass_normalised(full_modes):
    mats = read_full(examples.fullfile)
    phi, free = dof_vectors(full_modes, mats)
    m_free = mats.M[free][:, free]
    # normalisation divides by sqrt(phi^T M phi) once: the Gram matrix is I to rounding
    # (1e-15 measured; the degenerate pairs are M-orthogonal through the Lanczos basis)
    np.testing.assert_allclose(phi.T @ (m_free @ phi), np.eye(6), atol=1e-9)


def test_participation_of_all_modes_sums_to_the_rigid_mass():
    mats = read_full(examples.fullfile)
    free = ~mats.constrained
    result = fem.from_ansys(examples.fullfile, units="BIN", n_modes="all")
    rigid = np.zeros((int(free.sum()), 3))
    for d, name in enumerate(("UX", "UY", "UZ")):
        rigid[mats.labels[free] == name, d] = 1.0
    m_free = mats.M[free][:, free]
    rigid_mass_kg = np.einsum("id,id->d", rigid, m_free @ rigid) * BIN.mass_kg
    # sum_i Gamma_i^2 = R^T M phi phi^T M R = R^T M R for a complete M-orthonormal basis;
    # the dense solve keeps that identity to rounding (9e-16 measured over 900 terms)
    np.testing.assert_allclose(np.sum(result.gamma**2, axis=0), rigid_mass_kg, rtol=1e-9)
    np.testing.assert_allclose(result.mobile_mass_kg, rigid_mass_kg, rtol=1e-12)
    assert result.n_modes == int(free.sum())  # held at one end: no rigid-body mode


def test_full_without_coordinates_says_where_to_get_them():
    result = fem.from_ansys(examples.fullfile, units="BIN", n_modes=2)
    assert result.nodes is None
    with pytest.raises(InputError, match=r"node coordinates: .*\.cdb archive"):
        result.to_modal_model()


def test_full_model_file_meta_and_points(full_modes):
    model = full_modes.to_modal_model(points="all")
    assert model.n_points == 321 and model.n_modes == 6
    np.testing.assert_allclose(model.points.max(axis=0), np.array([1.0, 1.0, 5.0]) * 0.0254)
    assert model.meta["input"]["full"]["sha256"]
    assert model.labels[0] == "node 1"
    held = [i for i, lab in enumerate(model.labels) if lab in ("node 1", "node 4", "node 19")]
    assert np.all(model.shapes[held] == 0)  # nodes the .full constrains do not move


def test_rst_alone_gives_its_frequencies_and_shapes_but_no_participation():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rst = read_binary(examples.rstfile)
        first = rst.nodal_solution(0)[1]
    result = fem.from_ansys(examples.rstfile, units="BIN")
    np.testing.assert_allclose(result.freq_hz, rst.time_values, rtol=1e-9)
    np.testing.assert_allclose(result.freq_hz, RST_HZ, atol=0.005)
    assert result.shapes.shape == (321, 3, 6)
    np.testing.assert_allclose(result.shapes[:, :, 0], first * BIN.shape_to_si, rtol=1e-12)
    assert result.stress is not None and result.stress.shape == (321, 6, 6)
    with pytest.raises(InputError, match="holds no mass matrix"):
        result.to_modal_model()
    gamma = np.tile([0.1, 0.2, 0.3], (6, 1))
    model = fem.from_ansys(examples.rstfile, units="BIN", gamma=gamma).to_modal_model()
    np.testing.assert_array_equal(model.gamma, gamma)
    assert model.meta["derived"]["gamma"] == "given by the user"


def test_rst_paired_with_the_full_of_another_run_is_refused():
    with pytest.raises(InputError) as info:
        fem.from_ansys(examples.rstfile, units="BIN", full=examples.fullfile)
    message = str(info.value)
    assert "constraints differ" in message
    assert "63 DOF(s) constrained in file.full move in the modes of file.rst" in message


def synthetic_rst(full_modes, scale=1.0, freq_hz=None):
    """A result-file view of modes computed from file.full (what MAPDL would write for a
    matching run), scaled like MODOPT NRMKEY=ON would leave them."""
    values = full_modes.shapes / BIN.shape_to_si * scale
    return RstModes(
        freq_hz=full_modes.freq_hz if freq_hz is None else freq_hz,
        node_ids=full_modes.node_ids,
        nodes=full_modes.nodes / BIN.length_m,
        labels=np.array(["UX", "UY", "UZ"]),
        values=values,
        stress=None,
        units=None,
        path="synthetic.rst",
    )


def test_matching_rst_and_full_give_the_full_participation(full_modes):
    paired = from_rst_modes(
        synthetic_rst(full_modes, scale=2.0), full=examples.fullfile, units="BIN"
    )
    # same vectors up to the factor 2 the pairing removes: equal to rounding (~1e-15)
    np.testing.assert_allclose(paired.gamma, full_modes.gamma, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(paired.shapes, full_modes.shapes, rtol=1e-9, atol=1e-15)
    assert paired.provenance["derived"]["mass_normalisation"]["rescaled"]
    wrong = full_modes.freq_hz * 1.01  # a stiffer model: the modes no longer solve K, M
    with pytest.raises(InputError, match="does not solve the eigenproblem"):
        from_rst_modes(
            synthetic_rst(full_modes, freq_hz=wrong), full=examples.fullfile, units="BIN"
        )


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"units": "furlong"}, "unknown unit system"),
        (
            {"units": "BIN", "gamma": np.ones((6, 2))},
            r"gamma: expected finite values of shape \(6, 3\)",
        ),
        ({"units": "BIN", "gamma": np.ones((6, 3)), "full": examples.fullfile}, "not both"),
        ({"units": "BIN", "nodes": examples.hexarchivefile}, "holds its node coordinates"),
    ],
)
def test_bad_arguments_are_named(kwargs, message):
    with pytest.raises(InputError, match=message):
        fem.from_ansys(examples.rstfile, **kwargs)


def test_node_csv_and_missing_files(tmp_path, full_modes):
    csv = tmp_path / "nodes.csv"
    ids = full_modes.node_ids
    table = np.column_stack([ids, full_modes.nodes / BIN.length_m])
    np.savetxt(csv, table, delimiter=",", header="node,x,y,z", comments="")
    from_csv = fem.from_ansys(examples.fullfile, units="BIN", n_modes=2, nodes=csv)
    np.testing.assert_allclose(from_csv.nodes, full_modes.nodes)
    np.savetxt(csv, table[:-1], delimiter=",")
    with pytest.raises(InputError, match="lacks 1 node"):
        fem.from_ansys(examples.fullfile, units="BIN", n_modes=2, nodes=csv)
    with pytest.raises(InputError, match="does not exist"):
        fem.from_ansys(tmp_path / "nothing.full", units="BIN")
    bogus = tmp_path / "bogus.full"
    bogus.write_bytes(b"not a full file" * 10)
    with pytest.raises(InputError, match=r"not a MAPDL \.full file"):
        fem.from_ansys(bogus, units="BIN")


def test_rotated_nodal_coordinate_systems_are_applied():
    # issue 24: a .full's DOFs are in each node's nodal system (NROTAT). Our shell's
    # matrices (global DOFs, 6 per node) turned into random nodal systems, K_n = B^T K B,
    # must give the same frequencies, global shapes and participation factors once the node
    # rotations are applied (fem.imports.ansys._free_system, _observation); the rotations follow
    # ansys-mapdl-reader's own conversion of .rst results to global axes.
    from ansys.mapdl.reader.common import rotate_to_global

    from fem.imports.ansys import FullMatrices, _free_system, _observation, nodal_rotations
    from fem.modal import solve_modes

    part = fem.rectangular_plate(0.3, 0.2, 1e-3, mesh_size=0.05, element="shell")
    truth = fem.modal_analysis(part, [fem.ClampedEdge("x0")], 4, progress=False)
    system = truth.system
    n_nodes = len(system.nodes)
    angles = np.random.default_rng(3).uniform(-90, 90, (n_nodes, 3))
    turns = nodal_rotations(angles)
    vectors = np.random.default_rng(4).normal(size=(n_nodes, 3))
    theirs = np.einsum("nij,nj->ni", turns, vectors)
    rotate_to_global(vectors, angles.T.copy())  # in place, ZXY as MAPDL
    np.testing.assert_allclose(theirs, vectors, atol=1e-12)
    blocks = [turns[n] for n in range(n_nodes) for _ in range(2)]  # translations, rotations
    B = sp.block_diag(blocks, format="csr")
    labels = np.tile(["UX", "UY", "UZ", "ROTX", "ROTY", "ROTZ"], n_nodes)
    node_ids = np.repeat(np.arange(1, n_nodes + 1), 6)
    constrained = np.zeros(system.n_dof, dtype=bool)
    constrained[system.constraints.fixed] = True
    full = FullMatrices(
        (B.T @ system.K @ B).tocsr(), (B.T @ system.M @ B).tocsr(), node_ids, labels,
        constrained, "SI", "rotated",
    )  # fmt: skip
    rotations = dict(zip(range(1, n_nodes + 1), turns, strict=True))
    free, K, M, rigid = _free_system(full, rotations)
    observation = _observation(np.arange(1, n_nodes + 1), node_ids[free], labels[free], rotations)
    modes = solve_modes(K, M, M @ rigid, observation, 4, progress=False)
    # the same model in global DOFs (a .full holds no mass coupling to the constrained DOFs:
    # Gamma = phi^T M_ff R_f on both sides)
    plain = FullMatrices(system.K, system.M, node_ids, labels, constrained, "SI", "global")
    _, K0, M0, rigid0 = _free_system(plain)
    ids = np.arange(1, n_nodes + 1)
    observation0 = _observation(ids, node_ids[free], labels[free])
    reference = solve_modes(K0, M0, M0 @ rigid0, observation0, 4, progress=False)
    np.testing.assert_allclose(modes.freq_hz, truth.freq_hz, rtol=1e-9)
    np.testing.assert_allclose(modes.freq_hz, reference.freq_hz, rtol=1e-9)
    scale = np.abs(reference.gamma).max()
    np.testing.assert_allclose(modes.gamma, reference.gamma, atol=1e-9 * scale)
    shapes = (observation @ modes.vectors).reshape(n_nodes, 3, -1)
    np.testing.assert_allclose(shapes, truth.node_shapes(), atol=1e-9 * np.abs(shapes).max())
    # without the rotations the participation is wrong: the check can fail
    unturned = _free_system(full)[3]
    assert np.abs(modes.vectors.T @ (M @ unturned) - reference.gamma).max() > 1e-3 * scale


def test_rigid_body_modes_of_a_rst_follow_the_rule_of_every_door(full_modes):
    # issue 24: --from-ansys dropped six rigid modes silently and refused the option
    freq = np.concatenate([[0.0, 1e-4], full_modes.freq_hz[2:]])
    rst = synthetic_rst(full_modes, freq_hz=freq)
    with pytest.raises(InputError, match=r"2 rigid-body mode\(s\) .*allow_rigid_modes"):
        from_rst_modes(rst, units="BIN", n_modes=4)
    result = from_rst_modes(rst, units="BIN", n_modes=4, allow_rigid_modes=True)
    assert result.provenance["rigid_modes"] == {"count": 2, "freq_hz": [0.0, 1e-4]}
    np.testing.assert_array_equal(result.freq_hz, full_modes.freq_hz[2:6])
