"""Property tests of hostile input: model files, valid and damaged in every way a file can
be (wrong kinds and shapes, NaN and infinity, values outside the physical ranges, truncated
archives, extra, missing and garbage members, huge declared sizes, bad meta and schema
versions) load as a valid ModalModel or raise ModelFileError / ModelError, never another
exception; and ``jaxflex optimize`` with numbers across many decades, negative, zero, NaN
and infinity either works or exits with one clean error line, never a traceback. Both feed
the suite's tally (tests/conftest.py)."""

from __future__ import annotations

import contextlib
import io
import json
import math
import zipfile
from collections import Counter

import numpy as np
from conftest import random_model
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import jaxflex
from jaxflex._model_file import VALUE_RANGES
from jaxflex.cli import main
from jaxflex.errors import ModelError, ModelFileError

REAL = ("freq_hz", "zeta", "gamma", "shapes", "points")
MODEL_EXAMPLES = 400
CLI_EXAMPLES = 100


def _npy(array) -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, np.asarray(array), allow_pickle=True)
    return buffer.getvalue()


def _array(members: dict, name: str) -> np.ndarray:
    return np.lib.format.read_array(io.BytesIO(members[name + ".npy"]), allow_pickle=False)


def _valid_members(tmp_path) -> dict[str, bytes]:
    path = tmp_path / "valid.npz"
    random_model(n_points=5, n_modes=3).save(path)
    with zipfile.ZipFile(path) as archive:
        return {info.filename: archive.read(info) for info in archive.infolist()}


def _set(members, name, array):
    members[name + ".npy"] = _npy(array)


@st.composite
def damaged_model_files(draw, valid: dict[str, bytes]):
    """(archive bytes, must_refuse: True / False / None (either), what was done)."""
    members = dict(valid)
    kind = draw(
        st.sampled_from(
            ["none", "extra", "nan", "range", "kind", "shape", "missing", "meta", "version",
             "truncate", "garbage", "huge"]
        )
    )  # fmt: skip
    refuse: bool | None = True
    name = draw(st.sampled_from(REAL))
    what = f"{kind} {name}"
    if kind == "none":
        refuse = False
    elif kind == "extra":
        for i in range(draw(st.integers(1, 3))):
            extra = draw(st.sampled_from(["junk.npy", "../up.npy", f"x{i}.txt", "freq_hz.npy/"]))
            members[extra] = draw(st.binary(max_size=64))
        refuse = False
    elif kind == "nan":
        array = _array(members, name).copy()
        array.flat[draw(st.integers(0, array.size - 1))] = draw(
            st.sampled_from([math.nan, math.inf, -math.inf])
        )
        _set(members, name, array)
    elif kind == "range":
        array = _array(members, name).copy()
        index = draw(st.integers(0, array.size - 1))
        if name == "zeta":
            array.flat[index] = draw(st.sampled_from([-0.1, 1.0, 1.5, 1e300]))
        elif name == "freq_hz":
            array.flat[index] = draw(st.sampled_from([1e300, 5e-320, 0.0, -5.0, 2e6]))
        else:  # participation factors, shapes, coordinates x1e200
            low, high = VALUE_RANGES[name]
            array.flat[index] = draw(st.sampled_from([1e200, -1e200, 2 * high, 2 * low]))
        _set(members, name, array)
    elif kind == "kind":
        array = _array(members, name)
        other = draw(st.sampled_from(["text", "complex", "object", "integer", "bool"]))
        what += f" as {other}"
        if other == "integer":  # integers are numbers: loads if they are still in range
            refuse = None
        _set(
            members,
            name,
            {
                "text": lambda: array.astype(str),
                "complex": lambda: array + 1j,
                "object": lambda: array.astype(object),
                "integer": lambda: np.round(array).astype(np.int64),
                "bool": lambda: array > 0,
            }[other](),
        )
    elif kind == "shape":
        array = _array(members, name)
        how = draw(st.sampled_from(["longer", "shorter", "flat", "extra axis"]))
        what += f" {how}"
        changed = {
            "longer": lambda: np.concatenate([array, array[:1]]),
            "shorter": lambda: array[:-1],
            "flat": lambda: array.ravel()[:-1] if array.ndim == 1 else array.ravel(),
            "extra axis": lambda: array[..., None],
        }[how]()
        _set(members, name, changed)
    elif kind == "missing":
        del members[name + ".npy"]
    elif kind == "meta":
        text = draw(
            st.one_of(
                st.sampled_from(["[1,2]", "1", "{", "null", '"x"', '{"a": NaN}', "{}" * 3]),
                st.text(max_size=20),
            )
        )
        what = f"meta_json {text!r}"
        try:
            refuse = not isinstance(json.loads(text), dict)
        except ValueError:
            refuse = True
        _set(members, "meta_json", np.asarray(text))
    elif kind == "version":
        value = draw(st.sampled_from(["abc", math.nan, 2.0, (1, 1), 99, -1, 0, 1, 2, 2**62]))
        what = f"schema_version {value!r}"
        refuse = value not in (1, 2) or isinstance(value, float)
        _set(members, "schema_version", np.asarray(value))
    elif kind == "garbage":
        members[name + ".npy"] = draw(st.binary(max_size=200))
    elif kind == "huge":  # a header declaring 1e12 elements over a few bytes of data
        header = io.BytesIO()
        np.lib.format.write_array_header_1_0(
            header, {"descr": "<f8", "fortran_order": False, "shape": (10**12,)}
        )
        members[name + ".npy"] = header.getvalue() + b"\0" * 64
    compression = draw(st.sampled_from([zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED]))
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression) as archive:
        for member, data in members.items():
            archive.writestr(member, data)
    data = buffer.getvalue()
    if kind == "truncate":
        data = data[: draw(st.integers(0, len(data) - 1))]
        what = f"truncated to {len(data)} bytes"
    return data, refuse, what


def test_model_files_load_valid_or_raise_a_named_error(tmp_path, fuzz_tally):
    valid = _valid_members(tmp_path)
    path = tmp_path / "fuzzed.npz"
    counts = Counter()

    @settings(
        max_examples=MODEL_EXAMPLES,
        deadline=None,
        derandomize=True,
        suppress_health_check=[HealthCheck.too_slow],
    )
    @given(damaged_model_files(valid))
    def check(case):
        data, refuse, what = case
        path.write_bytes(data)
        counts["tried"] += 1
        try:
            model = jaxflex.load_model(path)
        except (ModelFileError, ModelError) as exc:
            counts["clear_errors"] += 1
            assert str(exc), what
            assert refuse is not False, f"{what}: a valid file refused: {exc}"
            return
        except Exception:
            counts["crashes"] += 1
            raise
        if refuse:
            counts["corrupt_accepted"] += 1
        assert not refuse, f"{what}: loaded"
        for name in REAL:
            assert np.isfinite(getattr(model, name)).all(), what

    try:
        check()
    finally:
        fuzz_tally("model files (hypothesis)", **{k: counts[k] for k in _COLUMNS})


_COLUMNS = ("tried", "clear_errors", "crashes", "hangs", "corrupt_accepted")

# numbers across many decades, negative, zero and the non-finite ones, as a user types them
NUMBERS = st.one_of(
    st.sampled_from(["0", "-1", "nan", "inf", "-inf", "1e-300", "1e300", "-0", "1e-6", "1e9"]),
    st.floats(-12, 12).map(lambda e: f"{10**e:.3g}"),
    st.floats(-12, 12).map(lambda e: f"{-(10**e):.3g}"),
)
OPTIONS = ("--vmax", "--amax", "--jmax", "--threshold", "--dt", "--clearance", "--max-duration")


@st.composite
def optimize_options(draw):
    """Command-line words of ``jaxflex optimize`` after the model: a few options with
    drawn numbers, the rest sensible defaults; small budgets keep every run short."""
    values = {"--threshold": "1e-3", "--distance": ["0.3", "0", "0.8"]}
    for option in draw(st.lists(st.sampled_from(OPTIONS), min_size=1, max_size=3, unique=True)):
        values[option] = draw(NUMBERS)
    if draw(st.booleans()):
        values["--distance"] = [draw(NUMBERS) for _ in range(3)]
    words = ["--max-steps", "400", "--max-memory", "1"]
    for option, value in values.items():
        if isinstance(value, list):
            words += [option, *value]
        else:
            words.append(f"{option}={value}")
    return words


def test_optimize_options_work_or_give_one_clean_error(tmp_path, fuzz_tally):
    model_path = tmp_path / "model.npz"
    random_model(n_points=6, n_modes=3).save(model_path)
    counts = Counter()

    @settings(
        max_examples=CLI_EXAMPLES,
        deadline=None,
        derandomize=True,
        suppress_health_check=[HealthCheck.too_slow],
    )
    @given(optimize_options())
    def check(words):
        argv = ["optimize", str(model_path), *words, "-o", str(tmp_path / "out"), "--quiet"]
        err, out = io.StringIO(), io.StringIO()
        counts["tried"] += 1
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
                try:
                    code = main(argv)
                except SystemExit as exc:  # argparse: usage and one error line, status 2
                    code = exc.code
        except Exception:
            counts["crashes"] += 1
            raise
        lines = err.getvalue().strip().splitlines()
        if code == 0:
            assert "best move:" in out.getvalue(), words
            return
        assert code in (1, 2), (words, code)
        assert "Traceback" not in err.getvalue(), words
        assert lines and lines[-1].startswith("jaxflex optimize: error: "), (words, lines)
        counts["clear_errors"] += 1

    try:
        check()
    finally:
        fuzz_tally("optimize options (hypothesis)", **{k: counts[k] for k in _COLUMNS})
