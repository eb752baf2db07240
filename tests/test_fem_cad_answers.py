"""The CAD door answers (issue 33 item 4, issue 34's tracebacks): a cut-off file is refused
before OpenCASCADE reads it, an IGES file's "largest coordinate" is a hint and not a
refusal (Rhino writes it in inches in a millimetre file), --mesh-size outside the part's
size is one line naming the option, progress lines say what runs; and the model command's
small doors: cups at negative coordinates, a Universal File read without pyuff's dump."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from conftest import run_jaxflex
from sheet_parts import write_panel_iges, write_panel_step
from solver_files import uff55_mode

import fem
from fem.mesh.cad_check import check_cad_file
from fem.mesh.iges import global_parameters, iges_units
from fem.sanity import PartWarning
from jaxflex.cli import build_parser
from jaxflex.errors import InputError

THICKNESS_M = 1e-3
INCH_PER_MM = 25.4


@pytest.fixture(scope="module")
def cad(tmp_path_factory):
    import gmsh

    folder = tmp_path_factory.mktemp("cad")
    write_panel_step(folder / "panel.step")
    write_panel_iges(folder / "panel.igs", "MM")
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.importShapes(str(folder / "panel.step"))
        gmsh.model.occ.synchronize()
        gmsh.write(str(folder / "panel.brep"))
    finally:
        gmsh.finalize()
    return folder


@pytest.mark.parametrize("name", ["panel.step", "panel.igs", "panel.brep"])
def test_a_cut_off_cad_file_is_refused_before_the_kernel_reads_it(tmp_path, cad, name):
    whole = (cad / name).read_bytes()
    check_cad_file(cad / name)  # the whole file passes
    cut = tmp_path / name
    cut.write_bytes(whole[: int(0.6 * len(whole))])
    with pytest.raises(InputError, match="is cut off"):
        fem.read_cad(cut, THICKNESS_M, mesh_size=0.05)


def _stated_in_inches(source, target, extent_mm: float) -> float:
    """The IGES file with its largest coordinate (global parameter 20) set to the part's
    extent in inches, as Rhino writes it in a millimetre file; the value written."""
    text = source.read_text(encoding="latin-1")
    lines = text.splitlines(keepends=True)
    inches = f"{extent_mm / INCH_PER_MM:.5f}"
    for k, line in enumerate(lines):
        if line[72:73] != "G":
            continue
        fields = global_parameters(line[:72])
        stated = global_parameters("".join(row[:72] for row in lines if row[72:73] == "G"))[19]
        if f",{stated}," in line:
            data = line[:72].rstrip().replace(f",{stated},", f",{inches},", 1)
            assert len(data) <= 72 and fields
            lines[k] = data.ljust(72) + line[72:]
            break
    target.write_text("".join(lines), encoding="latin-1")
    return float(inches)


def test_an_iges_largest_coordinate_in_inches_warns_and_reads_the_part(tmp_path, cad):
    plain = fem.read_cad(cad / "panel.igs", THICKNESS_M, mesh_size=0.05)
    extent_mm = 1e3 * float(np.max(np.abs(np.concatenate(plain.bounds_m()))))
    stated = _stated_in_inches(cad / "panel.igs", tmp_path / "rhino.igs", extent_mm)
    assert iges_units(tmp_path / "rhino.igs").max_coordinate == pytest.approx(stated)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rhino = fem.read_cad(tmp_path / "rhino.igs", THICKNESS_M, mesh_size=0.05)
    said = [str(w.message) for w in caught if issubclass(w.category, PartWarning)]
    assert any("25.4 times the largest coordinate" in s and "inches" in s for s in said), said
    for ours, theirs in zip(rhino.bounds_m(), plain.bounds_m(), strict=True):
        np.testing.assert_allclose(ours, theirs, atol=1e-9)  # the unit flag decides


def test_the_command_meshes_a_cad_part_with_progress_and_refuses_absurd_mesh_sizes(tmp_path, cad):
    out = tmp_path / "m.npz"
    args = ["model", "--cad", str(cad / "panel.step"), "--thickness", "1e-3", "--allow-rigid-modes"]
    ran = run_jaxflex(*args, "--n-modes", "2", "-o", str(out))
    assert ran.returncode == 0, ran.stderr
    assert "cad: reading panel.step (gmsh, OpenCASCADE)" in ran.stderr
    assert "cad: meshing panel.step with gmsh at" in ran.stderr
    for size in ("1e300", "1e-300"):
        refused = run_jaxflex(*args, "--mesh-size", size, "-o", str(out))
        assert refused.returncode == 2
        last = refused.stderr.strip().splitlines()[-1]
        assert last.startswith("jaxflex model: error: --mesh-size (mesh_size):"), refused.stderr
        assert "Traceback" not in refused.stderr


def test_cups_at_negative_coordinates_after_another_cup_are_cups():
    parser = build_parser("model")
    args = parser.parse_args(
        ["model", "--scene", "plate", "--cups", "0.1,0.1,0.03", "-0.02,0.05,0.08,0.005",
         "-.1,-2e-2,0.01", "-o", "m.npz"]
    )  # fmt: skip
    assert [(c.x, c.y, c.z, c.radius) for c in args.cups] == [
        (0.1, 0.1, None, 0.03),
        (-0.02, 0.05, 0.08, 0.005),
        (-0.1, -0.02, None, 0.01),
    ]
    assert args.output == "m.npz"
    with pytest.raises(SystemExit):  # an unknown option is still one
        parser.parse_args(["model", "--scene", "plate", "--cups", "-x,1,2"])


def test_a_universal_file_is_read_without_pyuffs_dump_on_stdout(tmp_path, capfd):
    import pyuff

    from fem.imports.from_modes import from_modes

    path = tmp_path / "groups.uff"
    nodes = pyuff.prepare_2411(
        node_nums=np.array([1, 2, 3]), def_cs=np.zeros(3, dtype=int),
        disp_cs=np.zeros(3, dtype=int), color=np.ones(3, dtype=int),
        x=np.array([0.0, 1, 0]), y=np.array([0.0, 0, 1]), z=np.zeros(3),
    )  # fmt: skip
    pyuff.UFF(str(path)).write_sets([nodes, uff55_mode()], mode="overwrite")
    group = [
        "    -1",
        "  2467",
        "".join(f"{v:10d}" for v in (1, 0, 0, 0, 0, 0, 0, 2)),
        "sensors",
        "".join(f"{v:10d}" for v in (8, 1, 0, 0, 8, 2, 0, 0)),
        "    -1",
    ]  # a permanent group (dataset 2467), which pyuff prints as it reads it
    with open(path, "a") as handle:
        handle.write("\n".join(group) + "\n")
    capfd.readouterr()
    result = from_modes(path, units="SI", gamma=[[0.0, 0.0, 1.0]])
    assert result.freq_hz.tolist() == [12.5]
    assert capfd.readouterr().out == ""
