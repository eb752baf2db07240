"""Beams and rods of Nastran decks (CBAR, CBEAM, CROD, CONROD, CTUBE with PBAR, PBARL,
PBEAM, PROD, PTUBE) against closed forms and against the same beam written another way.

The door solves a sheet: each deck carries one massless triangle hanging from the beam's
free end (MAT1 without RHO). Its two free grids have stiffness and no mass, so they are
condensed exactly (fem.imports.nastran.reduce) and add nothing: the deck's modes are the beam's.
"""

from __future__ import annotations

import numpy as np
import pytest
from decks import E_PA, NU, RHO, STEEL, card, solve, write

from fem.imports.nastran.beam_sections import library_section

LENGTH = 1.0
AREA, I1, I2, J = 4e-4, 2e-8, 5e-8, 3e-8
G_PA = E_PA / (2 * (1 + NU))
CANTILEVER = np.array([1.875104068711961, 4.694091132974175])  # beta_n L, clamped-free


def beam_deck(path, n, element_lines, axis=(1.0, 0.0, 0.0), extra=(), held=None):
    """Grids 1 ... n + 1 along ``axis`` (length 1 m), the elements of ``element_lines(i, a,
    b)`` (element i from grid a to b), the massless triangle; ``held`` {grid: components}
    (default: grid 1 clamped)."""
    axis = np.asarray(axis) / np.linalg.norm(axis)
    points = np.outer(np.linspace(0, LENGTH, n + 1), axis)
    lines = [card("GRID", i + 1, None, *map(float, p)) for i, p in enumerate(points)]
    for i in range(n):
        lines += element_lines(100 + i, i + 1, i + 2)
    side = np.cross(axis, [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0])
    tip = points[-1]
    lines += [
        card("GRID", 900, None, *map(float, tip + 0.01 * axis)),
        card("GRID", 901, None, *map(float, tip + 0.01 * side)),
        card("CTRIA3", 900, 9, n + 1, 900, 901),
        card("PSHELL", 9, 2, 1e-3, 2),
        card("MAT1", 2, 2.1e11, None, 0.3),
        STEEL,
        *(card("SPC1", 1, c, g) for g, c in (held or {1: 123456}).items()),
        *extra,
    ]
    return write(path, lines)


def cbar(eid, a, b, v=(0.0, 1.0, 0.0), pid=7):
    return [card("CBAR", eid, pid, a, b, *v)]


PBAR = card("PBAR", 7, 1, AREA, I1, I2, J)


def test_cantilever_bending_is_euler_bernoulli(tmp_path):
    result = solve(beam_deck(tmp_path / "c.bdf", 40, cbar, extra=[PBAR]), n_modes=6)
    for inertia in (I1, I2):
        exact = CANTILEVER**2 / (2 * np.pi * LENGTH**2) * np.sqrt(E_PA * inertia / (RHO * AREA))
        nearest = [result.freq_hz[np.argmin(np.abs(result.freq_hz - f))] for f in exact]
        # Hermite cubics with consistent mass converge as h^4: 5.4e-8 at 20 elements,
        # 3.1e-9 at 40 (mode 1), 1.3e-7 (mode 2): 1e-6 leaves room
        np.testing.assert_allclose(nearest, exact, rtol=1e-6)


def test_beam_orientation_and_its_forms(tmp_path):
    # the same beam along an oblique axis, its plane 1 given by a vector (X1..X3) or by a grid
    # G0, and as CBEAM with PBEAM (K1 = K2 = 0: no shear): the same frequencies as along x
    # (no discretisation difference: 1e-9)
    reference = solve(beam_deck(tmp_path / "x.bdf", 10, cbar, extra=[PBAR]), n_modes=8).freq_hz
    axis = np.array([1.0, 2.0, 2.0]) / 3
    y = np.cross([0.0, 0.0, 1.0], axis)
    y /= np.linalg.norm(y)
    v = tuple(map(float, y))
    pbeam = card("PBEAM", 7, 1, AREA, I1, I2, 0.0, J, None, *([None] * 8), 0.0, 0.0)
    forms = {
        "vector": (lambda e, a, b: cbar(e, a, b, v), [PBAR]),
        "G0": (
            lambda e, a, b: [card("CBAR", e, 7, a, b, 950)],
            [PBAR, card("GRID", 950, None, *map(float, 5 * y))],
        ),
        "CBEAM": (lambda e, a, b: [card("CBEAM", e, 7, a, b, *v)], [pbeam]),
    }
    for name, (lines, extra) in forms.items():
        deck = beam_deck(tmp_path / f"{name}.bdf", 10, lines, axis, extra)
        got = solve(deck, n_modes=8).freq_hz
        np.testing.assert_allclose(got, reference, rtol=1e-9, err_msg=name)
    # PBARL BAR and a PBAR of the same A, I1, I2, J
    area, i1, i2, _, j = library_section("BAR", [0.02, 0.04])
    by_pbar = card("PBAR", 7, 1, area, i1, i2, j)
    by_pbarl = card("PBARL", 7, 1, None, "BAR", None, None, None, None, 0.02, 0.04)
    expected = solve(beam_deck(tmp_path / "p.bdf", 10, cbar, extra=[by_pbar]), n_modes=8)
    got = solve(beam_deck(tmp_path / "l.bdf", 10, cbar, extra=[by_pbarl]), n_modes=8)
    np.testing.assert_allclose(got.freq_hz, expected.freq_hz, rtol=1e-9)


def fixed_free_bar(n: int, wave_speed2: float, count: int) -> np.ndarray:
    """The exact frequencies (Hz) of n linear elements with consistent mass, fixed-free:
    w_k^2 = 6 c^2 / h^2 (1 - cos p) / (2 + cos p), p = (2k - 1) pi / (2 n)."""
    h = LENGTH / n
    p = (2 * np.arange(1, count + 1) - 1) * np.pi / (2 * n)
    return np.sqrt(6 * wave_speed2 / h**2 * (1 - np.cos(p)) / (2 + np.cos(p))) / (2 * np.pi)


def test_rods_axial_and_torsion_are_the_exact_discrete_bar(tmp_path):
    # a rod has no bending stiffness: its lateral motions and bending rotations are held by
    # AUTOSPC, its modes are the axial (c^2 = E / rho) and the torsional (c^2 = G J /
    # (rho (I1 + I2)) = G / rho for a tube, J = I1 + I2) ones of linear elements
    n, outer, inner = 10, 0.02, 0.015
    area, _, _, _, j = library_section("TUBE", [outer, inner])
    rods = {
        "CROD": (lambda e, a, b: [card("CROD", e, 7, a, b)], [card("PROD", 7, 1, area, j)]),
        "CONROD": (lambda e, a, b: [card("CONROD", e, a, b, 1, area, j)], []),
        "CTUBE": (lambda e, a, b: [card("CTUBE", e, 7, a, b)],
                  [card("PTUBE", 7, 1, 2 * outer, outer - inner)]),
    }  # fmt: skip
    axial = fixed_free_bar(n, E_PA / RHO, 3)
    torsion = fixed_free_bar(n, G_PA / RHO, 3)
    expected = np.sort(np.concatenate([axial, torsion]))[:4]
    for name, (lines, extra) in rods.items():
        # the tip's lateral motion: no rod DOF (AUTOSPC holds it at the other grids; there
        # the triangle reaches it, which follows without resisting it)
        deck = beam_deck(tmp_path / f"{name}.bdf", n, lines, extra=extra,
                         held={1: 123456, n + 1: 2356})  # fmt: skip
        result = solve(deck, n_modes=4)
        np.testing.assert_allclose(result.freq_hz, expected, rtol=1e-9, err_msg=name)
        assert result.provenance["derived"]["autospc"] > 0


def simply_supported(inertia, area, mode, shear_area=np.inf):
    """(Hz) of a simply supported beam with shear deformation and no rotary inertia:
    w^2 = (E I k^4 / (rho A)) / (1 + k^2 E I / (G As)), k = n pi / L."""
    k = mode * np.pi / LENGTH
    w2 = E_PA * inertia * k**4 / (RHO * area) / (1 + k**2 * E_PA * inertia / (G_PA * shear_area))
    return np.sqrt(w2) / (2 * np.pi)


def test_timoshenko_beam_is_the_shear_beam_closed_form(tmp_path):
    # a stubby simply supported beam (L / depth 10 and 5, rectangle 0.2 x 0.1 m), PBEAM shear
    # factors K1 = K2 = 5/6: shear lowers the first frequencies by 1.3 % and 5 %; the element
    # converges to the closed form at second order: 2.6e-5 at 20 elements, 6.5e-6 and 2.4e-5
    # at 40 (measured)
    width, height = 0.2, 0.1  # plane 1 (y) has the 0.1 m depth
    area, i1, i2, _, j = library_section("BAR", [width, height])
    pbeam = card("PBEAM", 7, 1, area, i1, i2, 0.0, j, None, *([None] * 8), 5 / 6, 5 / 6)
    n = 40
    deck = beam_deck(
        tmp_path / "t.bdf",
        n,
        lambda e, a, b: [card("CBEAM", e, 7, a, b, 0.0, 1.0, 0.0)],
        extra=[pbeam],
        held={1: 1234, n + 1: 23},
    )
    result = solve(deck, n_modes=4)
    for inertia in (i1, i2):
        exact = simply_supported(inertia, area, 1, 5 / 6 * area)
        assert exact < 0.99 * simply_supported(inertia, area, 1)  # shear matters
        nearest = result.freq_hz[np.argmin(np.abs(result.freq_hz - exact))]
        assert nearest == pytest.approx(exact, rel=5e-5)


def test_pin_flags_and_offsets(tmp_path):
    # a pin flag PA = 56 on the first element of a beam clamped at grid 1 is a simply
    # supported end (the released rotations are condensed, as in Nastran): the same as
    # holding 1234 only (1e-8: the condensation's static shapes are the exact ones here) and
    # the closed form (Hermite error, 2.6e-8 at 40 elements)
    n = 40

    def pinned(e, a, b):
        return [card("CBAR", e, 7, a, b, 0.0, 1.0, 0.0, None, 56 if a == 1 else None)]

    by_pin = solve(beam_deck(tmp_path / "p.bdf", n, pinned, extra=[PBAR],
                             held={1: 123456, n + 1: 23}), n_modes=4)  # fmt: skip
    by_spc = solve(beam_deck(tmp_path / "s.bdf", n, cbar, extra=[PBAR],
                             held={1: 1234, n + 1: 23}), n_modes=4)  # fmt: skip
    np.testing.assert_allclose(by_pin.freq_hz, by_spc.freq_hz, rtol=1e-8)
    exact = [simply_supported(inertia, AREA, 1) for inertia in (I1, I2)]
    np.testing.assert_allclose(by_pin.freq_hz[:2], exact, rtol=1e-6)
    # offsets WA = WB = (0, 0.05, 0.02) (the beam lies beside its grids) vs the beam on grids
    # at that place tied to the first ones by RBE2s: the same model
    arm = (0.0, 0.05, 0.02)

    def offset(e, a, b):
        return [card("CBAR", e, 7, a, b, 0.0, 1.0, 0.0, None, None, None, *arm, *arm)]

    by_offset = solve(beam_deck(tmp_path / "o.bdf", 10, offset, extra=[PBAR]), n_modes=6)
    moved = [card("GRID", 500 + i, None, 0.1 * i + arm[0], arm[1], arm[2]) for i in range(11)]
    links = [card("RBE2", 600 + i, i + 1, 123456, 500 + i) for i in range(11)]

    def beside(e, a, b):
        return [card("CBAR", e, 7, a + 499, b + 499, 0.0, 1.0, 0.0)]

    deck = beam_deck(tmp_path / "b.bdf", 10, beside, extra=[PBAR, *moved, *links])
    np.testing.assert_allclose(by_offset.freq_hz, solve(deck, n_modes=6).freq_hz, rtol=1e-9)


@pytest.mark.parametrize(
    ("kind", "dims", "expected"),
    [
        # (A, I1 = int y^2, I2 = int z^2, I12, J) from textbook formulas
        ("ROD", [0.01], (np.pi * 1e-4, np.pi * 1e-8 / 4, np.pi * 1e-8 / 4, 0, np.pi * 1e-8 / 2)),
        ("TUBE", [0.02, 0.015], (np.pi * 1.75e-4, np.pi * 1.09375e-7 / 4,
                                 np.pi * 1.09375e-7 / 4, 0, np.pi * 1.09375e-7 / 2)),
        # I: h 0.1, flanges 0.05 x 0.008, web 0.005: I1 = (b h^3 - (b - tw)(h - 2 tf)^3) / 12
        ("I", [0.1, 0.05, 0.05, 0.005, 0.008, 0.008],
         (2 * 0.05 * 0.008 + 0.084 * 0.005, (0.05 * 0.1**3 - 0.045 * 0.084**3) / 12,
          (2 * 0.008 * 0.05**3 + 0.084 * 0.005**3) / 12, 0, None)),
        # BOX 0.05 x 0.1, walls 0.004: outer minus inner rectangle; Bredt
        ("BOX", [0.05, 0.1, 0.004, 0.004],
         (0.005 - 0.042 * 0.092, (0.05 * 0.1**3 - 0.042 * 0.092**3) / 12,
          (0.1 * 0.05**3 - 0.092 * 0.042**3) / 12, 0,
          4 * (0.046 * 0.096) ** 2 / (2 * (0.046 + 0.096) / 0.004))),
    ],
)  # fmt: skip
def test_library_sections_against_textbook_formulas(kind, dims, expected):
    values = library_section(kind, dims)
    for got, want in zip(values, expected, strict=True):
        if want is not None:
            assert got == pytest.approx(want, rel=1e-12, abs=1e-18)


def test_angle_section_has_its_product_of_inertia():
    # L 0.05 x 0.05 x 0.005 (equal legs): I12 = int y z dA about the centroid, closed form
    # for two rectangles; the principal moments are I1 + I12 and I1 - I12 (equal legs)
    a, t = 0.05, 0.005
    area, i1, i2, i12, _ = library_section("L", [a, a, t, t])
    assert area == pytest.approx(2 * a * t - t * t)
    c = (a * t * t / 2 + (a - t) * t * (t + (a - t) / 2)) / area  # centroid (y and z)
    legs = [(a, t, a / 2, t / 2), (t, a - t, t / 2, t + (a - t) / 2)]  # (w, h, zc, yc)
    expected_i12 = sum(w * h * (yc - c) * (zc - c) for w, h, zc, yc in legs)
    assert i12 == pytest.approx(expected_i12, rel=1e-12)
    assert i1 == pytest.approx(i2, rel=1e-12)
