"""The lowest modes of Nastran deck models sorted out (fem.imports.nastran.zero_modes):
rigid-body modes, mechanisms and modes of a part too soft for the rigid-mode cut-off; a real
deck of quadratic shells (pyNastran's trncomp12, tests/data/nastran/README.md)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from decks import STEEL, card, plate, solve, write

from fem.imports.nastran.zero_modes import regroup
from fem.modal import ModeSolution
from jaxflex.errors import InputError

DATA = Path(__file__).parent / "data" / "nastran"
PSHELL = card("PSHELL", 1, 1, 1e-3, 1)


def moving(message: str) -> list[int]:
    """The grids a mechanism refusal names."""
    return [int(g) for g in re.search(r"grids ([\d, ]+) move most", message).group(1).split(", ")]


def test_a_loose_plate_is_a_mechanism_not_six_rigid_modes(tmp_path):
    # plate A held everywhere and plate B beside it, connected to nothing (as the external
    # panel of pyNastran's satellite deck): B's six rigid motions are zero-energy modes that
    # no rigid motion of the whole model makes; the door said "6 rigid-body modes" and, with
    # allow_rigid_modes, wrote a model without plate B
    a_lines, a_ids, _ = plate(3, 3, 0.3, 0.3)
    b_lines, b_ids, _ = plate(2, 2, 0.2, 0.2, first=101, eid=101, z=0.5)
    held = card("SPC1", 1, 123456, int(a_ids.min()), "THRU", int(a_ids.max()))
    deck = write(tmp_path / "loose.bdf", [*a_lines, *b_lines, PSHELL, STEEL, held])
    for allow in (False, True):
        with pytest.raises(InputError) as refused:
            solve(deck, n_modes=4, allow_rigid_modes=allow)
        message = str(refused.value)
        assert "has 6 mechanism(s) beside 0 rigid-body mode(s)" in message
        assert set(moving(message)) <= set(b_ids.ravel().tolist())  # plate B's grids


def test_a_flap_on_a_line_of_pins_is_one_mechanism(tmp_path):
    # a free plate and a flap 5 mm beyond its edge y = 0.2, joined by two CBARs along y at
    # x = 0 and 0.2 whose ends on the flap are pinned about the hinge line (basic x: the
    # bars' element y for v = x, pin flag PB 5): free-free, the model has 6 rigid-body modes
    # and the flap's swing about the hinge, a mechanism
    plate_lines, ids, _ = plate(2, 2, 0.2, 0.2)
    flap_lines, flap_ids, _ = plate(2, 1, 0.2, 0.1, first=101, eid=101)
    shifted = []
    for line in flap_lines:
        if line.startswith("GRID"):
            fields = line.split(",")
            fields[4] = repr(float(fields[4]) + 0.205)
            line = ",".join(fields)
        shifted.append(line)
    bar = card("PBAR", 7, 1, 1e-4, 1e-9, 1e-9, 1e-9)
    hinge = [
        card("CBAR", 900 + k, 7, int(a), int(b), 1.0, 0.0, 0.0, None, None, "5")
        for k, (a, b) in enumerate(zip(ids[-1, [0, 2]], flap_ids[0, [0, 2]], strict=True))
    ]
    deck = write(tmp_path / "flap.bdf", [*plate_lines, *shifted, PSHELL, STEEL, bar, *hinge])
    with pytest.raises(InputError) as refused:
        solve(deck, n_modes=4, allow_rigid_modes=True)
    message = str(refused.value)
    assert "has 1 mechanism(s) beside 6 rigid-body mode(s)" in message
    assert set(moving(message)) <= set(flap_ids.ravel().tolist())  # the flap's grids
    # without the pin flags the hinge is stiff: six rigid-body modes, no mechanism
    stiff = [line.split("\n")[0] for line in hinge]
    deck = write(tmp_path / "stiff.bdf", [*plate_lines, *shifted, PSHELL, STEEL, bar, *stiff])
    result = solve(deck, n_modes=4, allow_rigid_modes=True)
    assert result.rigid_freq_hz.size == 6 and result.freq_hz[0] > 1.0


def test_quadratic_shell_deck_of_a_part_too_soft_is_refused_with_the_figure():
    # pyNastran's trncomp12 (NX, SOL 112): a 720 x 360 x 0.1 in laminate plate of CQUADR,
    # CQUAD8, CTRIAR and CTRIA6, mid-side grids on three of CQUAD8's edges and on two of the
    # CTRIA6's, RHO 0.283 (lbf/in^3, a weight density) without WTMASS: a plate so soft that
    # NX's own modes (its .op2's LAMA, lumped mass) start with 9 below 0.01 Hz (1.04e-4 ...
    # 8.65e-3 Hz) before its first in-plane mode at 0.769 Hz. Read with its mid-side grids
    # (53 free DOFs, as NX's), our model (consistent mass: the rotations carry mass too) has
    # 12 to 14 modes below 0.01 Hz (the sparse solver, shifted to -1 Hz^2, resolves a cluster
    # that tight only roughly), all deforming the plate: no rigid-body modes, and jaxflex
    # keeps no mode that low, so the deck is refused naming them (the door wrote a model
    # with modes at 0.011-0.017 Hz before, the mid-side grids dropped)
    with pytest.raises(InputError) as refused:
        solve(DATA / "trncomp12.bdf", units="BIN", n_modes=6, allow_rigid_modes=True)
    message = str(refused.value)
    found = re.search(r"(\d+) mode\(s\) below 0.01 Hz \((\S+) \.\.\. (\S+) Hz\)", message)
    assert found and int(found.group(1)) >= 9 and "deform the part" in message
    low, high = float(found.group(2)), float(found.group(3))
    assert 1e-4 / 3 < low < high < 0.01  # NX's: 1.04e-4 ... 8.65e-3 Hz


def test_regroup_moves_modes_by_what_they_are():
    # a solution whose solver called the 0.5 Hz mode rigid (a frequency gap) and left a
    # zero-energy one at 0.02 Hz among the elastic modes: regrouped by their energy, the
    # elastic modes come out ascending and the first `count` of them
    rng = np.random.default_rng(1)
    vectors, rigid_vectors = rng.normal(size=(8, 3)), rng.normal(size=(8, 2))
    modes = ModeSolution(
        freq_hz=np.array([0.02, 3.0, 5.0]),
        vectors=vectors,
        gamma=np.arange(9.0).reshape(3, 3),
        rigid_freq_hz=np.array([0.001, 0.5]),
        rigid_gamma=np.array([[1.0, 0, 0], [2.0, 0, 0]]),
        mobile_mass_kg=np.ones(3),
        static_residual_fraction=np.zeros(3),
        timings_s={},
        rigid_vectors=rigid_vectors,
    )
    out = regroup(modes, np.array([False, True]), np.array([True, False, False]), count=2)
    np.testing.assert_array_equal(out.freq_hz, [0.5, 3.0])
    expected = np.column_stack([rigid_vectors[:, 1], vectors[:, 1]])
    np.testing.assert_array_equal(out.vectors, expected)
    np.testing.assert_array_equal(out.rigid_freq_hz, [0.001, 0.02])
    np.testing.assert_array_equal(out.rigid_gamma[:, 0], [1.0, 0.0])
