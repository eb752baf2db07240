"""The Nastran bulk-data reader on decks formatted by hand after the Quick Reference Guide.

The same 12-grid plate (0.6 m x 0.4 m, six CQUAD4, steel 1 mm, edges held by SPC1) is written
in small-field, large-field and free-field format with explicit and implicit continuations,
comments, executive and case control or without, and must read to the same cards.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import fem
from fem.imports.nastran.bdf import parse_real, read_bulk
from fem.imports.nastran.constraints import deck_constraints
from fem.imports.nastran.coords import DeckGeometry
from fem.imports.nastran.materials import Materials, pshell
from fem.imports.nastran.scope import classify
from fem.imports.nastran.shells import SHELL_CARDS, read_shell
from jaxflex.errors import InputError

SMALL = """\
$ simply supported plate, small field (8 columns)
SOL 103
CEND
TITLE = PLATE
SPC = 1
METHOD = 10
BEGIN BULK
PARAM   POST    -1
EIGRL   10                      4
$.......2.......3.......4.......5.......6.......7.......8.......9.......10.....
GRID    1               0.      0.      0.
GRID    2               0.      .2      0.
GRID    3               0.      .4      0.
GRID    4               .2      0.      0.
GRID    5               .2      .2      0.
GRID    6               .2      .4      0.
GRID    7               .4      0.      0.
GRID    8               .4      .2      0.
GRID    9               .4      .4      0.
GRID    10              .6      0.      0.
GRID    11              .6      .2      0.
GRID    12              .6      .4      0.
CQUAD4  1       1       1       4       5       2
CQUAD4  2       1       2       5       6       3
CQUAD4  3       1       4       7       8       5
CQUAD4  4       1       5       8       9       6
CQUAD4  5       1       7       10      11      8
CQUAD4  6       1       8       11      12      9
                0
PSHELL  1       1       1.-3    1               1
MAT1    1       2.1+11          .3      7850.                           +M1
+M1     250.+6
SPC1    1       3       1       THRU    4
SPC1    1       3       6       7
SPC1    1       3       9       THRU    12
ENDDATA
"""

LARGE = """\
$ the same plate in large field (16 columns), bulk data only
GRID*   1                               0.              0.              *G1
*G1     0.
GRID*   2                               0.              .2              *G2
*G2     0.
GRID*   3                               0.              .4              *G3
*G3     0.
GRID*   4                               .2              0.              *G4
*G4     0.
GRID*   5                               .2              .2              *G5
*G5     0.
GRID*   6                               .2              .4              *G6
*G6     0.
GRID*   7                               .4              0.              *G7
*G7     0.
GRID*   8                               .4              .2              *G8
*G8     0.
GRID*   9                               .4              .4              *G9
*G9     0.
GRID*   10                              .6              0.              *G10
*G10    0.
GRID*   11                              .6              .2              *G11
*G11    0.
GRID*   12                              .6              .4              *G12
*G12    0.
CQUAD4* 1               1               1               4               *E1
*E1     5               2
CQUAD4* 2               1               2               5               *E2
*E2     6               3
CQUAD4* 3               1               4               7               *E3
*E3     8               5
CQUAD4* 4               1               5               8               *E4
*E4     9               6
CQUAD4* 5               1               7               10              *E5
*E5     11              8
CQUAD4* 6               1               8               11              *E6
*E6     12              9
PSHELL* 1               1               1.-3            1               *P1
*P1                     1
MAT1*   1               2.1+11                          .3              *M1
*M1     .785E+4
SPC1*   1               3               1               THRU            *S1
*S1     4
SPC1    1       3       6       7
SPC1    1       3       9       THRU    12
"""

FREE = """\
SOL 103
CEND
SPC = 1
BEGIN BULK
$ the same plate in free field (commas), two grids in large free field
PARAM,POST,-1
EIGRL,10,,,4
GRID,1,,0.,0.,0.
GRID,2,,0.,.2,0.
GRID*,3,,0.,.4
*,0.
GRID,4,,.2,0.,0.
GRID, 5, , .2, .2, 0.
GRID,6,,.2,.4,0.
GRID,7,,.4,0.,0.
GRID,8,,.4,.2,0.
GRID,9,,.4,.4,0.
GRID*,10,,.6,0.,+G10
*G10,0.
GRID,11,,.6,.2,0.
GRID,12,,.6,.4,0.
cquad4,1,1,1,4,5,2
CQUAD4,2,1,2,5,6,3
CQUAD4,3,1,4,7,8,5
CQUAD4,4,1,5,8,9,6
CQUAD4,5,1,7,10,11,8,0.,0.,+E5
+E5,,0
CQUAD4,6,1,8,11,12,9
PSHELL,1,1,1.-3,1,,1
MAT1,1,2.1E11,,0.3,7.85+3,,,,+M1
+M1,2.5D8
SPC1,1,3,1,THRU,4
SPC1,1,3,6,7
SPC1,1,3,9,THRU,12
ENDDATA
"""

GRIDS_XY = {g: (0.2 * ((g - 1) // 3), 0.2 * ((g - 1) % 3)) for g in range(1, 13)}
QUADS = [(1, 4, 5, 2), (2, 5, 6, 3), (4, 7, 8, 5), (5, 8, 9, 6), (7, 10, 11, 8), (8, 11, 12, 9)]
EDGE = [1, 2, 3, 4, 6, 7, 9, 10, 11, 12]


def write(tmp_path, text, name="deck.bdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


def shells_of(bulk):
    """(name, id, pid, grids) of the deck's shells (fem.imports.nastran.shells reads them)."""
    out = []
    for card in bulk.named(*SHELL_CARDS):
        shell = read_shell(card, bulk)
        out.append((card.name, card.integer(0, "EID"), shell.pid, shell.corners))
    return out


@pytest.mark.parametrize("text", [SMALL, LARGE, FREE], ids=["small", "large", "free"])
def test_the_three_formats_read_to_the_same_cards(tmp_path, text):
    bulk = read_bulk(write(tmp_path, text))
    assert sorted(bulk.grids) == list(range(1, 13))
    for gid, (x, y) in GRIDS_XY.items():
        # the decks give .2, .4, .6: the nearest doubles, as 0.2 * k rounds within 1 ulp
        np.testing.assert_allclose(bulk.grids[gid].xyz, (x, y, 0.0), rtol=1e-15, atol=0)
    assert shells_of(bulk) == [("CQUAD4", e, 1, q) for e, q in enumerate(QUADS, start=1)]
    materials = Materials(bulk)
    prop = pshell(bulk.by_id("PSHELL")[1], materials)
    assert prop.thickness == 1e-3 and prop.shear_flexible  # MID3 given (and not used)
    mat = materials.get(1, prop.card, 1, "MID1")
    assert (mat.e, mat.nu, mat.rho, mat.notes) == (
        2.1e11,
        0.3,
        7850.0,
        ("G from E = 2 (1 + NU) G",),
    )
    assert mat.g == 2.1e11 / 2.6  # Nastran's rule: G = E / (2 (1 + NU))
    held = deck_constraints(bulk, DeckGeometry(bulk), None).held
    assert sorted(held) == [(g, 3) for g in EDGE]


def test_case_control_and_ignored_cards(tmp_path):
    small = read_bulk(write(tmp_path, SMALL))
    assert small.case_spc == [1]
    assert classify(small) == ({}, {"EIGRL": 1, "PARAM": 1})
    assert read_bulk(write(tmp_path, LARGE)).case_spc is None  # bulk data only


def test_include_resolved_from_the_job_directory(tmp_path, monkeypatch):
    lines = SMALL.splitlines(keepends=True)
    grids = [line for line in lines if line.startswith("GRID")]
    (tmp_path / "mesh").mkdir()
    (tmp_path / "mesh" / "grids.bdf").write_text("".join(grids[:6]) + "INCLUDE 'mesh/more.bdf'\n")
    (tmp_path / "mesh" / "more.bdf").write_text("".join(grids[6:]))
    main = "".join(line for line in lines if not line.startswith("GRID"))
    # a quoted file name may continue on the next line; 'mesh/more.bdf' in mesh/grids.bdf is
    # relative to the job directory (where Nastran runs), not to mesh/
    main = main.replace("PARAM   POST", "INCLUDE 'mesh/\n  grids.bdf'\nPARAM   POST")
    bulk = read_bulk(write(tmp_path, main))
    assert sorted(bulk.grids) == list(range(1, 13))
    assert [Path(f).name for f in bulk.files[1:]] == ["grids.bdf", "more.bdf"]
    assert not bulk.include_notes
    # written relative to the including file instead: found there, and said so
    (tmp_path / "mesh" / "grids.bdf").write_text("".join(grids[:6]) + "INCLUDE 'more.bdf'\n")
    bulk = read_bulk(write(tmp_path, main))
    assert sorted(bulk.grids) == list(range(1, 13))
    assert "more.bdf found beside grids.bdf, not in the job directory" in bulk.include_notes[0]
    # a logical symbol (Nastran's SYMBOL=MESH=... in its rc file) from the environment
    symbolic = main.replace("'mesh/\n  grids.bdf'", "'MESHDIR:grids.bdf'")
    with pytest.raises(InputError, match=r"logical symbol MESHDIR .* set the environment variable"):
        read_bulk(write(tmp_path, symbolic))
    monkeypatch.setenv("MESHDIR", str(tmp_path / "mesh"))
    assert sorted(read_bulk(write(tmp_path, symbolic)).grids) == list(range(1, 13))
    missing = main.replace("grids.bdf'", "gone.bdf'")
    with pytest.raises(InputError, match=r"INCLUDE \(deck\.bdf line 8\): file .* does not exist"):
        read_bulk(write(tmp_path, missing))


def test_mat1_two_of_three_and_thru_over_missing_grids(tmp_path):
    def mat1(text):
        return Materials(read_bulk(write(tmp_path, text))).get(1, None, 0, "MID")

    g_only = SMALL.replace("2.1+11          .3", "2.1+11  8.+10     ")
    mat = mat1(g_only)
    assert (mat.nu, mat.notes) == (2.1e11 / (2 * 8e10) - 1, ("NU from E = 2 (1 + NU) G",))
    e_only = SMALL.replace("2.1+11          .3", "        8.+10   .3")
    mat = mat1(e_only)
    assert (mat.e, mat.notes) == (2 * 1.3 * 8e10, ("E from E = 2 (1 + NU) G",))
    # all three inconsistent: used as given, G for shear (Nastran's rule), and noted
    mat = mat1(SMALL.replace("2.1+11          .3", "2.1+11  9.+10   .3"))
    assert mat.q[2, 2] == 9e10 and "used as given" in mat.notes[0]
    # SPC1 ... THRU: grids missing from the range are skipped (Quick Reference Guide)
    sparse = SMALL.replace(
        "SPC1    1       3       1       THRU    4", "SPC1    1       3       1       THRU    40"
    )
    bulk = read_bulk(write(tmp_path, sparse))
    held = deck_constraints(bulk, DeckGeometry(bulk), None).held
    assert sorted(g for g, _ in held) == list(range(1, 13))  # 1 THRU 40 over the 12 grids


def test_grdset_gives_the_grids_defaults(tmp_path):
    text = SMALL.replace("PARAM   POST    -1", "GRDSET" + " " * 50 + "6")
    text = text.replace(
        "GRID    5               .2      .2      0.",
        "GRID    5               .2      .2      0.              345",
    )
    grids = read_bulk(write(tmp_path, text)).grids
    assert {g.ps for g in grids.values()} == {"6", "345"}
    assert grids[5].ps == "345"  # its own PS, not the default
    bulk = read_bulk(write(tmp_path, text.replace("GRDSET          ", "GRDSET          3")))
    assert {g.cp for g in bulk.grids.values()} == {3}
    with pytest.raises(InputError, match=r"GRID 1 .*field 3 CP\): coordinate system 3 is not in"):
        DeckGeometry(bulk)


def test_exact_duplicates_are_dropped_others_refused(tmp_path):
    text = SMALL.replace("GRID    12", "GRID    11              .6      .2      0.\nGRID    12")
    bulk = read_bulk(write(tmp_path, text))
    assert bulk.duplicates_dropped == 1 and len(bulk.grids) == 12
    text = SMALL.replace("GRID    12", "GRID    11              .6      .3      0.\nGRID    12")
    with pytest.raises(
        InputError, match=r"GRID 11 \(deck\.bdf line 22\): grid 11 is defined twice"
    ):
        read_bulk(write(tmp_path, text))


def test_long_free_field_lines_and_blanks_in_component_lists(tmp_path):
    # MSC's long free-field lines: data past the ninth field goes on in the next row
    bulk = read_bulk(write(tmp_path, "CORD2C,7,0,1.,2.,3.,1.,2.,4.,2.,2.,3.\n"))
    card = bulk.named("CORD2C")[0]
    assert card.texts[:11] == ["7", "0", "1.", "2.", "3.", "1.", "2.", "4.", "2.", "2.", "3."]
    # nine data fields: the ninth is the continuation marker
    bulk = read_bulk(write(tmp_path, "MAT1,1,2.1+11,,.3,7850.,,,,+M\n+M,250.+6\n"))
    assert bulk.named("MAT1")[0].texts[8] == "250.+6"
    spc = read_bulk(write(tmp_path, "SPC1    1       12 456  3\n")).named("SPC1")[0]
    assert spc.components(1, "C") == "12456"


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("7.85-9", 7.85e-9),
        ("1.+5", 1e5),
        ("2.1E5", 2.1e5),
        ("2.1e+05", 2.1e5),
        ("2.1D5", 2.1e5),
        ("-.5", -0.5),
        ("+.5-1", 0.05),
        ("7.", 7.0),
        ("70.-1", 7.0),
        (".7E1", 7.0),
        ("12", 12.0),
        ("1E7", 1e7),
        ("1D-3", 1e-3),
        ("-2E+5", -2e5),
        (".5+2", 50.0),
        ("1.-3", 1e-3),
    ],
)
def test_nastran_real_forms(text, expected):
    assert parse_real(text) == expected


@pytest.mark.parametrize("text", ["7.85-", "1+5", "1.5 E5", "inf", "1_0.", "", "1.5E", "E5"])
def test_not_nastran_reals(text):
    with pytest.raises(ValueError):
        parse_real(text)


@given(
    st.integers(0, 10**12),
    st.integers(0, 13),
    st.integers(-40, 40),
    st.sampled_from(["E", "D", "", "E+"]),
    st.booleans(),
)
def test_every_exponent_form_reads_as_python_reads_the_e_form(digits, point, exp, form, neg):
    text = str(digits)
    mantissa = text[:point] + "." + text[point:]
    sign = "-" if neg else ""
    if form == "":
        suffix = f"{exp:+d}"  # Nastran's short form: the sign starts the exponent
    elif form == "E+":
        suffix = f"E{exp:+d}"
    else:
        suffix = f"{form}{exp}"
    assert parse_real(sign + mantissa + suffix) == float(f"{sign}{mantissa}e{exp}")


def replaced(old: str, new: str) -> str:
    assert old in SMALL
    return SMALL.replace(old, new)


ERRORS = [
    (
        replaced("GRID    3               0.", "GRID    3       5       0."),
        r"GRID 3 \(deck\.bdf line 13, field 3 CP\): coordinate system 5 is not in the deck",
    ),
    (
        replaced(
            "GRID    12              .6      .4      0.",
            "GRID    12              .6      .4      0.      2",
        ),
        r"GRID 12 \(deck\.bdf line 22, field 7 CD\): coordinate system 2 is not in the deck",
    ),
    (
        replaced("7850.   ", "7850.-  "),
        r"MAT1 1 \(deck\.bdf line 31, field 6 RHO\): '7850\.-' is not a real number",
    ),
    (
        replaced(
            "CQUAD4  6       1       8       11      12      9",
            "CQUAD4  6       1       8       11      12      99",
        ),
        r"CQUAD4 6 \(deck\.bdf line 28, field 7 G4\): grid 99 is not in the deck",
    ),
    (
        replaced("CQUAD4  6       1       8", "CQUAD4  6       1.      8"),
        r"CQUAD4 6 \(deck\.bdf line 28, field 3 PID\): '1\.' is not an integer",
    ),
    (
        replaced("2.1+11          .3      7850.", "2.1+11                  7850."),
        r"PSHELL 1 \(deck\.bdf line 30, field 3 MID1\): material 1 gives no positive "
        r"plane-stress stiffness for a shell \(MAT1 1: only one of E, G: the other and NU are 0",
    ),
    (
        replaced("+M1     250.+6", "+M2     250.+6"),
        r"MAT1 1 \(deck\.bdf line 31\): line 32 continues marker '\+M2', the card announced '\+M1'",
    ),
    (
        replaced("PARAM   POST    -1\n", "+       1.\n"),
        r"deck\.bdf line 8: a continuation line with no card before it",
    ),
    (
        replaced("SPC1    1       3       6       7", "SPC1    1       37      6       7"),
        r"SPC1 1 \(deck\.bdf line 34, field 3 C\): '37' is not a component list",
    ),
    (
        replaced("PSHELL  1       1       1.-3    1", "PSHELL  1       1       0.      1"),
        r"PSHELL 1 \(deck\.bdf line 30, field 4 T\): the thickness must be > 0, got 0",
    ),
    (
        replaced("BEGIN BULK\n", ""),
        r"deck\.bdf has executive and case control \(CEND on line 3\) but no BEGIN BULK",
    ),
    (
        replaced("SPC = 1", "SPC = 7"),
        r"case control selects SPC = 7; the deck has \[1\]",
    ),
]


@pytest.mark.parametrize(("text", "message"), ERRORS)
def test_errors_name_the_card_the_line_and_the_field(tmp_path, text, message):
    with pytest.raises(InputError, match=message):
        fem.from_nastran(write(tmp_path, text), units="SI", n_modes=2)
