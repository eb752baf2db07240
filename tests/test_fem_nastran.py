"""Nastran decks (written here with pyNastran's writer) solved by our plate model."""

from __future__ import annotations

import numpy as np
import pytest
from pyNastran.bdf.bdf import BDF

import fem
from fem import meshing
from jaxflex.errors import InputError

STEEL_SI = {"E": 210e9, "nu": 0.3, "rho": 7850.0, "t": 1e-3}
STEEL_MPA = {"E": 210e3, "nu": 0.3, "rho": 7.85e-9, "t": 1.0}  # mm, t, s, N, MPa


def write_deck(path, nodes_xy, cells, *, scale=1.0, card="CTRIA3", mat=STEEL_SI, spc=None):
    """A bulk-data deck in large fields (16 characters keep 15 digits of the coordinates)."""
    deck = BDF(debug=None)
    for i, (x, y) in enumerate(nodes_xy * scale, start=1):
        deck.add_grid(i, [x, y, 0.0])
    add = {"CTRIA3": deck.add_ctria3, "CQUAD4": deck.add_cquad4, "CQUAD8": deck.add_cquad8}
    next_grid = len(nodes_xy) + 1
    for e, cell in enumerate(cells, start=1):
        nids = (np.asarray(cell) + 1).tolist()
        if card == "CQUAD8":  # mid-side grids, as a quadratic mesher writes them
            corners = np.asarray(cell)
            for k in range(4):
                a, b = corners[k], corners[(k + 1) % 4]
                deck.add_grid(next_grid, [*(0.5 * (nodes_xy[a] + nodes_xy[b]) * scale), 0.0])
                nids.append(next_grid)
                next_grid += 1
        add[card](e, 1, nids)
    deck.add_pshell(1, mid1=1, t=mat["t"], mid2=1, mid3=1)
    deck.add_mat1(1, mat["E"], None, mat["nu"], rho=mat["rho"])
    if spc is not None:
        deck.add_spc1(1, spc[0], (np.asarray(spc[1]) + 1).tolist())
    deck.write_bdf(str(path), size=16)
    return path


def test_deck_of_the_built_in_plate_gives_its_frequencies(tmp_path):
    part, cups = fem.scene("plate", mesh_size=0.05)
    mesh = part.mesh(cups)
    deck = write_deck(tmp_path / "plate.bdf", mesh.nodes_xy, mesh.triangles)
    result = fem.from_nastran(deck, units="SI", cups=cups, n_modes=12)
    reference = fem.modal_analysis(part, cups, n_modes=12)
    # same nodes (15 digits in the deck), elements, material, cups: the same matrices up to
    # the coordinates' last digit, so the target 1e-6 holds with room (1e-13 measured)
    np.testing.assert_allclose(result.freq_hz, reference.freq_hz, rtol=1e-6)
    model = result.to_modal_model(points=200)
    assert model.meta["input"]["deck"]["sha256"]
    assert model.meta["derived"]["units"]["name"] == "SI"


def simply_supported(tmp_path, card, units, mat, scale):
    nodes, quads = meshing.grid_quads(np.linspace(0, 0.6, 13), np.linspace(0, 0.4, 9))
    edge = np.flatnonzero(
        np.isclose(nodes[:, 0], 0)
        | np.isclose(nodes[:, 0], 0.6)
        | np.isclose(nodes[:, 1], 0)
        | np.isclose(nodes[:, 1], 0.4)
    )
    deck = write_deck(
        tmp_path / f"ss_{card}_{units}.bdf",
        nodes,
        quads,
        scale=scale,
        card=card,
        mat=mat,
        spc=("3", edge),
    )
    return fem.from_nastran(deck, units=units, n_modes=6)


def test_spc_edges_quads_and_units_equal_our_simply_supported_plate(tmp_path):
    part = fem.rectangular_plate(0.6, 0.4, mesh_size=0.05)
    reference = fem.modal_analysis(part, [fem.SimplySupportedEdge("all")], n_modes=6)
    # our plate meshes the rectangle with the same quads split the same way, and a simply
    # supported Morley edge holds exactly the deflection of its vertices: equal to rounding
    for card, units, mat, scale in [
        ("CQUAD4", "SI", STEEL_SI, 1.0),
        ("CQUAD4", "MPA", STEEL_MPA, 1e3),  # the same deck in mm, t, s
        ("CQUAD8", "SI", STEEL_SI, 1.0),  # mid-side grids are dropped
    ]:
        result = simply_supported(tmp_path, card, units, mat, scale)
        np.testing.assert_allclose(result.freq_hz, reference.freq_hz, rtol=1e-6)
    assert result.provenance["derived"]["held_grids"] == 40  # the 13 x 9 grid's boundary


def test_deck_errors_are_named(tmp_path):
    nodes, quads = meshing.grid_quads(np.linspace(0, 0.3, 4), np.linspace(0, 0.2, 3))
    free = write_deck(tmp_path / "free.bdf", nodes, quads, card="CQUAD4")
    with pytest.raises(InputError, match="does not state its unit system"):
        fem.from_nastran(free)
    with pytest.raises(InputError, match="no SPC and no cups"):
        fem.from_nastran(free, units="SI")
    clamped = write_deck(tmp_path / "c.bdf", nodes, quads, card="CQUAD4", spc=("123456", [0]))
    with pytest.raises(InputError, match="holds rotations"):
        fem.from_nastran(clamped, units="SI")
    with pytest.raises(InputError, match="does not exist"):
        fem.from_nastran(tmp_path / "none.bdf", units="SI")
