"""Turning-move inertia data of imported models (fem.rotation_integrals via the Nastran and
ANSYS doors) against closed forms and completeness identities written here, independently of
the code's own sums."""

from __future__ import annotations

import numpy as np
import pytest
from ansys.mapdl.reader import examples
from decks import STEEL, card, rigid_mass, skew, solve, write
from test_fem_ansys import BIN
from test_fem_deck_points import (
    CENTRE,
    MASS,
    OFFSET,
    celas2,
    conm2,
    conm2_inertia,
    plate_mass,
    rigid_plate,
)

import fem
from fem.imports.ansys import from_rst_modes, read_full
from jaxflex._pose import fixed_axis_path, turn_acceleration
from jaxflex._turning import Turn, simulate_turning


def about_origin(mass_6x6: np.ndarray, point: np.ndarray) -> np.ndarray:
    """A rigid body's (6, 6) mass matrix about ``point`` moved to the origin: the point
    moves by u + theta x point = (I, -S(point)) (u, theta)."""
    t = np.eye(6)
    t[:3, 3:] = -skew(point)
    return t.T @ mass_6x6 @ t


def test_deck_of_a_rigid_body_on_springs_carries_its_inertia(tmp_path):
    """The rigid plate with an offset CONM2 on six springs (tests/test_fem_deck_points.py):
    its six modes span every rigid motion, so the rotation data must be the body's mass,
    centre and inertia about the origin in closed form, and the rotational participation of
    the six modes must sum to that inertia (sum_m Gamma_rot,m Gamma_rot,m^T = R^T M R for a
    complete M-orthonormal basis). The shell's consistent mass is exact for rigid motions:
    only round-off remains (1e-9)."""
    result = solve(write(tmp_path / "d.bdf", rigid_plate([conm2(), *celas2()])), n_modes=6)
    rotation = result.to_modal_model().rotation
    body = about_origin(plate_mass() + rigid_mass(MASS, conm2_inertia(), OFFSET), CENTRE)
    mass = body[0, 0]
    inertia = body[3:, 3:]
    # the coupling block is m (-S(c)): the centre of mass, the CONM2's offset included
    centre = -np.array([body[2, 4], body[0, 5], body[1, 3]]) / mass
    scale = np.abs(inertia).max()
    assert rotation.mass_kg == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(rotation.centre_m, centre, rtol=0, atol=1e-12)
    assert np.abs(rotation.inertia_kg_m2 - inertia).max() <= 1e-9 * scale
    gamma_rot = rotation.gamma_rot
    assert np.abs(gamma_rot.T @ gamma_rot - inertia).max() <= 1e-9 * scale


def test_curved_deck_has_the_rotational_participation_of_its_rigid_rotations(tmp_path):
    """A curved sheet given as a Nastran deck (GRID + CQUAD4 on a cylinder, SPC1 at four
    grids): the rotational participation the model stores (from the linear fields' shape
    integrals) equals phi^T M (e_k x r) with the rigid rotations of the deck's own outputs
    (fem.system.FormulationOutputs.rigid_motion), taken here, to round-off (1e-9); the deck's
    model is no longer refused for a turning move, and a swivel bends it beyond the bound of
    the neglected terms."""
    nx, ny, width, height, radius = 8, 6, 0.4, 0.3, 1.0
    xs, ys = np.linspace(0, width, nx + 1), np.linspace(0, height, ny + 1)
    x, y = np.meshgrid(xs, ys)
    z = radius - np.sqrt(radius**2 - (x - width / 2) ** 2)
    ids = 1 + np.arange(x.size).reshape(x.shape)
    lines = [card("GRID", int(ids[j, i]), None, float(x[j, i]), float(y[j, i]), float(z[j, i]))
             for j in range(ny + 1) for i in range(nx + 1)]  # fmt: skip
    eid = 1
    quads = []
    for j in range(ny):
        for i in range(nx):
            quad = (ids[j, i], ids[j, i + 1], ids[j + 1, i + 1], ids[j + 1, i])
            quads.append(quad)
            lines.append(card("CQUAD4", eid, 1, *map(int, quad)))
            eid += 1
    held = [int(ids[j, i]) for j in (1, ny - 1) for i in (2, nx - 2)]
    lines += [card("PSHELL", 1, 1, 1e-3, 1), STEEL, card("SPC1", 1, 123456, *held)]
    deck = solve(write(tmp_path / "c.bdf", lines, "SPC = 1"), n_modes=6)
    model = deck.to_modal_model(points="all")
    assert model.rotation is not None
    alpha = turn_acceleration(np.pi / 2, 3.0, 20.0, 400.0, 1e-3)
    path = fixed_axis_path("z", alpha, 1e-3)
    response = simulate_turning(model, Turn(path, np.zeros((len(alpha), 3))), extend_s=0.1)
    assert response.deviation_m.max() > response.neglected_bound_m  # measured 7.2 vs 5.2 um
    # Gamma_rot of the deck's modes = phi^T M (e_k x r) with the rigid rotations the deck's
    # own outputs give (fem.system.FormulationOutputs.rigid_motion), built here
    system = deck.system
    rigid_rot = system.outputs.rigid_motion(np.zeros(3))[:, 3:]
    direct = (deck.basis @ deck.vectors).T @ (system.M @ rigid_rot)
    np.testing.assert_allclose(
        model.rotation.gamma_rot, direct, rtol=0, atol=1e-9 * np.abs(direct).max()
    )


@pytest.fixture(scope="module")
def column():
    return fem.from_ansys(
        examples.fullfile, units="BIN", n_modes="all", nodes=examples.hexarchivefile
    )


def test_ansys_full_rotational_participation_sums_to_the_inertia(column):
    """MAPDL's own example (a 1 x 1 x 5 in column of hexahedra, held at its base; a .full
    nobody here wrote) with every mode: the rotational participation sums to the inertia of
    the mass the modes move, R^T M_ff R with the rigid rotations e_k x r built here from the
    archive's coordinates (completeness, like sum Gamma^2 = mobile mass; the dense solve
    keeps it to rounding: 1e-9). The inertia about the column's axis is that of a 1 x 1 in
    square section of the mobile mass within the share the held base nodes take."""
    mats = read_full(examples.fullfile)
    free = ~mats.constrained
    ids, coords = column.node_ids, column.nodes / BIN.length_m
    where = {int(n): i for i, n in enumerate(ids)}
    points = coords[[where[int(n)] for n in mats.node_ids[free]]]
    translation = np.zeros((int(free.sum()), 3))
    for d, name in enumerate(("UX", "UY", "UZ")):
        translation[mats.labels[free] == name, d] = 1.0
    rigid_rot = np.stack([np.cross(np.eye(3)[k], points) for k in range(3)], axis=-1)
    rigid_rot = np.einsum("nc,nck->nk", translation, rigid_rot)
    m_free = mats.M[free][:, free]
    inertia = rigid_rot.T @ (m_free @ rigid_rot) * BIN.mass_kg * BIN.length_m**2
    rotation = column.rotation
    gamma_rot = rotation.gamma_rot
    np.testing.assert_allclose(gamma_rot.T @ gamma_rot, inertia, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(rotation.inertia_kg_m2, inertia, rtol=1e-12, atol=1e-15)
    assert rotation.mass_kg == pytest.approx(column.mobile_mass_kg[2], rel=1e-12)


def test_rst_paired_with_its_full_has_the_same_rotation_data(column):
    """A .rst of the .full's modes (scaled by 2, as MAPDL with another normalisation) paired
    with the .full: the pairing rescales the modes, so the inertia data equal the .full
    route's to rounding; a .rst alone has none and says so when turned."""
    from test_fem_ansys import synthetic_rst

    few = fem.from_ansys(examples.fullfile, units="BIN", n_modes=6, nodes=examples.hexarchivefile)
    paired = from_rst_modes(synthetic_rst(few, scale=2.0), full=examples.fullfile, units="BIN")
    scale = np.abs(few.rotation.shape_integrals).max()
    np.testing.assert_allclose(
        paired.rotation.shape_integrals, few.rotation.shape_integrals, rtol=0, atol=1e-9 * scale
    )
    np.testing.assert_allclose(paired.rotation.inertia_kg_m2, few.rotation.inertia_kg_m2)
    alone = from_rst_modes(synthetic_rst(few), gamma=few.gamma, units="BIN")
    assert alone.rotation is None
