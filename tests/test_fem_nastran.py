"""Nastran decks solved by our plate model. The grids and shell elements are written by
meshio's Nastran writer (an independent implementation), the property, material and
constraint cards are added as text in small field with Nastran's real forms."""

from __future__ import annotations

import meshio
import numpy as np
import pytest
from test_fem_bdf import SMALL

import fem
from fem.imports.nastran.thick import kirchhoff_excess
from fem.mesh import meshing
from fem.sanity import PartWarning
from jaxflex.cli import main
from jaxflex.errors import InputError

STEEL_SI = ["PSHELL  1       1       1.-3    1", "MAT1    1       2.1+11          .3      7850."]
STEEL_MPA = ["PSHELL  1       1       1.      1", "MAT1    1       2.1+5           .3      7.85-9"]


def meshio_deck(
    path, points, cell_type, cells, cards, point_format="fixed-large", cell_format="fixed-small"
):
    """A deck of GRIDs ((K, 2) or (K, 3) coordinates) and shells of property 1 written by
    meshio, ``cards`` (lines of text) added before ENDDATA. ``point_format``/``cell_format``:
    meshio's (its fixed-large GRID* keeps 12 digits of the coordinates)."""
    xyz = points if points.shape[1] == 3 else np.column_stack([points, np.zeros(len(points))])
    mesh = meshio.Mesh(
        xyz, [(cell_type, cells)], cell_data={"nastran:ref": [np.ones(len(cells), int)]}
    )
    meshio.write(
        path, mesh, file_format="nastran", point_format=point_format, cell_format=cell_format
    )
    text = path.read_text()
    assert text.endswith("ENDDATA\n")
    path.write_text(text.removesuffix("ENDDATA\n") + "".join(c + "\n" for c in cards) + "ENDDATA\n")
    return path


def spc1_cards(grid_ids, sid=1):
    """SPC1 cards holding translation 3 of ``grid_ids`` (1-based), six grids a card."""
    ids = [int(g) for g in grid_ids]
    return [
        "SPC1    " + f"{sid:<8d}3       " + "".join(f"{g:<8d}" for g in ids[k : k + 6])
        for k in range(0, len(ids), 6)
    ]


def test_deck_of_the_built_in_plate_gives_its_frequencies(tmp_path):
    part, cups = fem.scene("plate", mesh_size=0.05)
    mesh = part.mesh(cups)
    deck = meshio_deck(tmp_path / "plate.bdf", mesh.nodes_xy, "triangle", mesh.triangles, STEEL_SI)
    result = fem.from_nastran(deck, units="SI", cups=cups, n_modes=12)
    reference = fem.modal_analysis(part, cups, n_modes=12)
    # same nodes (12 digits in meshio's GRID*), elements, material, cups: the same matrices up
    # to the coordinates' 12th digit, so the target 1e-6 holds with room (6e-12 measured)
    np.testing.assert_allclose(result.freq_hz, reference.freq_hz, rtol=1e-6)
    model = result.to_modal_model(points=200)
    assert model.meta["input"]["deck"]["sha256"]
    assert model.meta["derived"]["units"]["name"] == "SI"
    assert model.meta["derived"]["material_notes"] == {"MAT1 1": "G from E = 2 (1 + NU) G"}


WIDTH, HEIGHT = 0.6, 0.4


@pytest.fixture(scope="module")
def simply_supported():
    """Our simply supported 0.6 m x 0.4 m plate; its mesh is the 13 x 9 grid of 50 mm quads
    split along the same diagonals, and a Morley edge holds the deflection of its vertices
    only: a deck of those quads with SPC 3 on the boundary grids is the same model."""
    part = fem.rectangular_plate(WIDTH, HEIGHT, mesh_size=0.05)
    return fem.modal_analysis(part, [fem.SimplySupportedEdge("all")], n_modes=6)


def on_boundary(points_xy):
    x, y = points_xy.T
    return np.isclose(x, 0) | np.isclose(x, WIDTH) | np.isclose(y, 0) | np.isclose(y, HEIGHT)


def rectangle():
    nodes, quads = meshing.grid_quads(np.linspace(0, WIDTH, 13), np.linspace(0, HEIGHT, 9))
    return nodes, quads, on_boundary(nodes)


def with_midside(nodes, cells):
    """Quadratic cells: each edge's mid-point appended as a grid, one per edge (neighbours
    share it, as a quadratic mesher writes them)."""
    n = cells.shape[1]
    edges = np.stack([cells, np.roll(cells, -1, axis=1)], axis=-1)  # (E, n, 2)
    unique, inverse = np.unique(np.sort(edges.reshape(-1, 2), axis=1), axis=0, return_inverse=True)
    mids = 0.5 * (nodes[unique[:, 0]] + nodes[unique[:, 1]])
    ids = len(nodes) + inverse.reshape(-1, n)
    return np.vstack([nodes, mids]), np.column_stack([cells, ids])


def test_quads_triangles_and_units(tmp_path, simply_supported):
    nodes, quads, _ = rectangle()
    decks = {
        "CQUAD4, free-field GRIDs": (nodes, STEEL_SI, "free", "fixed-small", "SI"),
        "CQUAD4 in mm, t, s": (nodes * 1e3, STEEL_MPA, "fixed-large", "fixed-large", "MPA"),
    }
    for name, (points, cards, point_format, cell_format, units) in decks.items():
        path = tmp_path / f"{point_format}.bdf"
        held = spc1_cards(np.flatnonzero(on_boundary(points / points.max() * WIDTH)) + 1)
        meshio_deck(path, points, "quad", quads, cards + held, point_format, cell_format)
        result = fem.from_nastran(path, units=units, n_modes=6)
        # the same model: equal to rounding (the mesh's node coordinates differ by 1e-15)
        np.testing.assert_allclose(
            result.freq_hz, simply_supported.freq_hz, rtol=1e-6, err_msg=name
        )
        assert result.provenance["derived"]["held_grids"] == 40  # the 13 x 9 grid's boundary


def navier_hz(count: int) -> np.ndarray:
    """The first frequencies of the simply supported steel plate WIDTH x HEIGHT x 1 mm
    (Navier: f_mn = pi / 2 (m^2 / a^2 + n^2 / b^2) sqrt(D / (rho t)))."""
    e, nu, rho, t = 2.1e11, 0.3, 7850.0, 1e-3
    d = e * t**3 / (12 * (1 - nu**2))
    f = [
        np.pi / 2 * (m**2 / WIDTH**2 + n**2 / HEIGHT**2) * np.sqrt(d / (rho * t))
        for m in range(1, 6)
        for n in range(1, 6)
    ]
    return np.sort(f)[:count]


def test_quadratic_elements_use_their_mid_side_grids(tmp_path):
    # the 13 x 9 grid of 50 mm quads as CQUAD4, and with a mid-side grid on every edge as
    # CQUAD8 and (split) CTRIA6; SPC 3 on every boundary grid, mid-side grids included.
    # Facets through the mid-side grids halve the element size: our elements' frequency
    # error is O(h^2) (DKT, Morley), so the quadratic decks come out 2.5-4 times closer to
    # Navier than the CQUAD4 deck of the same corners over the first four modes (measured
    # 2.5-4.0: a CQUAD8's six facets are no uniform halving; corner facets alone, the
    # mid-side grids dropped, give the CQUAD4 deck's error)
    nodes, quads, _ = rectangle()
    triangles = meshing.split_quads(quads, nodes)
    exact = navier_hz(4)
    decks = {
        "CQUAD4": (nodes, quads, "quad"),
        "CQUAD8": (*with_midside(nodes, quads), "quad8"),
        "CTRIA6": (*with_midside(nodes, triangles), "triangle6"),
    }
    errors = {}
    for name, (points, cells, kind) in decks.items():
        held = spc1_cards(np.flatnonzero(on_boundary(points)) + 1)
        path = meshio_deck(tmp_path / f"{kind}.bdf", points, kind, cells, STEEL_SI + held)
        for element in ("morley", "shell"):  # morley: the default of a flat deck like this
            result = fem.from_nastran(
                path, units="SI", n_modes=4, element=element, allow_rigid_modes=True
            )
            errors[name, element] = np.abs(result.freq_hz / exact - 1)
        if name != "CQUAD4":
            assert result.provenance["derived"]["elements"][name] == len(cells)
    for element in ("morley", "shell"):
        linear = errors["CQUAD4", element]
        for name in ("CQUAD8", "CTRIA6"):
            assert errors[name, element].sum() < linear.sum() / 2, (name, element)
    assert max(errors["CQUAD8", "shell"].max(), errors["CTRIA6", "shell"].max()) < 5e-3


def test_wtmass_and_mat1_from_e_and_g(tmp_path, simply_supported):
    nodes, quads, edge = rectangle()
    boundary = spc1_cards(np.flatnonzero(edge) + 1)
    # E and G given, NU blank: Nastran's rule gives NU = E / (2 G) - 1 = 0.3
    e_and_g = ["PSHELL  1       1       1.-3    1", "MAT1,1,2.1+11,8.0769230769231+10,,7850."]
    path = meshio_deck(tmp_path / "eg.bdf", nodes, "quad", quads, [*e_and_g, *boundary])
    result = fem.from_nastran(path, units="SI", n_modes=6)
    # NU from a 14-digit G: 1e-13 off, frequencies move by far less than 1e-6
    np.testing.assert_allclose(result.freq_hz, simply_supported.freq_hz, rtol=1e-6)
    assert result.provenance["derived"]["material_notes"] == {"MAT1 1": "NU from E = 2 (1 + NU) G"}
    # PARAM WTMASS scales the mass: a quarter of it doubles every frequency (omega ~ 1/sqrt(m))
    path = meshio_deck(
        tmp_path / "wt.bdf", nodes, "quad", quads, ["PARAM,WTMASS,.25", *STEEL_SI, *boundary]
    )
    result = fem.from_nastran(path, units="SI", n_modes=6)
    np.testing.assert_allclose(result.freq_hz, 2 * simply_supported.freq_hz, rtol=1e-9)


def test_case_control_selects_the_spc_set_and_include(tmp_path, simply_supported):
    nodes, quads, edge = rectangle()
    mesh_deck = meshio_deck(tmp_path / "mesh.bdf", nodes, "quad", quads, [])
    # meshio's file as an include: its BEGIN BULK is skipped, its ENDDATA would end the deck
    grids = [line for line in mesh_deck.read_text().splitlines() if line != "ENDDATA"]
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "plate.bdf").write_text("\n".join(grids) + "\n")
    two_sides = np.flatnonzero(np.isclose(nodes[:, 0], 0) | np.isclose(nodes[:, 0], WIDTH)) + 1
    lines = [
        "SOL 103",
        "CEND",
        "SUBCASE 1",
        "  SPC = 2",
        "  METHOD = 1",
        "BEGIN BULK",
        "INCLUDE 'parts/plate.bdf'",
        "EIGRL,1,,,6",
        *STEEL_SI,
        *spc1_cards(two_sides, sid=1),
        *spc1_cards(np.flatnonzero(edge) + 1, sid=2),
        "ENDDATA",
    ]
    deck = tmp_path / "job.dat"
    deck.write_text("\n".join(lines) + "\n")
    result = fem.from_nastran(deck, units="SI", n_modes=6)
    np.testing.assert_allclose(result.freq_hz, simply_supported.freq_hz, rtol=1e-6)
    derived = result.provenance["derived"]
    assert (derived["spc_set"], derived["spc_set_reason"]) == (2, "selected by case control")
    assert derived["ignored_cards"] == {"EIGRL": 1}
    assert result.provenance["input"]["included"][0]["path"].endswith("plate.bdf")
    # set 1 holds two opposite sides only: a softer plate (Levy's case), chosen by spc_id
    levy = fem.from_nastran(deck, units="SI", n_modes=2, spc_id=1)
    assert levy.provenance["derived"]["held_grids"] == 18
    assert levy.freq_hz[0] < simply_supported.freq_hz[0]


def test_hand_formatted_small_deck_gives_our_plate(tmp_path):
    # the 12-grid deck of test_fem_bdf (executive and case control, comments, continuations)
    deck = tmp_path / "small.bdf"
    deck.write_text(SMALL)
    result = fem.from_nastran(deck, units="SI", n_modes=4)
    part = fem.rectangular_plate(WIDTH, HEIGHT, mesh_size=0.2)
    reference = fem.modal_analysis(part, [fem.SimplySupportedEdge("all")], n_modes=4)
    np.testing.assert_allclose(result.freq_hz, reference.freq_hz, rtol=1e-6)
    assert result.provenance["derived"]["ignored_cards"] == {"EIGRL": 1, "PARAM": 1}
    # GRDSET PS 6 on every grid: drilling, not a DOF of the plate; changes nothing
    deck.write_text(SMALL.replace("PARAM   POST    -1", "GRDSET" + " " * 50 + "6"))
    drilling = fem.from_nastran(deck, units="SI", n_modes=4)
    np.testing.assert_allclose(drilling.freq_hz, reference.freq_hz, rtol=1e-6)
    assert drilling.provenance["derived"]["constraints_without_effect"] == 2  # grids 5, 8


def test_curved_deck_is_our_shell(tmp_path):
    nodes, quads = meshing.grid_quads(np.linspace(0, 0.4, 9), np.linspace(0, 0.3, 7))
    sag = 0.5 - np.sqrt(0.5**2 - (nodes[:, 0] - 0.2) ** 2)  # a cylinder of radius 0.5 m
    xyz = np.column_stack([nodes, sag])
    meshio.write(tmp_path / "panel.vtu", meshio.Mesh(xyz, [("quad", quads)]))
    corners = [0, 6, 56, 62]
    part = fem.read_mesh(tmp_path / "panel.vtu", 1e-3, "steel")
    reference = fem.modal_analysis(part, [fem.PointSupport(*nodes[i]) for i in corners], n_modes=6)
    pins = "SPC1,1,123," + ",".join(str(i + 1) for i in corners)
    deck = meshio_deck(tmp_path / "panel.bdf", xyz, "quad", quads, [*STEEL_SI, pins])
    result = fem.from_nastran(deck, units="SI", n_modes=6)
    assert result.part.element == part.element == "shell"
    # the deck's 12-digit coordinates differ from the mesh file's by ~1e-13 m: the same model
    np.testing.assert_allclose(result.freq_hz, reference.freq_hz, rtol=1e-6)
    # the thin solid on request: the same as the mesh file's thin solid. The extruded 1 mm
    # layer's normals move by ~1e-12 with the coordinates; the thin solid's conditioning
    # makes that 2e-8 in the frequencies (measured)
    solid = fem.from_nastran(deck, units="SI", n_modes=6, element="hex2")
    hex2 = fem.read_mesh(tmp_path / "panel.vtu", 1e-3, "steel", element="hex2")
    pins = [fem.PointSupport(*nodes[i]) for i in corners]
    np.testing.assert_allclose(
        solid.freq_hz, fem.modal_analysis(hex2, pins, n_modes=6).freq_hz, rtol=1e-6
    )


def test_deck_errors_are_named(tmp_path):
    nodes, quads = meshing.grid_quads(np.linspace(0, 0.3, 4), np.linspace(0, 0.2, 3))
    free = meshio_deck(tmp_path / "free.bdf", nodes, "quad", quads, STEEL_SI)
    with pytest.raises(InputError, match="does not state its unit system"):
        fem.from_nastran(free)
    with pytest.raises(InputError, match=r"no SPC and no cups .* allow_rigid_modes=True"):
        fem.from_nastran(free, units="SI")
    sets = meshio_deck(
        tmp_path / "s.bdf", nodes, "quad", quads, [*STEEL_SI, "SPC1,1,3,1", "SPC1,2,3,2"]
    )
    with pytest.raises(InputError, match=r"the deck has SPC sets \[1, 2\]; choose one"):
        fem.from_nastran(sets, units="SI")
    plies = meshio_deck(
        tmp_path / "p.bdf", nodes, "quad", quads, ["PCOMP,1", "MAT1,1,2.1+11,,.3,7850."]
    )
    with pytest.raises(
        InputError, match=r"PCOMP 1 \(p\.bdf line \d+, row 2 field 2 MID1\): required"
    ):
        fem.from_nastran(plies, units="SI")
    other = meshio_deck(tmp_path / "o.bdf", nodes, "quad", quads, ["PSHEAR,1,1,1.-3", STEEL_SI[1]])
    with pytest.raises(InputError, match=r"CQUAD4 1 \(o\.bdf line \d+, field 3 PID\): property 1 "
                       r"is a PSHEAR; CQUAD4 takes PSHELL, PCOMP, PCOMPG"):  # fmt: skip
        fem.from_nastran(other, units="SI")
    with pytest.raises(InputError, match="does not exist"):
        fem.from_nastran(tmp_path / "none.bdf", units="SI")
    static = meshio_deck(tmp_path / "st.bdf", nodes, "quad", quads,
                         [STEEL_SI[0], "MAT1,1,2.1+11,,.3", "SPC1,1,123,1,4,9"])  # fmt: skip
    with pytest.raises(InputError, match=r"no mass: RHO is blank or 0 on MAT1 1 .* static deck"):
        fem.from_nastran(static, units="SI")


def test_refusals_name_each_card_with_its_share_of_the_mass(tmp_path):
    # the plate (0.3 x 0.2 m x 1 mm steel: 0.471 kg) and a steel pyramid of CPYRAM on it (base
    # 0.1 x 0.1 m, 60 mm high: 1.57 kg): it holds 1.57 / (1.57 + 0.471) = 76.9 % of the mass
    nodes, quads = meshing.grid_quads(np.linspace(0, 0.3, 4), np.linspace(0, 0.2, 3))
    corners = [(0, 0, 0), (0.1, 0, 0), (0.1, 0.1, 0), (0, 0.1, 0), (0.05, 0.05, 0.06)]
    block = [f"GRID,{900 + k},,{x},{y},{z}" for k, (x, y, z) in enumerate(corners)]
    block += ["CPYRAM,500,5,900,901,902,903,904", "PSOLID,5,1", "CSEAM,600,,1,2"]
    path = meshio_deck(tmp_path / "b.bdf", nodes, "quad", quads, [*STEEL_SI, *block])
    with pytest.raises(InputError) as refused:
        fem.from_nastran(path, units="SI")
    message = str(refused.value)
    pyramid = 7850 * 0.1 * 0.1 * 0.06 / 3
    share = pyramid / (pyramid + 7850 * 1e-3 * 0.3 * 0.2)
    assert f"CPYRAM (1, {100 * share:.3g} % of the mass; first b.bdf line" in message
    assert "CSEAM (1, no mass;" in message
    assert "jaxflex model --from-modes FILE" in message
    # a card our element set has but a model option refuses: named before the work
    mass = meshio_deck(tmp_path / "m.bdf", nodes, "quad", quads, [*STEEL_SI, "CONM2,7,1,,1.",
                                                                   "SPC1,1,123,1,4,9"])  # fmt: skip
    with pytest.raises(InputError, match=r"element: 'morley' takes a deck of one isotropic "
                       r"sheet; this one has CONM2 \(1\)"):  # fmt: skip
        fem.from_nastran(mass, units="SI", element="morley")


def test_free_free_deck_and_the_warnings_of_a_thick_part(tmp_path):
    # a free 0.3 x 0.2 m plate 25 mm thick (1/8 of its span): with allow_rigid_modes its six
    # rigid-body modes are reported, not modelled, and its elastic modes are the mesh door's
    # (fem.read_mesh of the same quads with the shell: the same model, 1e-9); the door warns
    # about the thickness (as the mesh door) and notes the Kirchhoff element
    # (fem.imports.nastran.thick: about 5 % for 1/8)
    nodes, quads = meshing.grid_quads(np.linspace(0, 0.3, 7), np.linspace(0, 0.2, 5))
    cards = ["PSHELL,1,1,.025,1", STEEL_SI[1]]
    path = meshio_deck(tmp_path / "thick.bdf", nodes, "quad", quads, cards)
    with pytest.raises(InputError, match=r"leave \d rigid-body mode.*allow_rigid_modes=True"):
        fem.from_nastran(path, units="SI", element="shell", n_modes=4)
    with pytest.warns(PartWarning) as caught:
        result = fem.from_nastran(path, units="SI", element="shell", n_modes=4,
                                  allow_rigid_modes=True)  # fmt: skip
    messages = " ".join(str(w.message) for w in caught)
    assert "thickness 0.025 m is 1/8 of the part's span 0.2 m" in messages
    assert "Kirchhoff" in messages and "about 5.2 % lower" in messages
    assert result.rigid_freq_hz.size == 6 and "rigid-body modes kept out" in result.summary()
    mesh_file = tmp_path / "thick.vtu"
    meshio.write(mesh_file, meshio.Mesh(np.column_stack([nodes, np.zeros(len(nodes))]),
                                        [("quad", quads)]))  # fmt: skip
    with pytest.warns(PartWarning):
        part = fem.read_mesh(mesh_file, 0.025, "steel", element="shell")
    reference = fem.modal_analysis(part, [], n_modes=4, allow_rigid_modes=True)
    np.testing.assert_allclose(result.freq_hz, reference.freq_hz, rtol=1e-9)
    assert fem.from_nastran.__doc__ and kirchhoff_excess(1 / 8, 1.0, 0.3) == pytest.approx(
        0.052, abs=5e-4
    )


def test_the_command_prints_the_door_warnings(tmp_path, capsys):
    # jaxflex model --from-nastran prints the part's warnings as the mesh door does
    nodes, quads = meshing.grid_quads(np.linspace(0, 0.3, 4), np.linspace(0, 0.2, 3))
    path = meshio_deck(tmp_path / "t.bdf", nodes, "quad", quads, ["PSHELL,1,1,.025,1", STEEL_SI[1]])
    args = ["model", "--from-nastran", str(path), "--units", "SI", "--allow-rigid-modes"]
    assert main([*args, "--n-modes", "2", "--quiet", "-o", str(tmp_path / "t.npz")]) == 0
    err = capsys.readouterr().err
    assert "warning: t.bdf: thickness 0.025 m is 1/8 of the part's span" in err
    assert "warning: t.bdf: thickness/span 1/8: the 'morley' element is Kirchhoff" in err


def same_up_to_mode_signs(got, want, name):
    """Maps (Y, M) per mode agree up to each mode's sign (a symmetric part's modes have
    peaks of equal size: which one decides the sign hangs on round-off), to 1e-6 of the
    largest entry; (Y, 3) maps per base acceleration agree as they are."""
    got, want = np.asarray(got), np.asarray(want)
    if name != "a_map":
        got = got * np.sign(np.sum(got * want, axis=0))
    np.testing.assert_allclose(got, want, atol=1e-6 * np.abs(want).max(), err_msg=name)


def test_deck_model_outputs_are_the_mesh_doors(tmp_path):
    # the curved panel with four cups (rigid, and compliant "flat" ones): the deck model's cup
    # reactions and surface stresses are those of fem.read_mesh's shell of the same quads
    # (the same model)
    nodes, quads = meshing.grid_quads(np.linspace(0, 0.4, 9), np.linspace(0, 0.3, 7))
    sag = 0.5 - np.sqrt(0.5**2 - (nodes[:, 0] - 0.2) ** 2)
    xyz = np.column_stack([nodes, sag])
    meshio.write(tmp_path / "panel.vtu", meshio.Mesh(xyz, [("quad", quads)]))
    part = fem.read_mesh(tmp_path / "panel.vtu", 1e-3, "steel")
    deck = meshio_deck(tmp_path / "panel.bdf", xyz, "quad", quads, STEEL_SI)
    for stiffness in (None, "flat"):
        cups = [fem.SuctionCup(x, y, 0.03, stiffness=stiffness)
                for x in (0.1, 0.3) for y in (0.1, 0.2)]  # fmt: skip
        ours = fem.from_nastran(deck, units="SI", cups=cups, n_modes=6).to_modal_model(50)
        theirs = fem.modal_analysis(part, cups, n_modes=6).to_modal_model(50)
        np.testing.assert_allclose(ours.freq_hz, theirs.freq_hz, rtol=1e-6)
        for name in ("q_map", "v_map", "a_map"):
            same_up_to_mode_signs(
                getattr(ours.cups.reaction, name), getattr(theirs.cups.reaction, name), name
            )
        # stresses at the same points (the facets come in another order)
        order = [np.lexsort(np.asarray(m.stress.points_m).T) for m in (ours, theirs)]
        rows = [(6 * o[:, None] + np.arange(6)).ravel() for o in order]
        for name in ("q_map", "a_map"):
            got, want = (np.asarray(getattr(m.stress.stress, name))[r]
                         for m, r in zip((ours, theirs), rows, strict=True))  # fmt: skip
            same_up_to_mode_signs(got, want, name)


def test_heat_transfer_deck_is_refused_by_its_solution(tmp_path):
    # a SOL 153 deck (its PSHELL of a MAT4) is no structure to vibrate: refused by what it is
    nodes, quads = meshing.grid_quads(np.linspace(0, 0.3, 4), np.linspace(0, 0.2, 3))
    deck = meshio_deck(tmp_path / "h.bdf", nodes, "quad", quads, ["PSHELL,1,1,.001", "MAT4,1,50."])
    deck.write_text("SOL 153\nCEND\nBEGIN BULK\n" + deck.read_text())
    with pytest.raises(InputError, match=r"h.bdf is a heat-transfer analysis \(SOL 153\)"):
        fem.from_nastran(deck, units="SI")
