"""Files no one on this project wrote, through every door (issue 33): static and cyclic
ANSYS results refused, a PARAM,POST,-1 OP2 without LAMA read with the solver's eigenvalues,
an OP2 with displacement systems CD != 0 turned to the basic system, Simcenter/NX's UFF
2414 modes, a Rhino IGES file.

The files come from public repositories' test data: pymapdl-reader (MIT), pyNastran
(BSD-3-Clause), pyuff (MIT), pythonocc-core (LGPL-3.0, its test files). They are kept
gzip-compressed under ``tests/data/<source>/`` (tests/data/README.md names each file's
repository, commit and licence) and looked for under ``$JAXFLEX_REAL_FILES/<source>/`` (a folder
holding those repositories, named pymapdl-reader, pyNastran, pyuff, pythonocc-core); a test
whose file is in neither place is skipped, saying which one it needs. The references are
the solvers' own results in the same repositories (.f06 printouts, the result header).
"""

from __future__ import annotations

import atexit
import functools
import gzip
import os
import re
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

import fem
from fem.imports.from_modes import from_modes
from fem.sanity import PartWarning
from jaxflex.errors import InputError

DATA = Path(__file__).parent / "data"
ROOT = os.environ.get("JAXFLEX_REAL_FILES")
F06_DIGITS = 1e-6  # the .f06 prints 7 significant digits
FLOAT32 = 1e-6  # 32-bit OP2 words


def real(source: str, relative: str) -> Path:
    """A public repository's file (module docstring), or the test is skipped.

    tests/data keeps the small ones gzip-compressed (``relative + ".gz"``): each is unpacked
    once per session, with the other files of its folder (an .op2 beside its .f06).
    """
    packed = DATA / source / (relative + ".gz")
    if packed.is_file():
        return _unpacked(packed.parent, Path(relative).name)
    if ROOT and (Path(ROOT) / source / relative).is_file():
        return Path(ROOT) / source / relative
    pytest.skip(f"{source}/{relative}: not in tests/data; set JAXFLEX_REAL_FILES")


@functools.cache
def _unpacked_folder(folder: Path) -> Path:
    """The .gz files of one tests/data folder unpacked into a temporary folder of their own."""
    target = Path(tempfile.mkdtemp(prefix="jaxflex-real-files-"))
    atexit.register(shutil.rmtree, target, True)
    for packed in folder.glob("*.gz"):
        (target / packed.stem).write_bytes(gzip.decompress(packed.read_bytes()))
    return target


def _unpacked(folder: Path, name: str) -> Path:
    return _unpacked_folder(folder) / name


def _f06_eigenvalues(path: Path) -> np.ndarray:
    """Cycles of the first REAL EIGENVALUES table of an .f06."""
    lines = path.read_text(encoding="latin-1").splitlines()
    start = next(i for i, line in enumerate(lines) if "R E A L   E I G E N V A L U E S" in line)
    rows = []
    for line in lines[start + 3 :]:
        fields = line.split()
        if len(fields) != 7 or not re.fullmatch(r"\d+", fields[0]):
            break
        rows.append(float(fields[4]))
    return np.array(rows)


@pytest.mark.parametrize(
    ("relative", "what"),
    [
        ("tests/elements/shell181/shell181_box.rst", r"a static analysis \(ANTYPE,STATIC\)"),
        ("tests/elements/shell181/shell181.rst", r"static analysis .* 4 result set\(s\)"),
        ("tests/testfiles/cyclic_reader/cyclic_v182.rst", r"cyclic symmetry model \(15 sectors"),
        ("tests/testfiles/cyc12.rst", r"cyclic symmetry model \(18 sectors"),
        ("tests/testfiles/dist_rst/blade_stations/beam3_1.rst", "one part of a distributed"),
    ],
)
def test_ansys_results_that_are_not_modes_are_refused_naming_what_they_are(relative, what):
    with pytest.raises(InputError, match=what):
        fem.from_ansys(real("pymapdl-reader", relative), units="SI", gamma=np.ones((1, 3)))


def test_an_ansys_modal_result_is_read_with_the_solver_s_frequencies():
    from ansys.mapdl.reader import read_binary

    path = real("pymapdl-reader", "tests/testfiles/rst/beam_modal_cantilever.rst")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stated = np.asarray(read_binary(str(path)).time_values)
    result = fem.from_ansys(path, units="SI", gamma=np.ones((stated.size, 3)))
    np.testing.assert_allclose(result.freq_hz, stated, rtol=1e-12)


def test_a_post1_op2_without_lama_has_the_solver_s_eigenvalues():
    path = real("pyNastran", "models/sol_101_elements/mode_solid_shell_bar.op2")
    result = from_modes(path, units="SI")
    f06 = _f06_eigenvalues(path.with_suffix(".f06"))  # 71.26832, 75.95746, 125.7872 Hz
    assert f06.size == result.n_modes == 3
    np.testing.assert_allclose(result.freq_hz, f06, rtol=F06_DIGITS)
    assert "no LAMA table" in " ".join(result.provenance["notes"])
    plate = from_modes(real("pyNastran", "models/plate_py/plate_py.op2"), units="SI",
                       allow_rigid_modes=True)  # fmt: skip
    assert plate.provenance["rigid_modes"]["count"] == 6  # a free plate: six rigid modes
    assert plate.n_modes == 4 and plate.nodes is None  # no geometry in the file


def test_an_op2_with_displacement_systems_is_turned_to_the_basic_system():
    # femap's exhaust model (NX 8): 187 grids in cylindrical and rectangular systems CD. The
    # solver's eigenvectors are continuous in space: after the turn a CD grid moves as its
    # nearest basic-system neighbour does (1 % of the peak), as written it does not (25 %).
    from fem.imports.op2 import read_op2
    from fem.imports.op2_coords import op2_geometry

    path = real("pyNastran", "models/femap_exhaust/modal_example.op2")
    result = from_modes(path, units="SI")
    cd = op2_geometry(read_op2(path)).cd
    codes = np.array([cd.get(int(n), 0) for n in result.node_ids])
    local, plain = np.flatnonzero(codes > 0), np.flatnonzero(codes == 0)
    assert local.size == 187
    _, nearest = cKDTree(result.nodes[plain]).query(result.nodes[local])
    for k in range(1, 6):
        shape = result.shapes[:, :, k]
        gap = np.linalg.norm(shape[local] - shape[plain[nearest]], axis=1)
        assert np.median(gap) < 0.03 * np.abs(shape).max()


def test_simcenter_uff_2414_modes_are_read():
    path = real("pyuff", "data/NX simulation output.uff")
    result = from_modes(path)
    assert result.n_modes == 176 and len(result.node_ids) == 18
    assert result.freq_hz[0] == pytest.approx(23383.2, rel=1e-6)  # record 13 of the file
    assert "18 node(s) with a displacement system" in " ".join(result.provenance["notes"])
    with pytest.raises(InputError, match=r"analysis types \{'static': 2\}"):
        from_modes(real("pyuff", "data/Simcenter_nxopen_thickness.uff"))


def test_a_rhino_iges_file_is_read_in_the_unit_its_flag_states():
    # Rhino 7 writes MM (units flag 2) and its largest coordinate, 39.02, in inches: the part
    # is 991 mm long, and the field is a hint
    path = real("pythonocc-core", "test/test_io/testfile.igs")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        part = fem.read_cad(path, 1e-3)
    lo, hi = part.bounds_m()
    assert float(np.max(np.abs(np.concatenate([lo, hi])))) == pytest.approx(0.991101, rel=1e-5)
    assert any("25.4 times" in str(w.message) for w in caught if w.category is PartWarning)
    lens = fem.read_cad(real("pythonocc-core", "test/test_io/sunglasses_lens.igs"), 1e-3)
    assert lens.area_m2 > 0  # B-spline box 0.05 % beyond the stated extent: read
