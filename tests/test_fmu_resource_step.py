"""Issue 23: the trajectory step of an FMU resource is checked, with and without a move. A
resource whose step is 5e-324 s or 1e300 s (CRC fixed, so every other check passes) made the
embedded move silently do nothing; an FMU without a move did not look at the step at all.
Both the FMU's C (instantiation returns NULL with a message) and fmu.resource refuse them;
the steps at the ends of the allowed range are accepted."""

from __future__ import annotations

import struct
import zipfile
import zlib

import pytest
from conftest import random_model
from test_fmu_export import smooth_profile
from test_fmu_robustness import RawFmu

import jaxflex
from fmu import export_fmu
from fmu.harness import resource_location
from fmu.options import Fmi
from fmu.resource import HEADER, TRAJECTORY_STEP_RANGE_S, decode_resource, encode_resource
from jaxflex.errors import InputError, ModelFileError

DT = 0.01
STEP_FIELD = 8  # the header's trajectory step (fmu.resource.HEADER)


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """FMI 2.0 and 3.0 FMUs with and without a move: {(version, move): (folder, token)}."""
    out = tmp_path_factory.mktemp("fmu_step")
    part = random_model(3, n_points=8, n_modes=3)
    built = {}
    for version in (2, 3):
        for move in (True, False):
            path = out / f"s{version}{int(move)}.fmu"
            trajectory = jaxflex.as_move(smooth_profile(2, 20), DT) if move else None
            fmi = Fmi(version, windows=False)
            result = export_fmu(part, path, trajectory, fmi=fmi, threshold_m=0.01)
            folder = out / f"x{version}{int(move)}"
            with zipfile.ZipFile(path) as zf:
                zf.extractall(folder)
            built[version, move] = (folder, result.token)
    return built


def with_step(data: bytes, step_s: float) -> bytes:
    """The resource ``data`` with its trajectory step set to ``step_s`` and the CRC fixed."""
    body = bytearray(data[:-8])
    fields = list(HEADER.unpack_from(body))
    fields[STEP_FIELD] = step_s
    body[: HEADER.size] = HEADER.pack(*fields)
    return bytes(body) + struct.pack("<II", zlib.crc32(bytes(body)), 0)


CASES = [
    (True, 5e-324, False),
    (True, 1e300, False),
    (True, float("nan"), False),
    (True, -DT, False),
    (True, TRAJECTORY_STEP_RANGE_S[0], True),
    (True, TRAJECTORY_STEP_RANGE_S[1], True),
    (False, DT, False),  # no move, yet a step
    (False, 5e-324, False),
    (False, 0.0, True),
]


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize(("move", "step_s", "ok"), CASES)
def test_the_fmu_checks_the_trajectory_step(fmus, version, tmp_path, move, step_s, ok):
    folder, token = fmus[version, move]
    data = (folder / "resources" / "jaxflex_model.bin").read_bytes()
    res = tmp_path / "res"
    res.mkdir()
    damaged = with_step(data, step_s)
    (res / "jaxflex_model.bin").write_bytes(damaged)
    raw = RawFmu(folder, version)
    instance = raw.instantiate(resource_location(version, res), token)
    if ok:
        assert instance is not None, raw.messages
        raw.free(instance)
        decode_resource(damaged)
        return
    assert instance is None
    assert any("step" in m for m in raw.messages), raw.messages
    with pytest.raises(ModelFileError, match="step"):
        decode_resource(damaged)


@pytest.mark.parametrize("step_s", [5e-324, 1e300, 1e-7, 1e4])
def test_a_resource_with_such_a_step_is_not_written(step_s):
    with pytest.raises(InputError, match="trajectory sample step"):
        move = jaxflex.as_move(smooth_profile(1, 10), step_s)
        encode_resource(random_model(3, n_points=4, n_modes=2), "t", move)
