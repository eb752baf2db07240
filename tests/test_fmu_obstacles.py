"""The obstacle kinds of the FMU resource are one table (fmu.obstacles) that the Python writer
and the C reader share: the generated jxf_config.h carries exactly its codes, and an obstacle
or record of a kind outside it is refused by both (Python: InputError naming the kind and the
allowed ones; C: instantiation returns NULL with a logged message; the Python reader:
ModelFileError), never treated as a triangle mesh."""

from __future__ import annotations

import re
import struct
import zipfile
import zlib

import numpy as np
import pytest
from conftest import random_model
from test_fmu_robustness import RawFmu

from fmu import export_fmu
from fmu.harness import resource_location
from fmu.obstacles import OBSTACLE_KINDS, RECORD_VALUES, obstacle_records
from fmu.options import CellOutputs, Fmi
from fmu.resource import decode_resource
from jaxflex._cell import Box, Cell, HalfSpace, TriangleMesh
from jaxflex.errors import InputError, ModelFileError

UNKNOWN_CODE = 7.0


class RoundedBox(Box):
    """A Box subclass the cell accepts but the FMU has no record kind for."""


def _cell(*obstacles) -> Cell:
    return Cell(obstacles=obstacles, start_m=[0.0, 0.0, 0.5], end_m=[0.5, 0.0, 0.5])


def test_records_carry_the_codes_of_the_table():
    box = Box([1.0, 2.0, 3.0], [0.2, 0.4, 0.6])
    floor = HalfSpace([0, 0, 1], -0.5)
    mesh = TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2], [1, 3, 2]])
    records = obstacle_records([box, floor, mesh])
    codes = {kind.obstacle: kind.code for kind in OBSTACLE_KINDS}
    assert records.shape == (4, RECORD_VALUES)
    assert list(records[:, 0]) == [codes[Box], codes[HalfSpace]] + [codes[TriangleMesh]] * 2
    assert list(records[0, 1:7]) == [1.0, 2.0, 3.0, 0.1, 0.2, 0.3]  # centre, half edges
    assert list(records[1, 1:5]) == [0.0, 0.0, 1.0, -0.5]  # normal, offset
    assert list(records[3, 1:10]) == [1, 0, 0, 1, 1, 0, 0, 1, 0]  # the second triangle


def test_an_unknown_obstacle_kind_is_refused_in_python(tmp_path):
    with pytest.raises(InputError) as caught:
        obstacle_records([Box([0, 0, 0], [1, 1, 1]), object()])
    text = str(caught.value)
    assert "obstacles[1]" in text and "'object'" in text
    assert all(kind.name in text for kind in OBSTACLE_KINDS)
    cell = _cell(RoundedBox([2.0, 0.0, 0.0], [0.2, 0.2, 0.2]))
    path = tmp_path / "rounded.fmu"
    with pytest.raises(InputError, match=r"'RoundedBox' cannot be written into an FMU"):
        export_fmu(
            random_model(2, n_points=6, n_modes=2), path, fmi=Fmi(windows=False),
            outputs=CellOutputs(cell),
        )  # fmt: skip
    assert not path.exists()


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """Per FMI version: (extracted folder, token, resource bytes) of an FMU with two boxes."""
    root = tmp_path_factory.mktemp("fmu_obstacles")
    cell = _cell(Box([2.0, 0.0, 0.0], [0.2, 0.2, 0.2]), Box([0.0, 2.0, 0.0], [0.2, 0.2, 0.2]))
    out = {}
    for version in (2, 3):
        result = export_fmu(
            random_model(4, n_points=6, n_modes=2), root / f"o{version}.fmu",
            fmi=Fmi(version, windows=False), outputs=CellOutputs(cell),
        )  # fmt: skip
        folder = root / f"x{version}"
        with zipfile.ZipFile(result.fmu_path) as zf:
            zf.extractall(folder)
        out[version] = (folder, result.token, (folder / "resources/jaxflex_model.bin").read_bytes())
    return out


def test_the_c_reader_gets_the_table(exported):
    config = (exported[2][0] / "sources" / "jxf_config.h").read_text()
    for kind in OBSTACLE_KINDS:
        assert f"#define JXF_OBSTACLE_{kind.name.upper()} {kind.code}\n" in config
    codes = re.search(r"#define JXF_OBSTACLE_CODES \{(.*)\}", config).group(1)
    assert [int(c) for c in codes.split(",")] == [kind.code for kind in OBSTACLE_KINDS]


def _with_second_record_kind(data: bytes, code: float) -> bytes:
    """The resource with the kind of its second (last) obstacle record changed and a valid
    CRC-32: the records end the payload, just before the 8-byte trailer."""
    body = bytearray(data[:-8])
    at = len(body) - RECORD_VALUES * 8
    assert struct.unpack_from("<d", body, at)[0] == 1.0  # a box
    struct.pack_into("<d", body, at, code)
    return bytes(body) + struct.pack("<II", zlib.crc32(body), 0)


@pytest.mark.parametrize("version", [2, 3])
def test_an_unknown_record_kind_is_refused_by_the_c_reader(exported, version, tmp_path):
    folder, token, data = exported[version]
    raw = RawFmu(folder, version)
    good = raw.instantiate(resource_location(version, folder / "resources"), token)
    assert good is not None  # the resource as written loads
    raw.free(good)
    crafted = tmp_path / "res"
    crafted.mkdir()
    (crafted / "jaxflex_model.bin").write_bytes(_with_second_record_kind(data, UNKNOWN_CODE))
    assert raw.instantiate(resource_location(version, crafted), token) is None
    message = raw.messages[-1]
    assert "obstacle record 1 has the kind code 7" in message
    assert all(f"{kind.name} ({kind.code})" in message for kind in OBSTACLE_KINDS)


def test_an_unknown_record_kind_is_refused_by_the_python_reader(exported):
    data = exported[2][2]
    assert decode_resource(data).counts == (0, 0, 2)
    with pytest.raises(ModelFileError, match=r"obstacle kind code\(s\) \[7\.0\]"):
        decode_resource(_with_second_record_kind(data, UNKNOWN_CODE))
    with pytest.raises(ModelFileError, match=r"\[nan\]"):
        decode_resource(_with_second_record_kind(data, np.nan))
