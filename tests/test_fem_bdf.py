"""The Nastran bulk-data reader on decks formatted by hand after the Quick Reference Guide.

The same 12-grid plate (0.6 m x 0.4 m, six CQUAD4, steel 1 mm, edges held by SPC1) is written
in small-field, large-field and free-field format with explicit and implicit continuations,
comments, executive and case control or without, and must read to the same cards.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fem.bdf import parse_real, read_bulk
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


@pytest.mark.parametrize("text", [SMALL, LARGE, FREE], ids=["small", "large", "free"])
def test_the_three_formats_read_to_the_same_cards(tmp_path, text):
    bulk = read_bulk(write(tmp_path, text))
    assert sorted(bulk.grids) == list(range(1, 13))
    for gid, (x, y) in GRIDS_XY.items():
        # the decks give .2, .4, .6: the nearest doubles, as 0.2 * k rounds within 1 ulp
        np.testing.assert_allclose(bulk.grids[gid].xyz, (x, y, 0.0), rtol=1e-15, atol=0)
    assert [(s.name, s.id, s.pid, s.grids) for s in bulk.shells] == [
        ("CQUAD4", e, 1, q) for e, q in enumerate(QUADS, start=1)
    ]
    prop = bulk.pshells[1]
    assert (prop.mid1, prop.t, prop.mid2, prop.mid3) == (1, 1e-3, 1, 1)
    mat = bulk.mat1s[1]
    assert (mat.e, mat.nu, mat.rho, mat.derived) == (2.1e11, 0.3, 7850.0, "G")
    assert mat.g == 2.1e11 / 2.6  # Nastran's rule: G = E / (2 (1 + NU))
    assert sorted(c.grid for c in bulk.spcs[1]) == EDGE
    assert {c.components for c in bulk.spcs[1]} == {"3"}


def test_case_control_and_ignored_cards(tmp_path):
    small = read_bulk(write(tmp_path, SMALL))
    assert small.case_spc == [1]
    assert small.ignored == {"EIGRL": 1, "PARAM": 1}
    assert read_bulk(write(tmp_path, LARGE)).case_spc is None  # bulk data only


def test_include_relative_to_the_including_file(tmp_path):
    lines = SMALL.splitlines(keepends=True)
    grids = [line for line in lines if line.startswith("GRID")]
    (tmp_path / "mesh").mkdir()
    (tmp_path / "mesh" / "grids.bdf").write_text("".join(grids))
    main = "".join(line for line in lines if not line.startswith("GRID"))
    # a quoted file name may continue on the next line
    main = main.replace("PARAM   POST", "INCLUDE 'mesh/\n  grids.bdf'\nPARAM   POST")
    bulk = read_bulk(write(tmp_path, main))
    assert sorted(bulk.grids) == list(range(1, 13))
    assert bulk.files[1].endswith("grids.bdf")
    missing = main.replace("grids.bdf'", "gone.bdf'")
    with pytest.raises(InputError, match=r"INCLUDE \(deck\.bdf line 8\): file .* does not exist"):
        read_bulk(write(tmp_path, missing))


def test_mat1_two_of_three_and_thru_over_missing_grids(tmp_path):
    g_only = SMALL.replace("2.1+11          .3", "2.1+11  8.+10     ")
    mat = read_bulk(write(tmp_path, g_only)).mat1s[1]
    assert (mat.nu, mat.derived) == (2.1e11 / (2 * 8e10) - 1, "NU")
    e_only = SMALL.replace("2.1+11          .3", "        8.+10   .3")
    mat = read_bulk(write(tmp_path, e_only)).mat1s[1]
    assert (mat.e, mat.derived) == (2 * 1.3 * 8e10, "E")
    # SPC1 ... THRU: grids missing from the range are skipped (Quick Reference Guide)
    sparse = SMALL.replace(
        "SPC1    1       3       1       THRU    4", "SPC1    1       3       1       THRU    40"
    )
    held = [c.grid for c in read_bulk(write(tmp_path, sparse)).spcs[1]]
    assert held[:12] == list(range(1, 13))  # 1 THRU 40 over the deck's 12 grids


def test_grdset_gives_the_grids_defaults(tmp_path):
    text = SMALL.replace("PARAM   POST    -1", "GRDSET" + " " * 50 + "6")
    text = text.replace(
        "GRID    5               .2      .2      0.",
        "GRID    5               .2      .2      0.              345",
    )
    grids = read_bulk(write(tmp_path, text)).grids
    assert {g.ps for g in grids.values()} == {"6", "345"}
    assert grids[5].ps == "345"  # its own PS, not the default
    system = text.replace("GRDSET          ", "GRDSET          3")
    message = (
        r"GRID 1 \(deck\.bdf line 11, field 3 CP\), blank: the default of GRDSET "
        r"\(deck\.bdf line 8, field 3\): coordinate system 3"
    )
    with pytest.raises(InputError, match=message):
        read_bulk(write(tmp_path, system))


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
    ],
)
def test_nastran_real_forms(text, expected):
    assert parse_real(text) == expected


@pytest.mark.parametrize("text", ["7.85-", "1E5", "1.5 E5", "inf", "1_0.", "", "1.5E"])
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
        replaced(
            "PARAM   POST    -1\n",
            "CBAR    20      2       1       2       0.      0.      1.\n"
            "RBE2    30      5       123456  1       2\nCONM2   40      5               1.\n"
            "CBAR    21      2       2       3       0.      0.      1.\n",
        ),
        r"cards that change the structure are not supported: CBAR \(2, first deck\.bdf line 8\), "
        r"CONM2 \(1, first deck\.bdf line 10\), RBE2 \(1, first deck\.bdf line 9\)",
    ),
    (
        replaced("GRID    3               0.", "GRID    3       5       0."),
        r"GRID 3 \(deck\.bdf line 13, field 3 CP\): coordinate system 5; only the basic",
    ),
    (
        replaced(
            "GRID    12              .6      .4      0.",
            "GRID    12              .6      .4      0.      2",
        ),
        r"GRID 12 \(deck\.bdf line 22, field 7 CD\): coordinate system 2",
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
        r"MAT1 1 \(deck\.bdf line 31\): gives only E of E, G, NU",
    ),
    (
        replaced("2.1+11          .3", "2.1+11  9.+10   .3"),
        r"MAT1 1 \(deck\.bdf line 31\): E, G and NU are all given but "
        r"E / \(2 \(1 \+ NU\) G\) = 0\.8974",
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
        replaced("PSHELL  1       1       1.-3    1", "PSHELL  1       1       1.-3     "),
        r"PSHELL 1 \(deck\.bdf line 30, field 5 MID2\): a shell that bends needs a bending",
    ),
    (
        replaced(
            "CQUAD4  1       1       1       4       5       2",
            "CQUAD4  1       1       1       4       5       2       0.      1.-3",
        ),
        r"CQUAD4 1 \(deck\.bdf line 23, field 9 ZOFFS\): offset shells are not supported",
    ),
    (
        replaced("GRID    5               .2      .2      0.", "GRID,5,,.2,.2,0.,,,,,1"),
        r"deck\.bdf line 15: a free-field line holds at most 8 data fields",
    ),
    (
        replaced("BEGIN BULK\n", ""),
        r"deck\.bdf has executive and case control \(CEND on line 3\) but no BEGIN BULK",
    ),
    (
        replaced("GRID    2 ", "GRID    1 "),
        r"GRID 1 \(deck\.bdf line 12\): grid 1 is defined twice "
        r"\(first at GRID 1 \(deck\.bdf line 11\)\)",
    ),
]


@pytest.mark.parametrize(("text", "message"), ERRORS)
def test_errors_name_the_card_the_line_and_the_field(tmp_path, text, message):
    with pytest.raises(InputError, match=message):
        read_bulk(write(tmp_path, text))
