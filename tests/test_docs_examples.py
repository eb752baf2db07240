"""Every example runs: the fenced code blocks of README.md and docs/*.md are executed as a
user would (docs/design.md, "Examples in the docs"):

* ``python`` blocks: in a fresh interpreter, in a temporary directory of their own;
* ``bash`` / ``sh`` blocks: with ``bash -eo pipefail`` there (every command must succeed);
* ``toml`` blocks: parsed;
* ``text`` blocks (output listings, usage synopses, file trees): never run.

A block marked by an HTML comment on the line before its fence is run under a condition:
``<!-- slow -->`` runs it under ``@pytest.mark.slow``; ``<!-- not run: REASON -->`` skips it
(the reason is required: install commands, a cluster, a benchmark run of minutes). A fence
without a language fails the test, so that nothing is left unrun by accident.

The temporary directory holds a copy of examples/ and the files the docs take as given when
the block names them: ``plate.npz`` and ``model.npz`` (the demo plate of ``jaxflex model
--scene plate``) and ``opt/`` (its move from ``jaxflex optimize``), built once per run and
shared by every worker."""

from __future__ import annotations

import fcntl
import os
import re
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(.*)$")
MARK = re.compile(r"^<!--\s*(slow|not run:\s*\S.*?)\s*-->$")
RUN = ("python", "bash", "sh", "toml")
# the files the docs take as given (built once by `given_files`), by the name a block uses
GIVEN = ("plate.npz", "model.npz", "opt")


@dataclass(frozen=True)
class Block:
    page: str
    line: int  # of the opening fence, 1-based
    language: str
    mark: str  # "", "slow" or "not run: ..."
    code: str

    @property
    def id(self) -> str:
        return f"{self.page}:{self.line}"


def blocks(path: Path) -> list[Block]:
    """The fenced blocks of a Markdown page, with the marker comment before each."""
    lines = path.read_text(encoding="utf-8").splitlines()
    found, i = [], 0
    while i < len(lines):
        opening = FENCE.match(lines[i])
        if not opening:
            i += 1
            continue
        end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
        mark = MARK.match(lines[i - 1].strip()) if i else None
        page = str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else path.name
        code = "\n".join(lines[i + 1 : end]) + "\n"
        found.append(Block(page, i + 1, opening.group(1).strip(), mark[1] if mark else "", code))
        i = end + 1
    return found


ALL = [block for page in PAGES for block in blocks(page)]


def test_the_page_parser_reads_fences_and_marks(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "text\n<!-- slow -->\n```python\nx = 1\n```\n\n```text\nout\n```\n"
        "<!-- not run: needs a cluster -->\n```bash\ndask scheduler\n```\n```\nbare\n```\n"
    )
    got = [(b.line, b.language, b.mark, b.code) for b in blocks(page)]
    assert got == [
        (3, "python", "slow", "x = 1\n"),
        (7, "text", "", "out\n"),
        (11, "bash", "not run: needs a cluster", "dask scheduler\n"),
        (14, "", "", "bare\n"),
    ]


@pytest.mark.parametrize("block", ALL, ids=lambda b: b.id)
def test_every_block_says_how_it_is_treated(block):
    assert block.language in (*RUN, "text"), (
        f"{block.id}: a fence needs a language: python, bash, sh or toml (run) or text (not run)"
    )
    assert block.language in RUN or not block.mark, f"{block.id}: a text block is never run"


def _runnable() -> list:
    params = []
    for block in ALL:
        if block.language not in RUN or block.mark.startswith("not run"):
            continue
        marks = [pytest.mark.slow] if block.mark == "slow" else []
        params.append(pytest.param(block, id=block.id, marks=marks))
    return params


def _build_given(folder: Path) -> None:
    """The plate model and its optimised move, as the docs' commands make them."""
    env = _environment()
    jaxflex = [sys.executable, "-m", "jaxflex"]
    for args in (
        ["model", "--scene", "plate", "-q", "-o", "plate.npz"],
        ["optimize", "plate.npz", "--distance", "0", "0", "1", "--threshold", "5e-4", "-o", "opt"],
    ):
        done = subprocess.run(jaxflex + args, cwd=folder, env=env, capture_output=True, text=True)
        assert done.returncode == 0, f"jaxflex {' '.join(args)}:\n{done.stderr[-3000:]}"
    shutil.copy(folder / "plate.npz", folder / "model.npz")


@pytest.fixture(scope="session")
def given_files(tmp_path_factory) -> Path:
    """A folder with plate.npz, model.npz and opt/, built by the first worker that needs it
    (a lock on a file in the session's root: every xdist worker shares one build)."""
    base = tmp_path_factory.getbasetemp()
    root = base.parent if base.name.startswith("popen-") else base
    folder = root / "docs-given"
    with open(root / "docs-given.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (folder / "done").is_file():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            _build_given(folder)
            (folder / "done").write_text("")
    return folder


def _environment() -> dict[str, str]:
    """The user's shell: this interpreter's `jaxflex` first on PATH, plots to files."""
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    return env


@pytest.mark.parametrize("block", _runnable())
def test_example_runs(block, tmp_path, request):
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    needed = [name for name in GIVEN if re.search(rf"\b{re.escape(name)}\b", block.code)]
    if needed:
        given = request.getfixturevalue("given_files")
        for name in needed:
            source = given / name
            copy = shutil.copytree if source.is_dir() else shutil.copy
            copy(source, tmp_path / name)
    if block.language == "toml":
        assert tomllib.loads(block.code), block.id
        return
    command = (
        [sys.executable, "-c", block.code]
        if block.language == "python"
        else ["bash", "-eo", "pipefail", "-c", block.code]
    )
    done = subprocess.run(command, cwd=tmp_path, env=_environment(), capture_output=True, text=True)
    assert done.returncode == 0, f"{block.id} failed:\n{done.stdout[-2000:]}\n{done.stderr[-4000:]}"
