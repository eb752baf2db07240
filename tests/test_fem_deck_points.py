"""Masses, springs, bushings and rigid elements of Nastran decks against closed forms.

The part: a 0.2 m square steel plate (2 mm, 2 x 2 CQUAD4) made rigid by an RBE2 to grid 100
above its centre, where a CONM2 sits and springs (CELAS1/2 or a CBUSH) hold it to the
ground. Every grid moves rigidly with grid 100, so the model is a rigid body on springs:
its six frequencies follow from K x = w^2 M x with M the plate's rigid-body mass (our
shell's consistent mass is exact for rigid motions: translations rho t A, rotations rho t
(second moments) plus its rotary inertia rho t^3 / 12 per area on every rotation) plus the
CONM2's, both taken to grid 100 in closed form (tests/decks.py). No discretisation error
enters: the targets hold to round-off (1e-9 is used).
"""

from __future__ import annotations

import numpy as np
import pytest
from decks import (
    RHO,
    STEEL,
    card,
    mpc,
    plate,
    rigid_frequencies,
    rigid_mass,
    skew,
    solve,
    write,
)

from jaxflex.errors import InputError

SIDE, T = 0.2, 2e-3
CENTRE = np.array([0.1, 0.1, 0.05])
MASS, OFFSET = 0.5, np.array([0.01, -0.02, 0.03])
# I11, I21, I22, I31, I32, I33 as the CONM2 takes them: the tensor is [[I11, -I21, -I31], ...]
CONM2_I = (1e-3, 1e-4, 2e-3, 0.0, 2e-4, 3e-3)
SPRINGS = np.array([1e4, 2e4, 3e4, 50.0, 60.0, 70.0])  # N/m, N m/rad


def conm2_inertia(values=CONM2_I) -> np.ndarray:
    i11, i21, i22, i31, i32, i33 = values
    return np.array([[i11, -i21, -i31], [-i21, i22, -i32], [-i31, -i32, i33]])


def plate_mass() -> np.ndarray:
    """The plate's rigid-body mass matrix about grid 100 (module docstring)."""
    m = RHO * T * SIDE**2
    rotary = RHO * T**3 / 12 * SIDE**2
    second = RHO * T * SIDE**4 / 12  # int y^2 dm over the square about its centre
    inertia = np.diag([second + rotary, second + rotary, 2 * second + rotary])
    return rigid_mass(m, inertia, np.array([0.1, 0.1, 0.0]) - CENTRE)


def rigid_plate(extra: list[str]) -> list[str]:
    lines, ids, _ = plate(2, 2, SIDE, SIDE)
    return [
        *lines,
        card("PSHELL", 1, 1, T, 1),
        STEEL,
        card("GRID", 100, None, *map(float, CENTRE)),
        card("RBE2", 50, 100, 123456, *map(int, ids.ravel())),
        *extra,
    ]


def conm2(cid=None, offset=OFFSET, inertia=CONM2_I) -> str:
    return card("CONM2", 60, 100, cid, MASS, *map(float, offset), None, *map(float, inertia))


def celas2() -> list[str]:
    return [card("CELAS2", 70 + c, float(k), 100, c) for c, k in enumerate(SPRINGS, start=1)]


def expected(stiffness=None) -> np.ndarray:
    mass = plate_mass() + rigid_mass(MASS, conm2_inertia(), OFFSET)
    return rigid_frequencies(np.diag(SPRINGS) if stiffness is None else stiffness, mass)


def test_conm2_celas2_rbe2_give_the_rigid_body_on_springs(tmp_path):
    result = solve(write(tmp_path / "d.bdf", rigid_plate([conm2(), *celas2()])), n_modes=6)
    np.testing.assert_allclose(result.freq_hz, expected(), rtol=1e-9)
    # the part's mass and the participation include the CONM2: the six modes of a body on
    # springs to the ground carry all of it (the supports carry none directly)
    total = RHO * T * SIDE**2 + MASS
    assert result.mass_kg == pytest.approx(total, rel=1e-12)
    np.testing.assert_allclose((result.gamma**2).sum(axis=0), total, rtol=1e-9)
    assert result.provenance["derived"]["elements"] == {
        "CQUAD4": 4, "CONM2": 1, "CELAS2": 6, "RBE2": 1,
    }  # fmt: skip


def test_conm2_in_other_systems_and_celas1(tmp_path):
    # CID -1: X is the centre of gravity in basic; CID 5: a rotated system, X and the inertia
    # along its axes (the same body in basic: X = R^T X_5, J = R^T J_5 R)
    angle = np.radians(30)
    axes = np.array([[np.cos(angle), np.sin(angle), 0], [-np.sin(angle), np.cos(angle), 0],
                     [0, 0, 1]])  # fmt: skip
    local_offset = axes @ OFFSET
    local_inertia = axes @ conm2_inertia() @ axes.T
    values = (local_inertia[0, 0], -local_inertia[1, 0], local_inertia[1, 1],
              -local_inertia[2, 0], -local_inertia[2, 1], local_inertia[2, 2])  # fmt: skip
    system = card("CORD2R", 5, None, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, *map(float, axes[0]))
    pelas = [card("PELAS", 80 + c, float(k)) for c, k in enumerate(SPRINGS, start=1)]
    celas1 = [card("CELAS1", 70 + c, 80 + c, 100, c) for c in range(1, 7)]
    for name, lines in {
        "cid-1": [conm2(-1, CENTRE + OFFSET), *celas2()],
        "cid5": [system, conm2(5, local_offset, values), *celas2()],
        "celas1": [conm2(), *pelas, *celas1],
    }.items():
        result = solve(write(tmp_path / f"{name}.bdf", rigid_plate(lines)), n_modes=6)
        np.testing.assert_allclose(result.freq_hz, expected(), rtol=1e-9, err_msg=name)


def test_cbush_grounded_and_between_grids(tmp_path):
    # six springs K1..K6 along the axes of system 7 (rotated), at a point S1..S3 (in basic,
    # OCID 0) away from grid 100: K = B^T diag(k) B, B the spring point's motion in those axes
    axes = np.linalg.qr(np.array([[1.0, 2.0, 0.5], [0.0, 1.0, 2.0], [1.0, 0.0, 1.0]]))[0].T
    arm = np.array([0.02, 0.01, -0.03])
    system = card("CORD2R", 7, None, 0.0, 0.0, 0.0, *map(float, axes[2]), *map(float, axes[0]))
    pbush = card("PBUSH", 90, "K", *map(float, SPRINGS))
    motion = np.eye(6)
    motion[:3, 3:] = -skew(arm)
    b = np.kron(np.eye(2), axes) @ motion
    stiffness = b.T @ np.diag(SPRINGS) @ b
    grounded = card("CBUSH", 91, 90, 100, None, None, None, None, 7, None, 0, *map(float, arm))
    held = card("GRID", 200, None, *map(float, CENTRE), None, 123456)
    between = card("CBUSH", 91, 90, 100, 200, None, None, None, 7, None, 0, *map(float, arm))
    for name, lines in {"grounded": [grounded], "to a held grid": [held, between]}.items():
        deck = write(tmp_path / "bush.bdf", rigid_plate([system, pbush, conm2(), *lines]))
        result = solve(deck, n_modes=6)
        np.testing.assert_allclose(result.freq_hz, expected(stiffness), rtol=1e-9, err_msg=name)


def rigid_link_mpcs(sid: int, dependent: int, independent: int, arm) -> list[str]:
    """MPC cards of u_d = u_i + theta_i x r, theta_d = theta_i (r = x_d - x_i): the RBE2's
    definition written out by hand."""
    x, y, z = arm
    rows = {  # component of the dependent grid: [(component of the independent, coefficient)]
        1: [(1, 1.0), (5, z), (6, -y)],
        2: [(2, 1.0), (6, x), (4, -z)],
        3: [(3, 1.0), (4, y), (5, -x)],
        4: [(4, 1.0)],
        5: [(5, 1.0)],
        6: [(6, 1.0)],
    }
    return [
        mpc(sid, [(dependent, comp, 1.0), *((independent, c, -a) for c, a in terms if a)])
        for comp, terms in rows.items()
    ]


def test_rbe2_rbar_and_mpc_are_the_same_rigid_link(tmp_path):
    # a plate hanging on grid 100 by an RBE2 at one corner, vs the same link as an RBAR and
    # as MPC equations written by hand; grid 100 carries the CONM2 and the springs
    lines, ids, xyz = plate(2, 2, SIDE, SIDE)
    corner = int(ids[0, 0])
    arm = xyz[0, 0] - CENTRE
    base = [*lines, card("PSHELL", 1, 1, T, 1), STEEL,
            card("GRID", 100, None, *map(float, CENTRE)), conm2(), *celas2()]  # fmt: skip
    links = {
        "RBE2": [card("RBE2", 50, 100, 123456, corner)],
        "RBAR": [card("RBAR", 50, 100, corner, 123456, None, None, 123456)],
        "MPC": rigid_link_mpcs(9, corner, 100, arm),
    }
    results = {}
    for name, link in links.items():
        executive = "SPC = 1\nMPC = 9" if name == "MPC" else "SPC = 1"
        deck = write(tmp_path / f"{name}.bdf", [*base, *link, card("SPC1", 1, 3, int(ids[2, 2]))],
                     executive)  # fmt: skip
        results[name] = solve(deck, n_modes=8, element="shell").freq_hz
    np.testing.assert_allclose(results["RBAR"], results["RBE2"], rtol=1e-9)
    np.testing.assert_allclose(results["MPC"], results["RBE2"], rtol=1e-9)


def test_rbe3_is_the_weighted_average_mpc(tmp_path):
    # reference grid 100 at the centre of four independent grids (+-a, +-a, 0), equal
    # weights, their translations: the least-squares rigid motion is, by hand,
    # u_ref = mean u_i, theta_x = sum y w / sum y^2, theta_y = -sum x w / sum x^2,
    # theta_z = sum (x v - y u) / sum (x^2 + y^2); written as MPCs it must give the same modes.
    # The plate is held at its centre grid and in x at an edge's middle: its drilling hold at
    # the centre alone would not stop a spin (Nastran's CQUAD4 has no drilling stiffness)
    lines, ids, xyz = plate(2, 2, SIDE, SIDE)
    corners = [(int(ids[j, i]), xyz[j, i]) for j in (0, 2) for i in (0, 2)]
    centre = np.array([0.1, 0.1, 0.0])
    base = [*lines, card("PSHELL", 1, 1, T, 1), STEEL,
            card("GRID", 100, None, *map(float, centre)), conm2(),
            card("SPC1", 1, 123456, int(ids[1, 1])),
            card("SPC1", 1, 1, int(ids[0, 1]))]  # fmt: skip
    rbe3 = card("RBE3", 50, None, 100, 123456, 1.0, 123, *(g for g, _ in corners))
    mpcs = []
    a2 = sum(float(((p - centre)[:2] ** 2).sum()) for _, p in corners)
    for comp in (1, 2, 3, 4, 5, 6):
        terms = [(100, comp, -1.0)]
        for gid, p in corners:
            x, y, _ = p - centre
            if comp <= 3:
                terms.append((gid, comp, 0.25))
            elif comp == 4:
                terms.append((gid, 3, 2 * y / a2))
            elif comp == 5:
                terms.append((gid, 3, -2 * x / a2))
            else:
                terms += [(gid, 2, x / a2), (gid, 1, -y / a2)]
        mpcs.append(mpc(9, terms))
    by_rbe3 = solve(write(tmp_path / "r.bdf", [*base, rbe3], "SPC = 1"), n_modes=6)
    by_mpc = solve(write(tmp_path / "m.bdf", [*base, *mpcs], "SPC = 1\nMPC = 9"), n_modes=6)
    np.testing.assert_allclose(by_rbe3.freq_hz, by_mpc.freq_hz, rtol=1e-9)
    assert by_rbe3.provenance["derived"]["dependent_components"] == 6


def test_rigid_element_errors_are_named(tmp_path):
    lines, ids, _ = plate(2, 2, SIDE, SIDE)
    base = [*lines, card("PSHELL", 1, 1, T, 1), STEEL, card("GRID", 100, None, 0.1, 0.1, 0.05)]
    corner = int(ids[0, 0])
    cases = {
        "twice": ([card("RBE2", 50, 100, 123, corner), card("RBE2", 51, 100, 3, corner)],
                  r"RBE2 51 .*component 3 of grid 1 is already dependent in RBE2 50"),
        "held": ([card("RBE2", 50, 100, 123, corner), card("SPC1", 1, 3, corner)],
                 r"component 3 of grid 1 is dependent and held by SPC1 1"),
        "rbe3 line": ([card("RBE3", 50, None, 100, 123456, 1.0, 123, corner, int(ids[0, 2]))],
                      r"RBE3 50 .*do not determine component [2-6] of the reference grid 100"),
    }  # fmt: skip
    for name, (extra, message) in cases.items():
        with pytest.raises(InputError, match=message):
            solve(write(tmp_path / f"{name}.bdf", [*base, *extra]), n_modes=2, element="shell")


def test_conm1_and_scalar_masses(tmp_path):
    # CONM1: the CONM2's 6 x 6 mass matrix at grid 100 given whole (lower triangle, row by
    # row); CMASS2 and CMASS1/PMASS: 0.3 kg on component 1 and 0.2 kg on component 3, which
    # adds 0.3 e1 e1^T + 0.2 e3 e3^T to the closed form
    whole = rigid_mass(MASS, conm2_inertia(), OFFSET)
    lower = [float(whole[i, j]) for i in range(6) for j in range(i + 1)]
    conm1 = card("CONM1", 60, 100, None, *lower)
    scalars = [card("CMASS2", 61, 0.3, 100, 1), card("PMASS", 62, 0.2),
               card("CMASS1", 63, 62, 100, 3)]  # fmt: skip
    result = solve(write(tmp_path / "c1.bdf", rigid_plate([conm1, *scalars, *celas2()])),
                   n_modes=6)  # fmt: skip
    mass = plate_mass() + whole
    mass[0, 0] += 0.3
    mass[2, 2] += 0.2
    np.testing.assert_allclose(result.freq_hz, rigid_frequencies(np.diag(SPRINGS), mass), rtol=1e-9)
