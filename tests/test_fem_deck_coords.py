"""Coordinate systems of Nastran decks (CORD1R/C/S, CORD2R/C/S, chained; GRID CP and CD)
and the constraints given in them (SPC of translations and rotations, GRID PS, SPCADD).

The part: a steel plate 0.4 x 0.3 m, 1 mm, 8 x 6 CQUAD4 held on mixed components. The same
part given another way (turned and moved in space, its grids in other systems, its
constraints along the grids' displacement systems, or held by our own supports) is the
same finite-element model: its frequencies agree to round-off (1e-9). The plate is a
parallelogram (skew 0.2): a rectangle's quads have equal diagonals, and which one cuts them
into facets would hang on the round-off of the turned coordinates.
"""

from __future__ import annotations

import meshio
import numpy as np
from decks import STEEL, card, mpc, plate, solve, write

import fem
from fem.imports.nastran.bdf import read_bulk
from fem.imports.nastran.coords import DeckGeometry

WIDTH, HEIGHT = 0.4, 0.3
PSHELL = card("PSHELL", 1, 1, 1e-3, 1)
X_AXIS, Z_AXIS = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])


def held_cards(ids, sid=1) -> list[str]:
    """Mixed constraints: edge x = 0 clamped (123456), edge x = W held in 3 (simply
    supported), grid (W, 0) also in 1 and 2."""
    return [
        card("SPC1", sid, 123456, *map(int, ids[:, 0])),
        card("SPC1", sid, 3, *map(int, ids[:, -1])),
        card("SPC1", sid, 12, int(ids[0, -1])),
    ]


def rotation(angles_deg) -> np.ndarray:
    """Rows: the axes of a system turned by ``angles_deg`` about z, then y, then x."""
    a, b, c = np.radians(angles_deg)
    rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    rx = np.array([[1, 0, 0], [0, np.cos(c), -np.sin(c)], [0, np.sin(c), np.cos(c)]])
    return (rx @ ry @ rz).T  # columns of the product are the axes; rows here


def test_a_plate_in_turned_and_chained_systems_is_the_same_part(tmp_path):
    lines, ids, xyz = plate(8, 6, WIDTH, HEIGHT, skew=0.2)
    basic = write(tmp_path / "basic.bdf", [*lines, PSHELL, STEEL, *held_cards(ids)])
    reference = solve(basic, n_modes=8, element="shell").freq_hz
    # system 1 (CORD2R) turned and moved, given in system 2 (a CORD2C: A, B, C in R, THETA,
    # Z); every grid located in system 1 (CP) with the plate's own coordinates and its
    # displacements in system 1 (CD): the plate turned in space with its constraints
    axes = rotation([30.0, 20.0, 40.0])
    origin = np.array([0.5, -0.2, 1.0])
    frame2 = rotation([10.0, 0.0, 0.0])  # system 2: a cylindrical system turned about z
    origin2 = np.array([0.1, 0.2, 0.3])

    def in_system2(point):
        local = frame2 @ (point - origin2)
        return [float(np.hypot(local[0], local[1])),
                float(np.degrees(np.arctan2(local[1], local[0]))), float(local[2])]  # fmt: skip

    a, b, c = origin, origin + axes[2], origin + axes[0]
    cord2 = card("CORD2C", 2, None, *map(float, origin2), *map(float, origin2 + frame2[2]),
                 *map(float, origin2 + frame2[0]))  # fmt: skip
    cord1 = card("CORD2R", 1, 2, *in_system2(a), *in_system2(b), *in_system2(c))
    turned = [
        card("GRID", int(g), 1, *map(float, p), 1)
        for g, p in zip(ids.ravel(), xyz.reshape(-1, 3), strict=True)
    ]
    quads = [line for line in lines if line.startswith("CQUAD4")]
    deck = write(tmp_path / "turned.bdf", [*turned, *quads, cord2, cord1, PSHELL, STEEL,
                                           *held_cards(ids)])  # fmt: skip
    geometry = DeckGeometry(read_bulk(deck))
    placed = np.array([geometry.positions[int(g)] for g in ids.ravel()])
    np.testing.assert_allclose(placed, origin + xyz.reshape(-1, 3) @ axes, atol=1e-12)
    np.testing.assert_allclose(solve(deck, n_modes=8).freq_hz, reference, rtol=1e-9)
    # a CORD1R through three grids of the deck gives the same system 1
    anchors = [card("GRID", 9000 + k, None, *map(float, p)) for k, p in enumerate((a, b, c))]
    cord1r = card("CORD1R", 1, 9000, 9001, 9002)
    deck = write(tmp_path / "cord1.bdf", [*turned, *quads, *anchors, cord1r, PSHELL, STEEL,
                                          *held_cards(ids)])  # fmt: skip
    np.testing.assert_allclose(solve(deck, n_modes=8).freq_hz, reference, rtol=1e-9)


def test_spherical_positions_and_cylindrical_constraints(tmp_path):
    # grids given in a spherical system (R, THETA, PHI) at the same places
    lines, ids, xyz = plate(8, 6, WIDTH, HEIGHT, skew=0.2)
    quads = [line for line in lines if line.startswith("CQUAD4")]
    centre = np.array([0.2, 0.15, -0.5])
    sphere = card("CORD2S", 3, None, *map(float, centre), *map(float, centre + Z_AXIS),
                  *map(float, centre + X_AXIS))  # fmt: skip
    spherical = []
    for g, p in zip(ids.ravel(), xyz.reshape(-1, 3), strict=True):
        d = p - centre
        r = float(np.linalg.norm(d))
        theta = float(np.degrees(np.arccos(d[2] / r)))
        phi = float(np.degrees(np.arctan2(d[1], d[0])))
        spherical.append(card("GRID", int(g), 3, r, theta, phi))
    held = held_cards(ids)
    reference = solve(write(tmp_path / "b.bdf", [*lines, PSHELL, STEEL, *held]),
                      n_modes=8, element="shell").freq_hz  # fmt: skip
    deck = write(tmp_path / "s.bdf", [*spherical, *quads, sphere, PSHELL, STEEL, *held])
    np.testing.assert_allclose(solve(deck, n_modes=8).freq_hz, reference, rtol=1e-9)
    # the radial component of a cylindrical CD held at the edge y = H grids: the same as
    # MPCs cos(t) u_x + sin(t) u_y = 0 written in basic (t the grid's angle about the axis)
    axis = np.array([0.2, -0.4, 0.0])
    cylinder = card("CORD2C", 4, None, *map(float, axis), *map(float, axis + Z_AXIS),
                    *map(float, axis + X_AXIS))  # fmt: skip
    top = [int(g) for g in ids[-1, 1:]]  # (0, H) is clamped already
    in_cd = [line if not line.startswith("GRID") or int(line.split(",")[1]) not in top
             else line + ",4" for line in lines]  # fmt: skip
    radial = [*held, card("SPC1", 1, 1, *top)]
    by_cd = solve(write(tmp_path / "cd.bdf", [*in_cd, cylinder, PSHELL, STEEL, *radial]),
                  n_modes=8, element="shell").freq_hz  # fmt: skip
    mpcs = []
    for g in top:
        t = np.arctan2(*(xyz.reshape(-1, 3)[g - 1] - axis)[[1, 0]])
        terms = sorted([(g, 1, np.cos(t)), (g, 2, np.sin(t))], key=lambda x: -abs(x[2]))
        mpcs.append(mpc(9, terms))  # the larger term dependent
    by_mpc = solve(write(tmp_path / "mpc.bdf", [*lines, PSHELL, STEEL, *held, *mpcs],
                         "SPC = 1\nMPC = 9"), n_modes=8, element="shell").freq_hz  # fmt: skip
    np.testing.assert_allclose(by_cd, by_mpc, rtol=1e-9)


def test_rotations_held_by_spc_ps_and_spcadd_are_our_clamped_edge(tmp_path):
    # the edge x = 0 held in 123456 is fem.ClampedEdge("x0") of the same mesh read by
    # fem.read_mesh (the shell: the same facets and DOFs)
    lines, ids, xyz = plate(8, 6, WIDTH, HEIGHT)
    quads = np.array([[int(v) - 1 for v in line.split(",")[3:7]] for line in lines
                      if line.startswith("CQUAD4")])  # fmt: skip
    mesh_file = tmp_path / "plate.vtu"
    meshio.write(mesh_file, meshio.Mesh(xyz.reshape(-1, 3), [("quad", quads)]))
    part = fem.read_mesh(mesh_file, 1e-3, "steel", element="shell")
    reference = fem.modal_analysis(part, [fem.ClampedEdge("x0")], n_modes=6).freq_hz
    edge = [int(g) for g in ids[:, 0]]
    by_spc = write(tmp_path / "spc.bdf", [*lines, PSHELL, STEEL, card("SPC1", 1, 123456, *edge)])
    np.testing.assert_allclose(solve(by_spc, n_modes=6).freq_hz, reference, rtol=1e-9)
    # GRID PS 123456 on the edge grids, and SPCADD of two sets that each hold half the edge
    with_ps = [line + ",,123456" if line.startswith("GRID") and int(line.split(",")[1]) in edge
               else line for line in lines]  # fmt: skip
    by_ps = write(tmp_path / "ps.bdf", [*with_ps, PSHELL, STEEL])
    np.testing.assert_allclose(solve(by_ps, n_modes=6).freq_hz, reference, rtol=1e-9)
    halves = [card("SPC1", 1, 123456, *edge[:3]), card("SPC", 2, edge[3], 123456, 0.0,
                                                        edge[4], "12 456"),
              card("SPC1", 2, 3, *edge[4:]), card("SPC1", 2, 12456, *edge[5:]),
              card("SPCADD", 10, 1, 2)]  # fmt: skip
    by_add = write(tmp_path / "add.bdf", [*lines, PSHELL, STEEL, *halves], "SPC = 10")
    np.testing.assert_allclose(solve(by_add, n_modes=6).freq_hz, reference, rtol=1e-9)
