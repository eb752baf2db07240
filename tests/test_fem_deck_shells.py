"""Shell properties of Nastran decks (PSHELL variants, PCOMP, PCOMPG, MAT2, MAT8, corner
thicknesses, offsets) against the same plate written another way.

A flat steel plate 0.4 x 0.3 m, 1 mm, 8 x 6 CQUAD4, held at its four corner grids. Flat,
its membrane and bending decouple: a membrane-only section is the full one with 3, 4, 5
held at every grid, a bending-only one the full one with 1, 2, 6 held (AUTOSPC holds the
components without stiffness, as Nastran does). Each pair is the same finite-element model,
so the targets hold to round-off (1e-9).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from decks import E_PA, NU, RHO, STEEL, card, plate, solve, write

import fem
from fem.sanity import PartWarning

WIDTH, HEIGHT, T = 0.4, 0.3, 1e-3


def plate_deck(path, properties, extra=(), held_everywhere=None, quad_fields=None):
    """The plate with ``properties`` (cards of PID 1 and its materials), corners held in
    123 (and ``held_everywhere`` components at every grid); ``quad_fields``: text appended
    to every CQUAD4 (its fields after G4: THETA/MCID, ZOFFS, continuation)."""
    lines, ids, _ = plate(8, 6, WIDTH, HEIGHT)
    corners = [int(ids[j, i]) for j in (0, -1) for i in (0, -1)]
    held = [card("SPC1", 1, 123, *corners)]
    if held_everywhere:
        held.append(card("SPC1", 1, held_everywhere, int(ids.min()), "THRU", int(ids.max())))
    if quad_fields is not None:
        lines = [line + quad_fields if line.startswith("CQUAD4") else line for line in lines]
    return write(path, [*lines, *properties, *held, *extra])


def frequencies(path, n_modes=6):
    return solve(path, n_modes=n_modes, element="shell").freq_hz


PSHELL = card("PSHELL", 1, 1, T, 1, None, None, None, None)


def test_membrane_only_and_bending_only_sections(tmp_path):
    membrane = card("PSHELL", 1, 1, T)  # MID2 blank: no bending
    bending = card("PSHELL", 1, None, T, 1)  # MID1 blank: no membrane
    pairs = {
        "membrane": (membrane, PSHELL, 345),
        "bending": (bending, PSHELL, 126),
    }
    for name, (section, full, held) in pairs.items():
        alone = frequencies(plate_deck(tmp_path / f"{name}.bdf", [section, STEEL]))
        reference = frequencies(
            plate_deck(tmp_path / "ref.bdf", [full, STEEL], held_everywhere=held)
        )
        np.testing.assert_allclose(alone, reference, rtol=1e-9, err_msg=name)
    # 12I/T^3 = 2 doubles the bending stiffness, not the mass: sqrt(2) on every frequency
    stiffer = card("PSHELL", 1, None, T, 1, 2.0)
    doubled = frequencies(plate_deck(tmp_path / "d.bdf", [stiffer, STEEL]))
    single = frequencies(plate_deck(tmp_path / "s.bdf", [bending, STEEL]))
    np.testing.assert_allclose(doubled, np.sqrt(2) * single, rtol=1e-9)


def test_membrane_and_bending_materials_and_nsm(tmp_path):
    # MID1 steel, MID2 aluminium: the bending modes are an aluminium plate's stiffness with
    # steel's mass (the mass comes from MID1): the same as one material of E_al, NU_al,
    # RHO_steel held in 1, 2, 6
    aluminium = "MAT1,2,7.0+10,,.33,2700."
    mixed = [card("PSHELL", 1, 1, T, 2), STEEL, aluminium]
    equivalent = [PSHELL, "MAT1,1,7.0+10,,.33,7850."]
    got = frequencies(plate_deck(tmp_path / "m.bdf", mixed, held_everywhere=126))
    expected = frequencies(plate_deck(tmp_path / "e.bdf", equivalent, held_everywhere=126))
    np.testing.assert_allclose(got, expected, rtol=1e-9)
    # NSM: mass per area added to the sheet's (RHO T + NSM) A
    nsm = card("PSHELL", 1, 1, T, 1, None, None, None, 2.0)
    result = solve(plate_deck(tmp_path / "n.bdf", [nsm, STEEL]), n_modes=2, element="shell")
    assert result.mass_kg == pytest.approx((RHO * T + 2.0) * WIDTH * HEIGHT, rel=1e-12)


def test_laminates_and_anisotropic_materials_that_are_isotropic(tmp_path):
    # classical lamination theory of plies of one isotropic material is the homogeneous
    # sheet: A = Q t, B = 0, D = Q t^3 / 12; MAT8 with E1 = E2, G12 = E / (2 (1 + NU)) and
    # MAT2 with the plane-stress matrix are MAT1; SYM lists half the plies
    reference = frequencies(plate_deck(tmp_path / "ref.bdf", [PSHELL, STEEL]))
    q = E_PA / (1 - NU**2)
    g = E_PA / (2 * (1 + NU))
    mat8 = card("MAT8", 1, E_PA, E_PA, NU, g, None, None, RHO)
    mat2 = card("MAT2", 1, q, NU * q, 0.0, q, 0.0, g, RHO)
    plies = [card("PCOMP", 1, None, None, None, None, None, None, None,
                  1, T / 4, 0.0, None, 1, T / 4, 45.0, None,
                  1, T / 4, -45.0, None, 1, T / 4, 90.0, None)]  # fmt: skip
    sym = [card("PCOMP", 1, None, None, None, None, None, None, "SYM",
                1, T / 4, 0.0, None, 1, T / 4, 30.0, None)]  # fmt: skip
    pcompg = [card("PCOMPG", 1, None, None, None, None, None, None, None,
                   11, 1, T / 2, 0.0, None, None, None, None,
                   12, 1, T / 2, 60.0)]  # fmt: skip
    cases = {
        "PCOMP": [*plies, STEEL],
        "PCOMP SYM": [*sym, STEEL],
        "PCOMPG": [*pcompg, STEEL],
        "MAT8": [PSHELL, mat8],
        "MAT2": [PSHELL, mat2],
    }
    for name, cards in cases.items():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", PartWarning)
            result = fem.from_nastran(plate_deck(tmp_path / "c.bdf", cards), units="SI",
                                      n_modes=6, element="shell", progress=False)  # fmt: skip
        np.testing.assert_allclose(result.freq_hz, reference, rtol=1e-9, err_msg=name)
        laminate = any("classical lamination theory" in str(w.message) for w in caught)
        assert laminate == name.startswith("PCOMP"), name  # the equivalent shell is said


def test_orthotropic_plies_turn_with_their_angles(tmp_path):
    # an orthotropic ply at 90 degrees is the ply with E1 and E2 swapped at 0 (NU21 for
    # NU12); the element's THETA and a material system MCID turn it the same way
    e1, e2, nu12, g12 = 1.4e11, 1.0e10, 0.3, 5.0e9
    nu21 = nu12 * e2 / e1

    def ply(theta):
        return card("PCOMP", 1, None, None, None, None, None, None, None, 1, T, theta)

    along = [card("MAT8", 1, e1, e2, nu12, g12, None, None, 1600.0)]
    across = [card("MAT8", 1, e2, e1, nu21, g12, None, None, 1600.0)]
    expected = frequencies(plate_deck(tmp_path / "a.bdf", [ply(0.0), *across]))
    got = frequencies(plate_deck(tmp_path / "b.bdf", [ply(90.0), *along]))
    np.testing.assert_allclose(got, expected, rtol=1e-9)
    # THETA = 90 on every CQUAD4 (field 8), or MCID = 5, a system turned by 90 degrees
    theta = plate_deck(tmp_path / "t.bdf", [ply(0.0), *along], quad_fields=",90.0")
    np.testing.assert_allclose(frequencies(theta), expected, rtol=1e-9)
    system = card("CORD2R", 5, None, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0)
    mcid = plate_deck(tmp_path / "m.bdf", [ply(0.0), *along, system], quad_fields=",5")
    np.testing.assert_allclose(frequencies(mcid), expected, rtol=1e-9)


def test_corner_thicknesses(tmp_path):
    # T1..T4 equal to the PSHELL's T, or TFLAG = 1 with ratios 0.5 of a doubled T: the
    # same plate; a thickness linear in x: the mass is rho int t dA exactly
    reference = frequencies(plate_deck(tmp_path / "r.bdf", [PSHELL, STEEL]))
    given = ",,,\n+,,0," + ",".join([repr(T)] * 4)
    same = frequencies(plate_deck(tmp_path / "g.bdf", [PSHELL, STEEL], quad_fields=given))
    np.testing.assert_allclose(same, reference, rtol=1e-9)
    doubled = card("PSHELL", 1, 1, 2 * T, 1)
    ratios = ",,,\n+,,1,0.5,0.5,0.5,0.5"
    np.testing.assert_allclose(
        frequencies(plate_deck(tmp_path / "f.bdf", [doubled, STEEL], quad_fields=ratios)),
        reference,
        rtol=1e-9,
    )
    lines, _, xyz = plate(8, 6, WIDTH, HEIGHT)
    slope = 2e-3  # t = 1 mm + 2e-3 x
    out = []
    for line in lines:
        if line.startswith("CQUAD4"):
            grids = [int(v) for v in line.split(",")[3:7]]
            ts = [T + slope * float(xyz.reshape(-1, 3)[g - 1, 0]) for g in grids]
            line += ",,,\n+,,0," + ",".join(repr(t) for t in ts)
        out.append(line)
    deck = write(tmp_path / "v.bdf", [*out, PSHELL, STEEL, card("SPC1", 1, 123, 1, 9, 55, 63)])
    result = solve(deck, n_modes=2, element="shell")
    exact = RHO * HEIGHT * (T * WIDTH + slope * WIDTH**2 / 2)
    assert result.mass_kg == pytest.approx(exact, rel=1e-12)


def test_offset_is_the_sheet_beside_its_grids(tmp_path):
    # ZOFFS 5 mm on every element vs the sheet on grids 5 mm above, each tied to its grid by
    # an RBE2: the same model
    zoffs = ",0.,0.005"  # THETA 0, ZOFFS 5 mm
    offset = frequencies(plate_deck(tmp_path / "o.bdf", [PSHELL, STEEL], quad_fields=zoffs), 8)
    lines, _, _ = plate(8, 6, WIDTH, HEIGHT, first=1001, eid=1001, z=0.005)
    base, base_ids, _ = plate(8, 6, WIDTH, HEIGHT)
    grids = [line for line in base if line.startswith("GRID")]
    links = [card("RBE2", 5000 + g, int(g), 123456, int(g) + 1000) for g in base_ids.ravel()]
    corners = [int(base_ids[j, i]) for j in (0, -1) for i in (0, -1)]
    deck = write(tmp_path / "b.bdf", [*grids, *lines, *links, PSHELL, STEEL,
                                      card("SPC1", 1, 123, *corners)])  # fmt: skip
    np.testing.assert_allclose(offset, frequencies(deck, 8), rtol=1e-9)


def test_held_drilling_rotations_are_left_free_as_nastran_does(tmp_path):
    # an in-plane cantilever strip 1 m x 50 mm x 1 mm (40 x 2 CQUAD4), clamped at x = 0, out of
    # plane held everywhere (GRDSET 345) and with it the drilling rotation (GRDSET 3456), as
    # decks hold it for Nastran's CQUAD4, which has no stiffness there. Our membrane (OPT)
    # uses that rotation: held, it locked the strip's in-plane bending (its first mode 5.2
    # times Euler-Bernoulli's); left free, both decks are the same model and the first mode is
    # Euler-Bernoulli's (L / h = 20: shear and the mesh 0.5 % below it, measured)
    length, depth = 1.0, 0.05
    lines, ids, _ = plate(40, 2, length, depth)
    clamp = card("SPC1", 1, 123456, *(int(g) for g in ids[:, 0]))
    found = {}
    for held in ("345", "3456"):
        deck = write(tmp_path / f"{held}.bdf", [card("GRDSET", *[None] * 6, held), *lines,
                                                 PSHELL, STEEL, clamp])  # fmt: skip
        found[held] = solve(deck, n_modes=2, element="shell")
    np.testing.assert_allclose(found["3456"].freq_hz, found["345"].freq_hz, rtol=1e-9)
    assert found["3456"].provenance["derived"]["held_drilling_rotations_left_free"] == ids.size
    inertia, area = T * depth**3 / 12, T * depth
    euler = 1.875104**2 / (2 * np.pi) * np.sqrt(E_PA * inertia / (RHO * area * length**4))
    assert found["3456"].freq_hz[0] == pytest.approx(euler, rel=0.01)
    # CQUADR has a drilling stiffness in Nastran: its holds stay
    quadr = [line.replace("CQUAD4", "CQUADR") for line in lines]
    deck = write(tmp_path / "r.bdf", [card("GRDSET", *[None] * 6, "3456"), *quadr, PSHELL,
                                      STEEL, clamp])  # fmt: skip
    kept = solve(deck, n_modes=2, element="shell")
    assert kept.provenance["derived"]["held_drilling_rotations_left_free"] == 0
