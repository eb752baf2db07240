"""The fuzz and fault suite at every input door (issue 23): meshes, CAD, ANSYS, Nastran, R1,
cell files, sweep specs and the paths of every command. Each door gets at least
``DOOR_CASES`` generated cases (hypothesis, derandomized: the same cases on every run):
valid files, files damaged in every way a file can be (cut off, bytes flipped or spliced,
binary junk, empty, not UTF-8, non-finite and absurd numbers, indices past the end or
negative, nesting 100 000 deep, integers of thousands of digits) and paths that are no
files (directories, FIFOs, devices, sockets, loops). Every case must end in the door's own
error naming what is wrong, or in a result whose arrays are finite and consistent; the suite
counts tracebacks and signals (crashes), cases without an answer within their time
(hangs), and damaged input accepted (corrupt results), and its table (tests/conftest.py)
shows them per door.

The doors whose readers run in a child process (meshes, CAD, ANSYS: jaxflex.isolated) run
their cases two at a time (threads waiting on children), each under a budget of its own
(``CASE_MEMORY_GB``, ``CASE_TIME_S``: a reader that does not finish in time is a hang). The
others run in this process with an alarm as their time limit.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import itertools
import json
import math
import os
import shutil
import signal
import socket
import stat
import traceback
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import meshio
import numpy as np
import pytest
from conftest import random_model
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sheet_parts import write_box_step, write_panel_step
from sweep_cases import SPEC
from test_fem_bdf import SMALL

import fem
from fem.imports.ansys import read_full, read_node_coordinates, read_rst
from fem.imports.nastran.door import from_nastran
from fmu.export import sidecar_paths
from jaxflex._budget import make_budget, require, use_budget
from jaxflex._convolution import unit_response, write_unit_response_csv
from jaxflex.cli import main
from jaxflex.errors import BudgetError, JaxflexError
from jaxflex.files import MANIFEST
from optim.animate_page import PAGE
from optim.animate_series import CELL_FILE, PATH_FILE, SERIES, SERIES_DATA
from optim.cell_file import load_cell
from optim.result import RESULT_FILES
from optim.sweep.plan import sweep_needs
from optim.sweep.spec import load_spec
from optim.sweep.store import ROOT_FILES

DOOR_CASES = 100
SERIAL = itertools.count()  # file names: each generated case writes a file of its own
CASE_MEMORY_GB = 2.0
CASE_TIME_S = 120.0  # per case: far above any case's seconds (a hang guard, not a speed test)
SETTINGS = settings(
    max_examples=DOOR_CASES + DOOR_CASES // 5,  # a few to spare: hypothesis may stop early
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=list(HealthCheck),
)
HOSTILE_BYTES = [b"\xff\xfe", b"\x00" * 8, b"\xc3\x28", b"\x1b[2J", "é".encode("latin-1")]
ABSURD_NUMBERS = ["nan", "inf", "-inf", "1e999", "-1e999", "1e300", "5e-324", "9" * 5000, "-0"]


@dataclass
class Case:
    """One case of a door: ``call()`` reads it; ``refuse`` True (damaged: must be refused),
    False (valid: must be read) or None (either); ``check(result)`` whether an accepted
    result is sound (finite, consistent)."""

    label: str
    call: Callable
    refuse: bool | None
    check: Callable = lambda result: True


class Hang(Exception):
    """A case of an in-process door ran out of its time."""


@contextlib.contextmanager
def alarm(seconds: float):
    def ring(signum, frame):
        raise Hang

    previous = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def outcome(case: Case) -> tuple[str, str]:
    """(kind, detail): "accepted", "clear", "crash", "hang", "corrupt" or "refused-valid"."""
    try:
        result = case.call()
    except Hang:
        return "hang", case.label
    except BudgetError as exc:
        if "did not finish within" in str(exc):
            return "hang", f"{case.label}: {exc}"
        return ("refused-valid" if case.refuse is False else "clear"), f"{case.label}: {exc}"
    except JaxflexError as exc:
        if not str(exc) or "Traceback" in str(exc):
            return "crash", f"{case.label}: {exc!r}"
        return ("refused-valid" if case.refuse is False else "clear"), f"{case.label}: {exc}"
    except Exception as exc:
        where = traceback.extract_tb(exc.__traceback__)[-1]
        return "crash", f"{case.label[:200]}: {exc!r:.300} at {where.filename}:{where.lineno}"
    if case.refuse or not case.check(result):
        return "corrupt", case.label[:300]
    return "accepted", case.label


def in_child_threads(case: Case) -> tuple[str, str]:
    with use_budget(make_budget(CASE_MEMORY_GB, CASE_TIME_S)):
        return outcome(case)


def in_process(case: Case) -> tuple[str, str]:
    with alarm(CASE_TIME_S):
        return outcome(case)


def generated(strategy) -> list[Case]:
    """DOOR_CASES cases of ``strategy`` as hypothesis generates them (derandomized: the same
    every run), each with a file of its own; they are run afterwards (in parallel where the
    readers run in child processes)."""
    cases: list[Case] = []

    @SETTINGS
    @given(strategy)
    def collect(case):
        cases.append(case)

    collect()
    assert len(cases) >= DOOR_CASES, len(cases)
    return cases


def run_door(door: str, cases: list[Case], fuzz_tally, *, threads: int = 0) -> None:
    """Run ``cases``, tally them as ``door`` and assert: no crash, no hang, nothing damaged
    accepted, nothing valid refused."""
    assert len(cases) >= DOOR_CASES
    if threads:
        with ThreadPoolExecutor(threads) as pool:
            results = list(pool.map(in_child_threads, cases))
    else:
        results = [in_process(case) for case in cases]
    kinds = Counter(kind for kind, _ in results)
    fuzz_tally(
        door,
        tried=len(cases),
        clear_errors=kinds["clear"] + kinds["refused-valid"],
        crashes=kinds["crash"],
        hangs=kinds["hang"],
        corrupt_accepted=kinds["corrupt"],
    )
    bad = [detail for kind, detail in results if kind not in ("accepted", "clear")]
    assert not bad, "\n".join(bad[:40])


def finite(*arrays) -> bool:
    return all(np.isfinite(np.asarray(a, dtype=float)).all() for a in arrays)


# -- damage that applies to any file ------------------------------------------------------
def damaged_bytes(draw, data: bytes) -> tuple[str, bytes, bool | None]:
    """(what, bytes, refuse) of one damage of ``data``."""
    kind = draw(st.sampled_from(["truncate", "flip", "splice", "empty", "junk", "pad", "nul"]))
    if kind == "truncate":
        cut = draw(st.integers(0, max(len(data) - 1, 0)))
        return f"cut to {cut} bytes", data[:cut], None
    if kind == "flip":
        out = bytearray(data)
        for _ in range(draw(st.integers(1, 8))):
            at = draw(st.integers(0, len(out) - 1))
            out[at] ^= 1 << draw(st.integers(0, 7))
        return "bits flipped", bytes(out), None
    if kind == "splice":
        at = draw(st.integers(0, len(data)))
        junk = draw(st.binary(min_size=1, max_size=64)) + draw(st.sampled_from(HOSTILE_BYTES))
        return f"{len(junk)} bytes at {at}", data[:at] + junk + data[at:], None
    if kind == "empty":
        return "empty", b"", True
    if kind == "junk":
        return "binary junk", draw(st.binary(min_size=1, max_size=4096)), None
    if kind == "pad":
        return "padded", data + draw(st.binary(min_size=1, max_size=256)), None
    return "zeros", b"\x00" * len(data), None


# -- meshes ---------------------------------------------------------------------------------
def plate_mesh(nx: int = 6, ny: int = 4) -> tuple[np.ndarray, np.ndarray]:
    x, y = np.meshgrid(np.linspace(0, 0.6, nx + 1), np.linspace(0, 0.4, ny + 1), indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    idx = np.arange(points.shape[0]).reshape(nx + 1, ny + 1)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    tris = np.concatenate([np.column_stack([a.ravel(), b.ravel(), c.ravel()]),
                           np.column_stack([a.ravel(), c.ravel(), d.ravel()])])  # fmt: skip
    return points, tris


MESH_FORMATS = {".vtu": None, ".msh": "gmsh22", ".stl": "stl", ".obj": None, ".inp": None}


def sound_part(part) -> bool:
    sheet = part.geometry.sheet
    cells = sheet.all_triangles()
    return (
        finite(sheet.nodes)
        and cells.min() >= 0
        and cells.max() < len(sheet.nodes)
        and part.area_m2 > 0
        and math.isfinite(part.mass_kg)
    )


@st.composite
def mesh_cases(draw, folder: Path):
    i = next(SERIAL)
    suffix = draw(st.sampled_from(list(MESH_FORMATS)))
    path = folder / f"m{i}{suffix}"
    points, tris = plate_mesh()
    kind = draw(st.sampled_from(["valid", "bytes", "value", "index", "cells"]))
    refuse: bool | None = False
    what = kind
    if kind == "value":
        row, col = draw(st.integers(0, len(points) - 1)), draw(st.integers(0, 2))
        value = draw(st.sampled_from([math.nan, math.inf, -math.inf, 1e300, -1e308, 50.0]))
        points = points.copy()
        points[row, col] = value
        what, refuse = f"node {row} coordinate {value}", True
    elif kind == "index":  # formats that store indices (STL and OBJ writers resolve them)
        suffix = draw(st.sampled_from([".vtu", ".msh", ".inp"]))
        path = path.with_suffix(suffix)
        tris = tris.copy()
        tris[draw(st.integers(0, len(tris) - 1)), draw(st.integers(0, 2))] = draw(
            st.sampled_from([-1, -(10**6), len(points), 10**9])
        )
        what, refuse = "a cell index out of range", True
    elif kind == "cells":
        tris = tris[:0] if draw(st.booleans()) else tris[:, [0, 0, 1]]
        what, refuse = "no cells / degenerate cells", True
    meshio.write(path, meshio.Mesh(points, [("triangle", tris)]), file_format=MESH_FORMATS[suffix])
    if kind == "bytes":
        what, data, refuse = damaged_bytes(draw, path.read_bytes())
        path.write_bytes(data)
    if suffix == ".stl" and kind == "value":
        refuse = None  # STL stores corners per facet: a node's coordinate may be a lone one
    return Case(f"{path.name}: {what}", lambda: fem.read_mesh(path, 1e-3), refuse, sound_part)


def test_mesh_door(tmp_path, fuzz_tally):
    cases = generated(mesh_cases(tmp_path))
    run_door("meshes (read_mesh)", cases, fuzz_tally, threads=2)


# -- CAD ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cad_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cad")
    write_panel_step(folder / "panel.step")
    write_box_step(folder / "box.step")
    return folder


def sound_cad(part) -> bool:
    base = part.geometry.base
    return finite(base.nodes) and part.area_m2 > 0 and math.isfinite(part.mass_kg)


@st.composite
def cad_cases(draw, folder: Path, source: Path):
    i = next(SERIAL)
    path = folder / f"c{i}.step"
    text = (source / "panel.step").read_text(encoding="utf-8")
    kind = draw(st.sampled_from(["valid", "bytes", "lines", "numbers", "size", "solid"]))
    refuse: bool | None = False
    scale, mesh_size = 1.0, 0.05
    what = kind
    data = text.encode()
    if kind == "bytes":
        what, data, refuse = damaged_bytes(draw, data)
    elif kind == "lines":
        lines = text.splitlines()
        start = draw(st.integers(0, len(lines) - 1))
        del lines[start : start + draw(st.integers(1, 20))]
        data, what, refuse = "\n".join(lines).encode(), f"lines from {start} deleted", None
    elif kind == "numbers":
        number = draw(st.sampled_from(["1.E300", "-1.E300", "1.E-300", "NAN", "1.E+99999"]))
        data = text.replace("0.", number, draw(st.integers(1, 20))).encode()
        what, refuse = f"numbers set to {number}", None
    elif kind == "size":
        scale, mesh_size = draw(st.sampled_from([(200.0, 0.05), (1e-6, None), (1.0, 1e-6)]))
        what, refuse = f"scale {scale}, mesh size {mesh_size}", True
    elif kind == "solid":
        data, what, refuse = (source / "box.step").read_bytes(), "a solid body", True
    path.write_bytes(data)
    return Case(
        f"{path.name}: {what}",
        lambda: fem.read_cad(path, 1e-3, mesh_size=mesh_size, scale=scale),
        refuse,
        sound_cad,
    )


@pytest.mark.slow
def test_cad_door(tmp_path, cad_files, fuzz_tally):
    cases = generated(cad_cases(tmp_path, cad_files))
    run_door("CAD (read_cad, gmsh)", cases, fuzz_tally, threads=2)


# -- ANSYS ----------------------------------------------------------------------------------
def ansys_sources() -> dict[str, Path]:
    from ansys.mapdl.reader import examples

    return {
        ".full": Path(examples.fullfile),
        ".rst": Path(examples.rstfile),
        ".cdb": Path(examples.hexarchivefile),
    }


def sound_ansys(result) -> bool:
    if hasattr(result, "K"):  # FullMatrices
        n = result.K.shape[0]
        return (
            result.K.shape == result.M.shape == (n, n)
            and finite(result.K.data, result.M.data)
            and len(result.node_ids) == len(result.labels) == n
        )
    if hasattr(result, "freq_hz"):  # RstModes
        return finite(result.freq_hz, result.nodes, result.values)
    ids, coords = result
    return len(ids) == len(coords) and finite(coords)


@st.composite
def ansys_cases(draw, folder: Path):
    suffix = draw(st.sampled_from([".full", ".rst", ".cdb"]))
    source = ansys_sources()[suffix]
    path = folder / f"a{next(SERIAL)}{suffix}"
    data = source.read_bytes()
    kind = draw(st.sampled_from(["valid", "bytes", "bytes", "header", "tail"]))
    refuse: bool | None = False
    what = kind
    if kind == "bytes":
        what, data, refuse = damaged_bytes(draw, data)
        if suffix != ".cdb" and what.startswith("cut") and len(data) < len(source.read_bytes()):
            refuse = True  # the header states the length
    elif kind == "header":  # a word of the first 1 000 (headers, pointers) set to a hostile value
        at = 4 * draw(st.integers(0, 999))
        word = draw(st.sampled_from([-1, 0, 2**31 - 1, -(2**31), 10**9, 3]))
        data = data[:at] + int(word).to_bytes(4, "little", signed=True) + data[at + 4 :]
        what, refuse = f"word {at // 4} = {word}", None
    elif kind == "tail":  # the last tenth replaced by zeros (the size kept)
        cut = len(data) - len(data) // 10
        data, what, refuse = data[:cut] + b"\x00" * (len(data) - cut), "tail zeroed", None
    path.write_bytes(data)
    reader = {".full": read_full, ".rst": read_rst, ".cdb": read_node_coordinates}[suffix]
    return Case(f"{path.name}: {what}", lambda: reader(path), refuse, sound_ansys)


@pytest.mark.slow
def test_ansys_door(tmp_path, fuzz_tally):
    cases = generated(ansys_cases(tmp_path))
    run_door("ANSYS (.full .rst .cdb)", cases, fuzz_tally, threads=2)


# -- Nastran --------------------------------------------------------------------------------
HOSTILE_CARDS = [
    "GRID,1,,1.E+999,0.,0.",
    "GRID,1,,NAN,0.,0.",
    "GRID,-5,,0.,0.,0.",
    "GRID," + "9" * 5000 + ",,0.,0.,0.",
    "CQUAD4,1,1,1,2,3,99999",
    "CTRIA3,7,1,1,1,1",
    "PSHELL,1,1,-1.E-3,1",
    "MAT1,1,0.,,0.3,7850.",
    "MAT1,1,2.1E11,,5.,7850.",
    "SPC1,1,123456,1,THRU,999999999",
    "+       1.      2.",
    "GRID*,1,,0.,0.",
    "INCLUDE 'loop.bdf'",
    "INCLUDE '/etc/passwd'",
    "INCLUDE 'fifo'",
    "INCLUDE '.'",
    "INCLUDE '/dev/zero'",
    "RBE2,1,2,123456,3",
    "CQUAD4,1,1,1,2,3,4,5,6,7,8,9,10,11",
    "ENDDATA",
    "$ only a comment",
    "PARAM,WTMASS,-1.",
]


def sound_deck(result) -> bool:
    return sound_part(result.part) and finite(result.freq_hz, result.node_shapes())


def _deck_modes(path: Path):
    """The deck through the user's door (jaxflex model --deck): read, modelled, two modes."""
    return from_nastran(path, units="SI", n_modes=2, allow_rigid_modes=True)


@st.composite
def deck_cases(draw, folder: Path):
    path = folder / f"d{next(SERIAL)}.bdf"
    lines = SMALL.splitlines()
    kind = draw(st.sampled_from(["valid", "card", "card", "bytes", "delete"]))
    refuse: bool | None = False
    what = kind
    if kind == "card":
        card = draw(st.sampled_from(HOSTILE_CARDS))
        lines.insert(draw(st.integers(0, len(lines))), card)
        what, refuse = f"card {card[:40]!r}", None
    elif kind == "delete":
        at = draw(st.integers(0, len(lines) - 1))
        del lines[at]
        what, refuse = f"line {at + 1} deleted", None
    data = "\n".join(lines).encode()
    if kind == "bytes":
        what, data, refuse = damaged_bytes(draw, data)
    path.write_bytes(data)
    return Case(f"{path.name}: {what}", lambda: _deck_modes(path), refuse, sound_deck)


def test_nastran_door(tmp_path, fuzz_tally):
    (tmp_path / "loop.bdf").write_text("INCLUDE 'loop.bdf'\n", encoding="utf-8")
    os.mkfifo(tmp_path / "fifo")

    cases = generated(deck_cases(tmp_path))
    run_door("Nastran decks", cases, fuzz_tally)


# -- R1 -------------------------------------------------------------------------------------
R1_DT = 0.01


@pytest.fixture(scope="module")
def r1_text(tmp_path_factory):
    model = random_model(2, n_points=5, n_modes=2, f_min_hz=2.0, f_max_hz=8.0)
    path = tmp_path_factory.mktemp("r1") / "r1.csv"
    write_unit_response_csv(path, unit_response(model, R1_DT, 60)[2], R1_DT)
    return path.read_text(encoding="utf-8")


@st.composite
def r1_cases(draw, folder: Path, text: str):
    path = folder / f"r{next(SERIAL)}.csv"
    rows = text.splitlines()
    kind = draw(st.sampled_from(["valid", "number", "number", "ragged", "bytes"]))
    refuse: bool | None = False
    what = kind
    if kind == "number":
        row = draw(st.integers(1, len(rows) - 1))
        cells = rows[row].split(",")
        cells[draw(st.integers(0, len(cells) - 1))] = draw(st.sampled_from(ABSURD_NUMBERS))
        rows[row] = ",".join(cells)
        what, refuse = f"row {row}: {cells}", None
    elif kind == "ragged":
        row = draw(st.integers(1, len(rows) - 1))
        rows[row] = ",".join(rows[row].split(",")[: -draw(st.integers(1, 5))])
        what, refuse = f"row {row} shortened", True
    data = "\n".join(rows).encode()
    if kind == "bytes":
        what, data, refuse = damaged_bytes(draw, data)
    path.write_bytes(data)
    return Case(
        f"{path.name}: {what}",
        lambda: fem.from_r1(path, R1_DT, "z", max_modes=4),
        refuse,
        lambda result: finite(result.freq_hz, result.zeta),
    )


def test_r1_door(tmp_path, r1_text, fuzz_tally):
    cases = generated(r1_cases(tmp_path, r1_text))
    run_door("R1 tables", cases, fuzz_tally)


# -- settings files: cells and sweep specs ----------------------------------------------------
VALID_CELL = {
    "gravity_m_s2": [0, 0, -9.81],
    "part": {"start_m": [0.0, 0.0, 0.3], "rotation_deg": [0, 0, 0]},
    "path": {"end_m": [1.0, 0.0, 0.6], "via": [{"position_m": [0.5, 0, 0.8], "tolerance_m": 0.05}]},
    "obstacles": [
        {"type": "box", "name": "die", "centre_m": [1.3, 0, 0.3], "size_m": [0.5, 0.5, 0.2]},
        {"type": "half_space", "normal": [0, 0, 1], "offset_m": 0.0},
        {"type": "mesh", "name": "guard", "path": "guard.stl"},
    ],
}
HOSTILE_VALUES = [
    None, True, "x", [], {}, [1, 2], [math.nan, 0, 0], [math.inf, 0, 0], 10**30, -(10**30),
    1e308, -1.0, 0, [1e308, 1e308, 1e308], [[[[1]]]], "guard.stl", "fifo", ".", "/dev/zero",
    "missing.stl", "junk.stl",
]  # fmt: skip


def _paths(data, prefix=()):
    """Every (path of keys, value) in nested dicts and lists."""
    yield prefix, data
    items = (
        data.items()
        if isinstance(data, dict)
        else enumerate(data)
        if isinstance(data, list)
        else ()
    )
    for key, value in items:
        yield from _paths(value, (*prefix, key))


def _replace(data, keys, value):
    if not keys:
        return value
    copy = dict(data) if isinstance(data, dict) else list(data)
    copy[keys[0]] = _replace(copy[keys[0]], keys[1:], value)
    return copy


def settings_text(draw, data: dict, suffix: str) -> tuple[str, bytes, bool | None]:
    """(what, text, refuse) of ``data`` changed at one place, or written with hostile text
    (refuse None: it may still be valid), or as it is (refuse False)."""
    kind = draw(st.sampled_from(["valid", "value", "value", "value", "text", "bytes"]))
    if kind == "value":
        keys, _ = draw(st.sampled_from(list(_paths(data))[1:]))
        value = draw(st.sampled_from(HOSTILE_VALUES))
        data = _replace(data, keys, value)
        kind = f"{'.'.join(map(str, keys))} = {str(value)[:30]}"
    text = json.dumps(data) if suffix == ".json" else "\n".join(toml_lines(data)) + "\n"
    if kind == "text":
        choice = draw(st.sampled_from(["deep", "digits", "nan"]))
        if choice == "deep":
            text = ("x = " if suffix == ".toml" else '{"x": ') + "[" * 100_000 + "]" * 100_000
            text += "" if suffix == ".toml" else "}"
        elif choice == "digits":
            text = ("x = " if suffix == ".toml" else '{"x": ') + "7" * 5000
            text += "\n" if suffix == ".toml" else "}"
        else:
            text = text.replace("9.81", "nan" if suffix == ".toml" else "NaN")
        kind = f"text: {choice}"
    raw = text.encode()
    if kind == "bytes":
        kind, raw, _ = damaged_bytes(draw, raw)
    return kind, raw, False if kind == "valid" else None


def toml_lines(data: dict, table: str = "") -> list[str]:
    """``data`` as TOML (JSON values are TOML values except null, written as a string)."""
    lines, tables = [], []
    for key, value in data.items():
        if isinstance(value, dict):
            tables.append((key, value))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            tables += [(f"[{key}]", v) for v in value]
        else:
            text = json.dumps(value if value is not None else "null")
            text = text.replace("NaN", "nan").replace("Infinity", "inf")
            lines.append(f"{json.dumps(key)} = {text}")
    for key, value in tables:
        name = key[1:-1] if key.startswith("[") else key
        full = f"{table}.{name}" if table else name
        lines.append(f"[[{full}]]" if key.startswith("[") else f"[{full}]")
        lines += toml_lines(value, full)
    return lines


def sound_cell(cell) -> bool:
    arrays = [cell.start_m, cell.end_m, cell.rotation, cell.gravity_m_s2]
    for obstacle in cell.obstacles:
        arrays += [v for v in vars(obstacle).values() if isinstance(v, np.ndarray)]
    return finite(*arrays)


@st.composite
def cell_cases(draw, folder: Path):
    suffix = draw(st.sampled_from([".toml", ".json"]))
    path = folder / f"cell{next(SERIAL)}{suffix}"
    what, raw, refuse = settings_text(draw, VALID_CELL, suffix)
    path.write_bytes(raw)
    return Case(f"{path.name}: {what}", lambda: load_cell(path), refuse, sound_cell)


def _settings_folder(folder: Path) -> None:
    points, tris = plate_mesh(2, 2)
    meshio.write(folder / "guard.stl", meshio.Mesh(points, [("triangle", tris)]))
    (folder / "junk.stl").write_bytes(b"solid x\n facet normal nan\n" + bytes(range(256)))
    os.mkfifo(folder / "fifo")


def test_cell_door(tmp_path, fuzz_tally):
    _settings_folder(tmp_path)

    cases = generated(cell_cases(tmp_path))
    run_door("cell files", cases, fuzz_tally)


VALID_SPEC = {
    **SPEC,
    "optimization": {"threshold_m": 1e-4, "robust": {"n_freq": 3, "n_zeta": 2}},
}
SWEEP_ABSURD = [
    ("grids", [{"name": "g", "nx": list(range(1, 40)), "ny": list(range(1, 40)),
                "inset_x": [0.1, 0.2, 0.3], "inset_y": [0.1, 0.2, 0.3],
                "radius_m": [0.01 * k for k in range(1, 200)]}]),
    ("optimization", {"robust": {"n_freq": 100_000, "n_zeta": 100_000}}),
    ("model", {"monitor_grid": [100_000, 100_000]}),
    ("model", {"n_modes": 10**9}),
    ("part", {"width_m": 0.6, "height_m": 0.4, "mesh_size_m": 1e-6}),
    ("moves", [{"name": "far", "distance_m": [1e6, 0, 0]}]),
]  # fmt: skip


def sweep_plan(path: Path):
    """The spec of ``path`` as a sweep would have it: read, and planned before its first
    case on one worker (the refusals of jaxflex._budget)."""
    spec = load_spec(path)
    require(*sweep_needs(spec, len(spec.layouts) * len(spec.moves), len(spec.layouts), 1))
    return spec


def sound_spec(spec) -> bool:
    numbers = [spec.part.thickness_m, spec.model.zeta, spec.optimization.dt_s]
    numbers += [v for move in spec.moves for v in (*move.distance_m, *move.vmax)]
    numbers += [v for layout in spec.layouts for cup in layout.cups for v in cup]
    return finite(numbers)


@st.composite
def spec_cases(draw, folder: Path):
    suffix = draw(st.sampled_from([".toml", ".json"]))
    path = folder / f"spec{next(SERIAL)}{suffix}"
    refuse: bool | None = None
    if draw(st.integers(0, 3)) == 0:
        key, value = draw(st.sampled_from(SWEEP_ABSURD))
        data = {**VALID_SPEC, key: value}
        what, raw, refuse = f"{key}: {str(value)[:40]}", json.dumps(data).encode(), True
        path = path.with_suffix(".json")
    else:
        what, raw, refuse = settings_text(draw, VALID_SPEC, suffix)
    path.write_bytes(raw)
    return Case(f"{path.name}: {what}", lambda: sweep_plan(path), refuse, sound_spec)


def test_sweep_spec_door(tmp_path, fuzz_tally):
    _settings_folder(tmp_path)

    cases = generated(spec_cases(tmp_path))
    with use_budget(make_budget(CASE_MEMORY_GB, 3600.0)):
        run_door("sweep specs (read and planned)", cases, fuzz_tally)


# -- the paths of every command ---------------------------------------------------------------
def hostile_paths(folder: Path) -> dict[str, str]:
    """Paths that are no (writable) file, by what they are."""
    (folder / "dir").mkdir()
    os.mkfifo(folder / "fifo")
    listener = socket.socket(socket.AF_UNIX)
    listener.bind(str(folder / "sock"))
    (folder / "loop").symlink_to(folder / "loop")
    (folder / "dangling").symlink_to(folder / "nowhere")
    (folder / "file.txt").write_text("x", encoding="utf-8")
    return {
        "missing": str(folder / "missing.npz"),
        "directory": str(folder / "dir"),
        "fifo": str(folder / "fifo"),
        "socket": str(folder / "sock"),
        "/dev/zero": "/dev/zero",
        "/dev/null": "/dev/null",
        "symlink loop": str(folder / "loop"),
        "dangling symlink": str(folder / "dangling"),
        "inside a file": str(folder / "file.txt" / "x.npz"),
        "not UTF-8": os.fsdecode(bytes(folder / "caf") + b"\xe9.npz"),
        "too long": str(folder / ("x" * 300 + ".npz")),
        "empty": "",
        "missing directory": str(folder / "no" / "such" / "dir" / "x.npz"),
    }


OUTPUT_ONLY = {"/dev/full": "/dev/full", "/proc/version": "/proc/version"}


def command_cases(folder: Path) -> list[tuple[str, list[str], int]]:
    """(label, argv with one path replaced, index of the replaced word) for every command's
    path options."""
    model = folder / "model.npz"
    random_model(n_points=6, n_modes=3).save(model)
    spec = folder / "spec.json"
    spec.write_text(json.dumps(SPEC), encoding="utf-8")
    cups = ["--cups", "0.1,0.1,0.02", "0.5,0.1,0.02", "0.3,0.35,0.02"]
    out = str(folder / "out.npz")
    bases = {
        "model --mesh": ["model", "--mesh", "P", "--thickness", "1e-3", *cups, "-o", out],
        "model --cad": ["model", "--cad", "P", "--thickness", "1e-3", *cups, "-o", out],
        "model --from-ansys": ["model", "--from-ansys", "P", "--units", "SI", "-o", out],
        "model --from-nastran": ["model", "--from-nastran", "P", *cups, "-o", out],
        "model --from-r1": ["model", "--from-r1", "P", "--dt", "0.01", "-o", out],
        "model --trajectory": [
            "model", "--scene", "plate", "--tolerance", "5%", "--threshold", "1e-3",
            "--trajectory", "P", "-o", out,
        ],
        "optimize MODEL": ["optimize", "P", "--distance", "0", "0", "1", "--threshold", "1e-3",
                           "-o", str(folder / "o")],
        "optimize --cell": ["optimize", str(model), "--cell", "P", "--threshold", "1e-3",
                            "-o", str(folder / "o")],
        "sweep SPEC": ["sweep", "P", "--serial", "-o", str(folder / "s")],
        "export MODEL": ["export", "P", "-o", str(folder / "x.fmu")],
        "export --trajectory": ["export", str(model), "--trajectory", "P",
                                "-o", str(folder / "x.fmu")],
        "export --cell": ["export", str(model), "--cell", "P", "-o", str(folder / "x.fmu")],
        "model -o": ["model", "--scene", "plate", "--mesh-size", "0.2", "-o", "P"],
        "model --plot": ["model", "--scene", "plate", "--mesh-size", "0.2", "-o", out,
                         "--plot", "P"],
        "optimize -o": ["optimize", str(model), "--distance", "0", "0", "1", "--threshold",
                        "1e-3", "-o", "P"],
        "sweep -o": ["sweep", str(spec), "--serial", "-o", "P"],
        "export -o": ["export", str(model), "-o", "P"],
        "export --ssp": ["export", str(model), "--trajectory", str(folder / "t.csv"),
                         "--ssp", "P"],
    }  # fmt: skip
    paths = hostile_paths(folder)
    cases = []
    for label, argv in bases.items():
        output = label.endswith(("-o", "--plot", "--ssp"))
        kinds = {**paths, **(OUTPUT_ONLY if output else {})}
        for kind, path in kinds.items():
            if output and kind in ("missing", "not UTF-8"):
                continue  # a new file in an existing directory: writable
            if kind == "directory" and label in ("optimize -o", "sweep -o"):
                continue  # an output directory
            cases.append((f"{label} {kind}", [path if w == "P" else w for w in argv]))
    return cases


class Refused(JaxflexError):
    """The command refused with exit status 2 and one error line."""


def run_command(argv: list[str]) -> int:
    """main(argv) as a user runs it: Refused for status 2 with one error line last on stderr,
    the exit status otherwise; a traceback escapes."""
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main([*argv, "--quiet"])
        except SystemExit as exc:  # argparse: usage and one error line, status 2
            code = exc.code
    lines = err.getvalue().strip().splitlines()
    if code == 2 and lines and "error: " in lines[-1] and "Traceback" not in err.getvalue():
        raise Refused(lines[-1])
    return code


def test_command_path_door(tmp_path, fuzz_tally):
    """Every path option of every command given a path that is no file it may read or write:
    exit status 2 and one error line before any work (a FIFO would block a reader forever,
    /dev/zero never end, /dev/full and a FIFO as outputs were replaced by regular files)."""
    cases = command_cases(tmp_path)
    run_door(
        "command paths (model, optimize, sweep, export)",
        [Case(label, lambda argv=argv: run_command(argv), True) for label, argv in cases],
        fuzz_tally,
    )
    for device in ("/dev/full", "/dev/null"):
        assert Path(device).is_char_device()  # never replaced by a regular file


# -- outputs: never through a link, nothing outside the named output changes ------------------
# What can stand where a command writes: a symbolic link to a file outside (a write would
# replace that file), a link to nothing (a write would create a file outside), a FIFO, a
# device, a directory; and a hard link to a file outside (the command must give its name a
# new file and leave the other name's content alone). Every output of every command (the
# files named on the command line, the FMU's side files, the members of the result sets)
# meets each of them in a watched directory: the command refuses naming the path and the
# whole tree stays as it was, or (a hard link) runs and the tree differs only by the
# named outputs.
FILE_OBSTACLES = ("symlink", "dangling symlink", "FIFO", "device", "directory")
DIR_OBSTACLES = ("directory symlink", "dangling symlink", "FIFO", "device")
DOOR_SPEC = {
    **SPEC,
    "moves": SPEC["moves"][:1],
    "layouts": [],
    "grids": [{**SPEC["grids"][0], "inset_x": [0.2], "radius_m": [0.03]}],
}  # one case: a sweep that runs in seconds


def plant(path: Path, kind: str, watched: Path) -> bool:
    """Put an obstacle of ``kind`` at ``path`` (False: not possible here, a device without
    the right to make one)."""
    if kind == "symlink":
        path.symlink_to(watched / "victim.txt")
    elif kind == "dangling symlink":
        path.symlink_to(watched / "created-through-a-link")
    elif kind == "directory symlink":
        path.symlink_to(watched, target_is_directory=True)
    elif kind == "FIFO":
        os.mkfifo(path)
    elif kind == "device":  # a second /dev/null
        try:
            os.mknod(path, stat.S_IFCHR | 0o600, os.makedev(1, 3))
        except PermissionError:
            return False
    elif kind == "directory":
        path.mkdir()
    return True


def tree(root: Path) -> dict[str, tuple]:
    """What every path under ``root`` is: a link and its target, a file's inode and
    SHA-256, a directory's inode, another file's type and inode (links not followed)."""
    state = {}
    for folder, dirs, files in os.walk(root):
        for name in dirs + files:
            path = Path(folder) / name
            info = path.lstat()
            key = str(path.relative_to(root))
            if stat.S_ISLNK(info.st_mode):
                state[key] = ("link", os.readlink(path))
            elif stat.S_ISREG(info.st_mode):
                state[key] = ("file", info.st_ino, hashlib.sha256(path.read_bytes()).hexdigest())
            else:
                state[key] = (stat.S_IFMT(info.st_mode), info.st_ino)
    return state


@dataclass(frozen=True)
class OutputDoor:
    """A command whose output ``target`` (a file or a directory, relative to the case's
    folder; a member's parent directory is made first) is met by an obstacle."""

    label: str
    argv: tuple[str, ...]  # "{D}": the case's folder
    target: str
    directory: bool = False
    result: str | None = None  # an optimised result copied to "{D}/r" first (animate's input)


ANIMATION_FILES = (SERIES, SERIES_DATA, CELL_FILE, PATH_FILE, PAGE, "part_0000.vtu")


def output_doors(inputs: dict[str, str]) -> list[OutputDoor]:
    """Every output of every command."""
    model, trajectory, spec = inputs["model"], inputs["trajectory"], inputs["spec"]
    fe = ("model", "--scene", "plate", "--mesh-size", "0.2")
    opt = ("optimize", model, "--distance", "0", "0", "1", "--threshold", "1e-3", "-o", "{D}/o")
    export = ("export", model, "--trajectory", trajectory, "--no-verify")
    doors = [
        OutputDoor("model -o", (*fe, "-o", "{D}/m.npz"), "m.npz"),
        OutputDoor("model --plot", (*fe, "-o", "{D}/m.npz", "--plot", "{D}/p.png"), "p.png"),
        OutputDoor("model --vtu", (*fe, "-o", "{D}/m.npz", "--vtu", "{D}/m.vtu"), "m.vtu"),
        OutputDoor("model --report", (*fe, "-o", "{D}/m.npz", "--report", "{D}/r.json"), "r.json"),
        OutputDoor("optimize -o", opt, "o", directory=True),
        OutputDoor("export -o", ("export", model, "-o", "{D}/x.fmu"), "x.fmu"),
        OutputDoor("export -o: input CSV", (*export, "-o", "{D}/x.fmu"), "x_input.csv"),
        OutputDoor("export -o: case JSON", (*export, "-o", "{D}/x.fmu"), "x_case.json"),
        OutputDoor("export --ssp", (*export, "--ssp", "{D}/x.ssp"), "x.ssp"),
        OutputDoor("sweep -o", ("sweep", spec, "--serial", "-o", "{D}/s"), "s", directory=True),
        OutputDoor("demo -o", ("demo", "-o", "{D}/d"), "d", directory=True),
        OutputDoor("bench -o", ("bench", "--size", "tiny", "-o", "{D}/b"), "b", directory=True),
    ]
    doors += [OutputDoor(f"optimize -o: {n}", opt, f"o/{n}") for n in (*RESULT_FILES, MANIFEST)]
    sweep = ("sweep", spec, "--serial", "-o", "{D}/s")
    doors += [OutputDoor(f"sweep -o: {n}", sweep, f"s/{n}") for n in ROOT_FILES]
    doors += [OutputDoor(f"sweep -o: {n}/", sweep, f"s/{n}", True) for n in ("cases", "models")]
    demo = ("demo", "-o", "{D}/d")
    members = ["model.npz", "demo.json"]
    for name in ("part_fmi2.fmu", "part_fmi3.fmu"):
        members += [name, *(side.name for side in sidecar_paths(name))]
    doors += [OutputDoor(f"demo -o: {n}", demo, f"d/{n}") for n in members]
    doors.append(OutputDoor("demo -o: optimized/", demo, "d/optimized", directory=True))
    animate = ("animate", "{D}/r")
    doors.append(OutputDoor("animate: animation/", animate, "r/animation", True, trajectory))
    doors += [
        OutputDoor(f"animate: {n}", animate, f"r/animation/{n}", result=trajectory)
        for n in ANIMATION_FILES
    ]
    animated = (*opt[:-1], "{D}/o", "--animate")
    doors += [
        OutputDoor("optimize --animate: animation/", animated, "o/animation", directory=True),
        OutputDoor("optimize --animate: page", animated, "o/animation/animation.html"),
    ]
    return doors


@pytest.fixture(scope="module")
def door_inputs(tmp_path_factory) -> dict[str, str]:
    """A small model, a sweep spec of one case, and an optimised move (a result set)."""
    folder = tmp_path_factory.mktemp("door-inputs")
    random_model(n_points=6, n_modes=3).save(folder / "model.npz")
    (folder / "spec.json").write_text(json.dumps(DOOR_SPEC), encoding="utf-8")
    argv = ["optimize", str(folder / "model.npz"), "--distance", "0", "0", "1"]
    assert run_command([*argv, "--threshold", "1e-3", "--no-plots", "-o", str(folder / "opt")]) == 0
    return {k: str(folder / v) for k, v in (("model", "model.npz"), ("spec", "spec.json"),
                                             ("trajectory", "opt"))}  # fmt: skip


def _watched(root: Path) -> Path:
    watched = root / "watched"
    watched.mkdir()
    (watched / "victim.txt").write_text("the user's file", encoding="utf-8")
    return watched


def obstacle_outcome(door: OutputDoor, kind: str, root: Path, watched: Path) -> tuple[str, str]:
    """(outcome, detail) of ``door`` met by an obstacle of ``kind``: "clear" (refused, the
    path named, the tree under ``root`` unchanged), "corrupt" (ran, or changed a file),
    "vague" (refused without naming the path), "crash", "hang" or "impossible"."""
    case = root / f"case{next(SERIAL)}"
    if door.result is not None:
        shutil.copytree(door.result, case / "r")
    target = case / door.target
    target.parent.mkdir(parents=True, exist_ok=door.result is not None)
    if not plant(target, kind, watched):
        return "impossible", f"{door.label} {kind}"
    argv = [word.replace("{D}", str(case)) for word in door.argv]
    before = tree(root)
    label = f"{door.label} {kind}"
    try:
        with alarm(CASE_TIME_S):
            code = run_command(argv)
    except Refused as exc:
        after = tree(root)
        changed = sorted(k for k in before.keys() | after.keys() if before.get(k) != after.get(k))
        if changed:
            return "corrupt", f"{label}: refused but changed {changed}"
        if str(target) not in str(exc):
            return "vague", f"{label}: {exc}"
        return "clear", f"{label}: {exc}"
    except Hang:
        return "hang", label
    except Exception as exc:
        return "crash", f"{label}: {exc!r:.300}"
    return "corrupt", f"{label}: exit status {code}, the obstacle was not refused"


def test_output_door(tmp_path, door_inputs, fuzz_tally):
    """Every output of every command, met by a symbolic link (to a file, to a directory, to
    nothing), a FIFO, a device or a directory: refused before any work, naming the path,
    and nothing under the watched tree changes (not the link, not its target, no file
    created, no temporary file left)."""
    watched = _watched(tmp_path)
    results = []
    for door in output_doors(door_inputs):
        for kind in DIR_OBSTACLES if door.directory else FILE_OBSTACLES:
            results.append(obstacle_outcome(door, kind, tmp_path, watched))
    kinds = Counter(kind for kind, _ in results)
    fuzz_tally(
        "outputs (links, FIFOs, devices, dirs)",
        tried=len(results) - kinds["impossible"],
        clear_errors=kinds["clear"],
        crashes=kinds["crash"] + kinds["vague"],
        hangs=kinds["hang"],
        corrupt_accepted=kinds["corrupt"],
    )
    bad = [detail for kind, detail in results if kind not in ("clear", "impossible")]
    assert not bad, "\n".join(bad)


# One run per command with every output it writes a hard link to a file outside: the run
# gives each name a new file; the other names keep their content. (bench: refusals only, its
# run takes minutes; its files are written by the same jaxflex.files functions.)
HARD_LINK_RUNS = {
    "model": (
        ("model", "--scene", "plate", "--mesh-size", "0.2", "-o", "{D}/m.npz", "--plot",
         "{D}/p.png", "--vtu", "{D}/m.vtu"),
        ("m.npz", "p.png", "m.vtu"),
    ),
    "optimize": (
        ("optimize", "{model}", "--distance", "0", "0", "1", "--threshold", "1e-3", "-o", "{D}/o"),
        ("o/trajectory.csv", "o/report.json", "o/profiles.png", "o/deviation.png",
         "o/manifest.json", "o/robust.png"),
    ),
    "export": (
        ("export", "{model}", "--trajectory", "{trajectory}", "--no-verify", "-o", "{D}/x.fmu",
         "--ssp", "{D}/x.ssp"),
        ("x.fmu", "x_input.csv", "x_case.json", "x.ssp"),
    ),
    "sweep": (
        ("sweep", "{spec}", "--serial", "--no-plots", "-o", "{D}/s"),
        ("s/spec.json", "s/results.csv"),
    ),
}  # fmt: skip
NOT_WRITTEN = {"o/robust.png"}  # a nominal run's set has no robust plot: the name is removed
RUN_TIME_S = 1800.0  # per whole run: a hang guard far above its seconds on a loaded machine


def hard_link_outcome(command: str, root: Path, inputs: dict[str, str]) -> tuple[str, str]:
    """(outcome, detail) of a run whose outputs are hard links to files of a watched
    directory: "accepted" (exit 0, every output a new file, the watched files and
    everything else under ``root`` as they were), "corrupt" or "crash"."""
    argv, outputs = HARD_LINK_RUNS[command]
    case = root / f"hard-{command}"
    watched = case / "watched"
    watched.mkdir(parents=True)
    for i, name in enumerate(outputs):
        (watched / f"v{i}").write_text(f"the user's file {i}", encoding="utf-8")
        (case / name).parent.mkdir(exist_ok=True)
        os.link(watched / f"v{i}", case / name)
    before = tree(root)
    words = [w.replace("{D}", str(case)).format(**inputs) for w in argv]
    try:
        with alarm(RUN_TIME_S):
            code = run_command(words)
    except Exception as exc:
        return "crash", f"{command}: {exc!r:.300}"
    after = tree(root)
    inside = tuple(str((case / name).relative_to(root)) for name in outputs)
    sets = tuple(str((case / n).parent.relative_to(root)) + "/" for n in outputs if "/" in n)
    changed = sorted(k for k in before.keys() | after.keys() if before.get(k) != after.get(k)
                     and k not in inside and not k.startswith(sets))  # fmt: skip
    problems = [f"exit status {code}"] if code != 0 else []
    problems += [f"changed outside the outputs: {changed}"] if changed else []
    for i, name in enumerate(outputs):
        victim = watched / f"v{i}"
        if victim.read_text(encoding="utf-8") != f"the user's file {i}":
            problems.append(f"{name}: written through its hard link")
        path = case / name
        if name in NOT_WRITTEN:
            if os.path.lexists(path):
                problems.append(f"{name}: an earlier set's member was kept")
        elif not path.is_file() or path.stat().st_ino == victim.stat().st_ino:
            problems.append(f"{name}: not written as a new file")
    return ("corrupt", f"{command}: {problems}") if problems else ("accepted", command)


def test_output_door_hard_links(tmp_path, door_inputs, fuzz_tally):
    results = [hard_link_outcome(command, tmp_path, door_inputs) for command in HARD_LINK_RUNS]
    kinds = Counter(kind for kind, _ in results)
    fuzz_tally(
        "outputs (hard links)",
        tried=len(results),
        clear_errors=0,
        crashes=kinds["crash"],
        hangs=0,
        corrupt_accepted=kinds["corrupt"],
    )
    bad = [detail for kind, detail in results if kind != "accepted"]
    assert not bad, "\n".join(bad)
