"""Gaps, shear panels, fasteners and spot welds of Nastran decks against closed forms.

Each deck makes the element the only flexible part of a rigid body on it: a CONM2 on a grid
(CGAP), the top edge of a panel sliding on RBE2s (CSHEAR), a second plate made rigid by an
RBE2 over a plate held everywhere (CFAST, CWELD). The frequencies follow from the element's
stiffness in closed form and the rigid body's mass (tests/decks.py); no discretisation error
enters, so the targets hold to round-off (1e-9).
"""

from __future__ import annotations

import numpy as np
import pytest
from decks import card, plate, rigid_frequencies, rigid_mass, solve, write

from jaxflex.errors import InputError

E_PA, NU = 2.1e11, 0.3
G_PA = E_PA / (2 * (1 + NU))
MASSLESS_STEEL = "MAT1,1,2.1+11,,.3"  # no RHO: the shells carry no mass
MASS = 2.0


def test_gap_is_its_initial_state_spring(tmp_path):
    # a 2 kg CONM2 on grid 2, 0.1 m from grid 1 (held) along x, joined by a CGAP; closed
    # (U0 <= 0): axial KA and transverse KT in both other directions; open: KB alone
    ka, kb, kt = 4e6, 1e3, 2e6
    for u0, expected in ((0.0, (ka, kt, kt)), (0.01, (kb,))):
        lines = [
            card("GRID", 1, None, 0.0, 0.0, 0.0, None, "123456"),
            card("GRID", 2, None, 0.1, 0.0, 0.0, None, "456"),
            card("CONM2", 5, 2, None, MASS),
            card("CGAP", 7, 8, 1, 2, 0.0, 1.0, 0.0),
            card("PGAP", 8, u0, None, ka, kb, kt),
        ]
        if u0 > 0:  # open: nothing holds y and z, hold them
            lines[1] = card("GRID", 2, None, 0.1, 0.0, 0.0, None, "23456")
        # the deck has no shell; a shell far away (held) carries the door's part
        lines += [*plate(1, 1, 0.1, 0.1, first=10, eid=10, z=1.0)[0], "PSHELL,1,1,.001,1",
                  "MAT1,1,2.1+11,,.3,7850.", card("SPC1", 1, 123456, 10, "THRU", 13)]  # fmt: skip
        result = solve(write(tmp_path / "g.bdf", lines), n_modes=len(expected))
        exact = np.sort(np.sqrt(np.array(expected) / MASS)) / (2 * np.pi)
        np.testing.assert_allclose(result.freq_hz[: len(exact)], exact, rtol=1e-9)


def test_bush1d_is_an_axial_spring_with_its_mass_on_its_ends(tmp_path):
    # a 2 kg CONM2 on grid 2, joined to grid 1 (held) by a CBUSH1D along (1, 1, 0) / sqrt(2),
    # K = 5e5 N/m, M = 1 kg; grid 2 moves along the axis only (its displacement system CD 3
    # has x along it, the other components held): f = sqrt(K / (2 + 1 / 2)) / (2 pi)
    k, m = 5e5, 1.0
    lines = [
        card("CORD2R", 3, None, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0),
        card("GRID", 1, None, 0.0, 0.0, 0.0, None, "123456"),
        card("GRID", 2, None, 0.1, 0.1, 0.0, 3, "23456"),
        card("CONM2", 5, 2, None, MASS),
        card("CBUSH1D", 7, 8, 1, 2),
        card("PBUSH1D", 8, k, None, m),
        *plate(1, 1, 0.1, 0.1, first=10, eid=10, z=1.0)[0],
        "PSHELL,1,1,.001,1",
        "MAT1,1,2.1+11,,.3,7850.",
        card("SPC1", 1, 123456, 10, "THRU", 13),
    ]
    result = solve(write(tmp_path / "b.bdf", lines), n_modes=1)
    assert result.freq_hz[0] == pytest.approx(np.sqrt(k / (MASS + m / 2)) / (2 * np.pi), rel=1e-9)


@pytest.mark.parametrize("skew", [0.0, 0.3])
def test_shear_panel_is_its_constant_shear_flow(tmp_path, skew):
    # a panel of base a = 0.2 m and height h = 0.1 m (a parallelogram when skewed), 1 mm,
    # its bottom edge held and its top edge sliding along x as one (an RBE2 ties grid 4's x to
    # grid 3's), a CONM2 of 2 kg on grid 3: k = G t a / h, the mass the CONM2 plus the top
    # corners' lumped quarters (rho t a h / 2)
    a, h, t, rho = 0.2, 0.1, 1e-3, 7850.0
    lines = [
        card("GRID", 1, None, 0.0, 0.0, 0.0, None, "123456"),
        card("GRID", 2, None, a, 0.0, 0.0, None, "123456"),
        card("GRID", 3, None, a + skew * h, h, 0.0, None, "23456"),
        card("GRID", 4, None, skew * h, h, 0.0, None, "23456"),
        card("CSHEAR", 9, 9, 1, 2, 3, 4),
        card("PSHEAR", 9, 1, t),
        f"MAT1,1,2.1+11,,.3,{rho!r}",
        card("RBE2", 20, 3, 1, 4),
        card("CONM2", 21, 3, None, MASS),
        *plate(1, 1, 0.1, 0.1, first=10, eid=10, z=1.0)[0],
        "PSHELL,1,1,.001,1",
        card("SPC1", 1, 123456, 10, "THRU", 13),
    ]
    result = solve(write(tmp_path / "s.bdf", lines), n_modes=1)
    k = G_PA * t * a / h
    m = MASS + rho * t * a * h / 2
    assert result.freq_hz[0] == pytest.approx(np.sqrt(k / m) / (2 * np.pi), rel=1e-9)
    assert result.provenance["derived"]["elements"]["CSHEAR"] == 1


def two_plates(connector: list[str], gap: float) -> tuple[list[str], np.ndarray]:
    """Plate A (0.2 m square, 2 x 2 CQUAD4 of PSHELL 1, held everywhere) and plate B ``gap``
    above it (PSHELL 2, massless), made rigid by an RBE2 to its centre grid 100, where a
    CONM2 sits; ``connector`` joins them (cards). Returns the lines and B's mass matrix
    about grid 100."""
    a_lines = plate(2, 2, 0.2, 0.2)[0]
    b_lines, b_ids, _ = plate(2, 2, 0.2, 0.2, first=101, eid=101, pid=2, z=gap)
    inertia = np.diag([1e-3, 2e-3, 3e-3])
    centre = np.array([0.1, 0.1, gap])
    lines = [
        *a_lines,
        *b_lines,
        "PSHELL,1,1,.001,1",
        "PSHELL,2,1,.001,1",
        MASSLESS_STEEL,
        card("SPC1", 1, 123456, 1, "THRU", 9),
        card("GRID", 100, None, *map(float, centre)),
        card("RBE2", 90, 100, 123456, *(int(g) for g in b_ids.ravel())),
        card("CONM2", 92, 100, None, MASS, None, None, None, None, 1e-3, None, 2e-3, None,
             None, 3e-3),
        *connector,
    ]  # fmt: skip
    return lines, rigid_mass(MASS, inertia, np.zeros(3))


def arm(stiffness: np.ndarray, point: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """(6, 6) a stiffness at ``point`` seen from a rigid body's reference ``centre``."""
    t = np.eye(6)
    x, y, z = point - centre
    t[:3, 3:] = -np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return t.T @ stiffness @ t


def test_fastener_between_property_patches(tmp_path):
    # a CFAST at GS (0.07, 0.13) between the plates 10 mm apart: six springs (PFAST, axes of
    # the fastener: x along the normal, y and z alike) at the middle of the two piercing
    # points, rigidly to both; plate A held, plate B rigid: its modes are those of a rigid
    # body on the springs
    gap = 0.01
    k = np.array([3e6, 1e6, 1e6, 40.0, 20.0, 20.0])
    connector = [
        card("GRID", 500, None, 0.07, 0.13, gap / 2),
        card("CFAST", 300, 31, "PROP", 1, 2, 500),
        card("PFAST", 31, 0.005, None, None, *k[:4]),
        "+," + ",".join(repr(float(v)) for v in k[4:]),
    ]
    lines, mass = two_plates(connector, gap)
    result = solve(write(tmp_path / "f.bdf", lines), n_modes=6)
    # fastener axes: x = basic z (normal), y and z any pair normal to it (KT2 = KT3)
    axes = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    turn = np.kron(np.eye(2), axes)
    local = turn.T @ np.diag(k) @ turn
    stiffness = arm(local, np.array([0.07, 0.13, gap / 2]), np.array([0.1, 0.1, gap]))
    np.testing.assert_allclose(result.freq_hz, rigid_frequencies(stiffness, mass), rtol=1e-9)


def test_spot_weld_is_a_round_beam_of_the_effective_length(tmp_path):
    # a CWELD (ELPAT, TYPE SPOT) at GS between the plates 10 mm apart, 1 mm sheets: a
    # Timoshenko round beam (D 6 mm, shear factor 0.9) of the effective length (tA + tB) / 2 =
    # 1 mm, centred between the piercing points; plate A held: its tip stiffness at the
    # beam's upper end, taken to grid 100, against plate B's rigid mass
    gap, diameter = 0.01, 0.006
    connector = [
        card("GRID", 500, None, 0.07, 0.13, gap / 2),
        card("CWELD", 300, 31, 500, "ELPAT", None, None, None, None, 1, 101),
        card("PWELD", 31, 1, diameter, None, None, None, None, "SPOT"),
    ]
    lines, mass = two_plates(connector, gap)
    result = solve(write(tmp_path / "w.bdf", lines), n_modes=6)
    length = 1e-3
    area, inertia = np.pi * diameter**2 / 4, np.pi * diameter**4 / 64
    phi = 12 * E_PA * inertia / (G_PA * 0.9 * area * length**2)
    bend = E_PA * inertia / (length**3 * (1 + phi))
    tip = np.zeros((6, 6))  # clamped beam along basic z, tip DOFs (u, v, w, rx, ry, rz)
    tip[2, 2], tip[5, 5] = E_PA * area / length, G_PA * 2 * inertia / length
    for u, r, sign in ((0, 4, 1), (1, 3, -1)):  # bending in xz (u, ry) and yz (v, rx)
        tip[u, u] = 12 * bend
        tip[r, r] = (4 + phi) * bend * length**2
        tip[u, r] = tip[r, u] = -sign * 6 * bend * length
    upper = np.array([0.07, 0.13, gap / 2 + length / 2])
    stiffness = arm(tip, upper, np.array([0.1, 0.1, gap]))
    np.testing.assert_allclose(result.freq_hz, rigid_frequencies(stiffness, mass), rtol=1e-9)


def test_connector_errors_are_named(tmp_path):
    connector = [
        card("GRID", 500, None, 0.07, 0.13, 0.005),
        card("CWELD", 300, 31, 500, "GRIDID", None, None, None, None, 1, 101),
        card("PWELD", 31, 1, 0.006),
    ]
    lines, _ = two_plates(connector, 0.01)
    with pytest.raises(InputError, match=r"CWELD 300 .*field 5 TYPE.*'GRIDID'; read: ELPAT"):
        solve(write(tmp_path / "e.bdf", lines), n_modes=2)
    connector[1] = card("CFAST", 300, 31, "PROP", 1, 2, 500)
    connector[2] = card("PFAST", 31, 0.005, None, None, 1e6, 2e6, 1e6, 1.0)
    lines, _ = two_plates(connector, 0.01)
    with pytest.raises(InputError, match=r"PFAST 31 .*MCID.*KT2 != KT3"):
        solve(write(tmp_path / "e.bdf", lines), n_modes=2)
    connector[1] = card("CFAST", 300, 31, "PROP", 1, 7, 500)
    lines, _ = two_plates(connector, 0.01)
    with pytest.raises(InputError, match=r"CFAST 300 .*field 6 IDB\): no shell of property 7"):
        solve(write(tmp_path / "e.bdf", lines), n_modes=2)
