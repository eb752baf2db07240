"""Resource fuzzing and hostile calls against the FMU built with AddressSanitizer and
UndefinedBehaviorSanitizer: every damaged or crafted resource is refused with a logged
message or, when it is a valid resource, runs; nothing crashes, hangs, leaks or reads out of
bounds, and no resource the format forbids is accepted. A few hundred cases per FMI version
run in one harness process; the ``slow`` run tries ten times as many. Also the time
arithmetic of both FMUs (the part and the trajectory source) and the escaping of their log
messages."""

from __future__ import annotations

import shutil
import struct
import subprocess
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest
from conftest import random_model
from fmpy.fmi1 import FMICallException
from test_fmu_export import smooth_profile
from test_fmu_robustness import RawFmu

import jaxflex
from fmu import export_fmu
from fmu.build import compile_library
from fmu.harness import SANITIZE_FLAGS, compile_harness, resource_location
from fmu.master import Session
from fmu.options import Fmi
from fmu.resource import HEADER as _HEADER
from fmu.resource import decode_resource
from fmu.source import export_source_fmu
from fmu.toolchain import host_target
from jaxflex.errors import ModelError, ModelFileError

DT = 0.01
N_STEPS = 40  # embedded move
CI_CASES = 300  # per FMI version
SLOW_CASES = 3000
HARNESS_TIMEOUT_S = 600  # a hang guard for the whole corpus (it takes seconds)
INTERESTING = (
    np.nan,
    np.inf,
    -np.inf,
    0.0,
    -0.0,
    -1.0,
    1.0,
    0.999999,
    2.0,
    5e-324,
    1e-300,
    1e-3,
    9.99e-4,
    1e6,
    1.0000001e6,
    1e300,
    -1e300,
    1.7976931348623157e308,
)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """Per FMI version: (folder of the extracted FMU, token, resource bytes, switch value
    reference, sanitized library, sanitized harness)."""
    if shutil.which("gcc") is None:
        pytest.skip("gcc is not installed")
    root = tmp_path_factory.mktemp("fuzz_fmu")
    part = random_model(5, n_points=12, n_modes=4)
    out = {}
    for version in (2, 3):
        result = export_fmu(
            part,
            root / f"f{version}.fmu",
            jaxflex.as_move(smooth_profile(2, N_STEPS), DT),
            fmi=Fmi(version, windows=False),
            threshold_m=0.01,
        )
        folder = root / f"x{version}"
        with zipfile.ZipFile(result.fmu_path) as zf:
            zf.extractall(folder)
        library = root / f"asan{version}.so"
        compile_library(
            host_target(), folder / "sources", version, library, extra_flags=SANITIZE_FLAGS
        )
        harness = compile_harness(version, root / f"harness{version}", sanitize=True)
        data = (folder / "resources" / "jaxflex_model.bin").read_bytes()
        switch = _switch_vr(folder)
        out[version] = (folder, result.token, data, switch, library, harness)
    return out


def _switch_vr(folder: Path) -> int:
    from fmpy import read_model_description

    md = read_model_description(str(folder))
    return next(v.valueReference for v in md.modelVariables if v.name == "use_embedded_trajectory")


# -- the corpus ---------------------------------------------------------------------------


def _with_crc(body: bytes) -> bytes:
    """``body`` (header and payload) with a correct trailer: the mutation reaches the checks
    behind the CRC."""
    return body + struct.pack("<II", zlib.crc32(body), 0)


def _mutate(data: bytes, rng: np.random.Generator) -> tuple[str, bytes]:
    body = bytearray(data[:-8])
    kind = int(rng.integers(11))
    if kind == 0:  # bit flips anywhere, trailer untouched
        out = bytearray(data)
        for _ in range(int(rng.integers(1, 4))):
            out[int(rng.integers(len(out)))] ^= 1 << int(rng.integers(8))
        return "bit-flip", bytes(out)
    if kind == 1:
        return "truncated", data[: int(rng.integers(len(data)))]
    if kind == 2:
        return "padded", data + rng.bytes(int(rng.integers(1, 64)))
    if kind == 3:
        return "garbage", rng.bytes(int(rng.integers(0, 2 * len(data))))
    if kind == 4:  # one header field, CRC fixed
        fields = list(_HEADER.unpack_from(body))
        index = int(rng.choice([1, 2, 4, 5, 6, 7, 8, 9, 10, 11]))
        if index == 8:
            fields[8] = float(rng.choice(INTERESTING))
        else:
            fields[index] = int(rng.choice([0, 1, 2, 3, 127, 129, 2**31, 2**32 - 1]))
            if index == 9:
                sizes = [0, 8, 2**63, 2**64 - 1, fields[9] + 8]  # a list: numpy would round
                fields[9] = sizes[int(rng.integers(len(sizes)))]
        body[: _HEADER.size] = _HEADER.pack(*fields)
        return f"header-{index}", _with_crc(bytes(body))
    if kind == 5:  # payload values, CRC fixed
        count = (len(body) - _HEADER.size) // 8
        for _ in range(int(rng.integers(1, 4))):
            at = _HEADER.size + 8 * int(rng.integers(count))
            body[at : at + 8] = struct.pack("<d", float(rng.choice(INTERESTING)))
        return "payload-value", _with_crc(bytes(body))
    if kind == 6:  # the first values (frequencies, damping): the model's own checks
        at = _HEADER.size + 8 * int(rng.integers(8))
        body[at : at + 8] = struct.pack("<d", float(rng.choice(INTERESTING)))
        return "modal-value", _with_crc(bytes(body))
    if kind == 7:  # token bytes: control sequences, no NUL, CRC fixed
        token = bytes(rng.choice([0x1B, 0x07, 0x0A, 0x9B, 0xC2, 0x41, 0xFF], size=64))
        body[16:80] = token
        return "token", _with_crc(bytes(body))
    if kind == 8:
        body[0:8] = rng.bytes(8)
        return "magic", _with_crc(bytes(body))
    if kind == 9:  # random bytes spliced into the payload, CRC fixed
        at = int(rng.integers(_HEADER.size, len(body)))
        size = int(rng.integers(1, 32))
        body[at : at + size] = rng.bytes(size)[: len(body) - at]
        return "payload-bytes", _with_crc(bytes(body))
    return "valid", data


def _oracle_accepts(data: bytes, token: str, template: bytes) -> bool:
    """What the format allows (fmu.resource, the model's checks) and this FMU was built for."""
    try:
        decoded = decode_resource(data)
    except (ModelFileError, ModelError):
        return False
    built = decode_resource(template)
    sizes = (decoded.model.n_points, decoded.model.n_modes, len(decoded.acc), decoded.counts)
    return (
        decoded.token == token
        and sizes == (built.model.n_points, built.model.n_modes, len(built.acc), built.counts)
        and bool(np.isfinite(decoded.acc).all())
        and np.isfinite(decoded.dt_s)
        and decoded.dt_s > 0
    )


def _corpus(version: int, token: str, data: bytes, folder: Path, n_cases: int, seed: int):
    """(locations file, [(label, whether the FMU must accept it)]) for ``n_cases`` resource
    folders under ``folder``: three that are not a resource file at all, then mutations of
    the valid resource ``data``."""
    rng = np.random.default_rng(seed)
    cases, lines = [], []
    for i in range(n_cases):
        case_dir = folder / f"c{i}"
        case_dir.mkdir()
        if i == 0:
            (case_dir / "jaxflex_model.bin").mkdir()  # a directory where the file should be
            label, expected = "directory", False
        elif i == 1:
            label, expected = "missing", False
        elif i == 2:
            (case_dir / "jaxflex_model.bin").symlink_to("/dev/zero")
            label, expected = "dev-zero", False
        else:
            label, content = _mutate(data, rng)
            (case_dir / "jaxflex_model.bin").write_bytes(content)
            expected = _oracle_accepts(content, token, data)
        cases.append((label, expected))
        lines.append(resource_location(version, case_dir))
    listing = folder / "locations.txt"
    listing.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return listing, cases


def _run_corpus(built, version, tmp_path, n_cases, seed, fuzz_tally):
    _, token, data, switch, library, harness = built[version]
    listing, cases = _corpus(version, token, data, tmp_path, n_cases, seed)
    proc = subprocess.run(
        [str(harness), str(library), "-", token, "fuzz", "20", str(DT), str(switch), str(listing)],
        capture_output=True,
        text=True,
        timeout=HARNESS_TIMEOUT_S,
    )
    lines = proc.stdout.splitlines()
    crashed = proc.returncode != 0
    corrupt, wrong, clear = [], [], 0
    for (label, expected), line in zip(cases, lines, strict=False):
        outcome, logged, *rest = line.split()
        accepted = outcome == "accepted"
        if accepted and int(rest[1]) != 0:
            wrong.append((label, line))
        if not accepted:
            clear += int(logged) > 0
            if expected:
                wrong.append((label, "a valid resource refused"))
        elif not expected:
            corrupt.append(label)
    fuzz_tally(
        f"FMU {version} resources (ASan+UBSan)",
        tried=len(cases),
        clear_errors=clear,
        crashes=int(crashed),
        hangs=0,  # the harness's timeout raises
        corrupt_accepted=len(corrupt),
    )
    assert not crashed, (
        f"harness died at case {len(lines)} ({cases[min(len(lines), len(cases) - 1)][0]}): "
        + proc.stderr[-3000:]
    )
    assert len(lines) == len(cases)
    assert corrupt == [], corrupt
    assert wrong == [], wrong[:5]
    refused = sum(1 for line in lines if line.startswith("refused"))
    assert clear == refused  # every refusal said why
    assert sum(1 for _, expected in cases if expected) > 0  # valid ones ran too


@pytest.mark.parametrize("version", [2, 3])
def test_resource_corpus_under_sanitizers(built, version, tmp_path, fuzz_tally):
    _run_corpus(built, version, tmp_path, CI_CASES, seed=version, fuzz_tally=fuzz_tally)


@pytest.mark.slow
@pytest.mark.parametrize("version", [2, 3])
def test_large_resource_corpus_under_sanitizers(built, version, tmp_path, fuzz_tally):
    _run_corpus(built, version, tmp_path, SLOW_CASES, seed=100 + version, fuzz_tally=fuzz_tally)


# -- time arithmetic and NaN (regressions) ------------------------------------------------


def _session(built, version, **kwargs) -> Session:
    folder = built[version][0]
    return Session(folder, unzip_dir=folder, **kwargs)


def _step_in_child(built, version, t, h) -> subprocess.CompletedProcess:
    """One doStep with the embedded trajectory, in a child process with a timeout: a call
    that never returns fails the test instead of hanging it."""
    code = (
        "import sys; from fmu.master import Session\n"
        f"s = Session({str(built[version][0])!r}, unzip_dir={str(built[version][0])!r})\n"
        "s.start(0.0, {'use_embedded_trajectory': True})\n"
        f"s.step({t!r}, {h!r}); print(s.get('deviation'))\n"
    )
    import sys

    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("version", [2, 3])
def test_a_step_from_long_before_the_start_returns_and_is_exact(built, version):
    """Beyond ~6.7e5 s before the start the old replay's breakpoints rounded to the current
    time: a step of 0 s, forever. Now the span before the start is one exact step at rest,
    and the rest of the step is split at the same sample times as a step from the start, so
    both give the same state bit for bit."""
    start, span = -1e7, 1e7 + N_STEPS * DT
    proc = _step_in_child(built, version, start, span)
    assert proc.returncode == 0, proc.stderr
    with _session(built, version) as s:
        s.start(0.0, {"use_embedded_trajectory": True})
        s.step(0.0, start + span)  # the same end time, rounding included
        expected = s.get("deviation")
    assert float(proc.stdout.split()[-1]) == expected > 0


@pytest.mark.parametrize("version", [2, 3])
def test_a_huge_step_is_refused_not_turned_into_nan(built, version):
    """doStep(0, 1e308) under a 5 m/s^2 input made the state NaN, which the deviation's
    maximum skipped: 0 m and settled. Now it is refused and the state stays as it was."""
    with _session(built, version) as s:
        s.start(0.0)
        s.set_inputs([5.0, 0.0, 0.0])
        s.step(0.0, 0.1)
        before = s.get("deviation")
        with pytest.raises(FMICallException):
            s.step(0.1, 1e308)
        assert s.get("deviation") == before > 0
        assert any("beyond what the exact step" in m for _, m in s.messages)
        with pytest.raises(FMICallException):
            s.step(1e20, 1e-3)  # would not advance the time
        assert any("resolution of the time" in m for _, m in s.messages)
        s.step(0.1, 0.1)  # still usable


def test_source_fmu_refuses_steps_that_overflow_or_do_not_advance_the_time(tmp_path):
    acc = smooth_profile(4, 30)
    result = export_source_fmu(tmp_path / "src.fmu", jaxflex.as_move(acc, DT), 2, windows=False)
    with Session(result.fmu_path) as s:
        s.start(0.0)
        for t, h in ((1e308, 1e308), (1e20, 1e-3)):
            with pytest.raises(FMICallException):
                s.step(t, h)
        s.step(0.0, DT)
        assert s.get("ax") == pytest.approx(acc[1, 0])
    text = " ".join(m for _, m in s.messages)
    assert "ending at a finite time" in text and "resolution of the time" in text


@pytest.mark.parametrize("version", [2, 3])
def test_log_messages_carry_no_control_bytes(built, version, tmp_path):
    """A token from a crafted resource (terminal escapes, invalid UTF-8) reaches the log as
    \\xNN text, never as raw bytes."""
    folder, token, data, *_ = built[version]
    body = bytearray(data[:-8])
    body[16:80] = (b"\x1b[2J\x1b]0;pwned\x07\x9b\xc2\x85" + b"A" * 64)[:64]
    res = tmp_path / "res"
    res.mkdir()
    (res / "jaxflex_model.bin").write_bytes(_with_crc(bytes(body)))
    raw = RawFmu(folder, version)
    assert raw.instantiate(resource_location(version, res), token) is None
    message = next(m for m in raw.messages if "belongs to another FMU" in m)
    assert "\\x1b[2J" in message and "\\x9b" in message and "\\xc2\\x85" in message
    assert not any(ord(ch) < 0x20 or 0x7F <= ord(ch) <= 0x9F for ch in message)


@pytest.mark.parametrize("version", [2, 3])
def test_resource_messages_say_what_is_wrong(built, version, tmp_path):
    """A directory as the resource file, a damaged payload size field, a damaged header size
    field: each message names the actual problem (not "out of memory ... 9223372036854775807
    bytes", "1496 bytes, expected 1496" or "version 1 ... reads 1")."""
    folder, token, data, *_ = built[version]
    raw = RawFmu(folder, version)

    def message_for(prepare) -> str:
        res = tmp_path / f"r{len(raw.messages)}"
        res.mkdir()
        prepare(res / "jaxflex_model.bin")
        assert raw.instantiate(resource_location(version, res), token) is None
        return raw.messages[-1]

    assert "not a readable file (a directory?)" in message_for(lambda p: p.mkdir())
    fields = list(_HEADER.unpack_from(data))
    fields[9] += 8
    text = message_for(lambda p: p.write_bytes(_with_crc(_HEADER.pack(*fields) + data[128:-8])))
    assert "payload size field" in text
    fields = list(_HEADER.unpack_from(data))
    fields[2] = 129
    text = message_for(lambda p: p.write_bytes(_with_crc(_HEADER.pack(*fields) + data[128:-8])))
    assert "header size field" in text and "not supported" not in text
