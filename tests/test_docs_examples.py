"""Every page runs pasted top to bottom: the fenced code blocks of README.md and docs/*.md
are executed in order, as a user who pastes the page would (docs/design.md, "Examples in the
docs"), in one fresh directory per page that holds only a copy of examples/:

* ``python`` blocks: each in a fresh interpreter;
* ``bash`` / ``sh`` blocks: with ``bash -eo pipefail`` (every command must succeed);
* ``toml`` blocks: parsed;
* ``text`` blocks (output listings, usage synopses, file trees): never run.

So a page stands alone: what a block reads (a model file, an optimised move) is made by an
earlier block of the same page, never provided by the test. A block marked by an HTML comment
on the line before its fence is run under a condition: ``<!-- slow -->`` puts its page under
``@pytest.mark.slow``; ``<!-- not run: REASON -->`` skips it (the reason is required: install
commands, a cluster, a benchmark run of minutes), so a later block must not read what it
writes. A fence without a language fails the test, so that nothing is left unrun by
accident."""

from __future__ import annotations

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


def _runnable(page: Path) -> list[Block]:
    """The blocks of a page that run, in page order."""
    return [b for b in blocks(page) if b.language in RUN and not b.mark.startswith("not run")]


def _pages() -> list:
    params = []
    for page in PAGES:
        runnable = _runnable(page)
        if runnable:
            marks = [pytest.mark.slow] if any(b.mark == "slow" for b in runnable) else []
            params.append(pytest.param(page, id=str(page.relative_to(ROOT)), marks=marks))
    return params


def _environment() -> dict[str, str]:
    """The user's shell: this interpreter's `jaxflex` first on PATH, plots to files."""
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    return env


def _run(block: Block, folder: Path) -> None:
    if block.language == "toml":
        assert tomllib.loads(block.code), block.id
        return
    command = (
        [sys.executable, "-c", block.code]
        if block.language == "python"
        else ["bash", "-eo", "pipefail", "-c", block.code]
    )
    done = subprocess.run(command, cwd=folder, env=_environment(), capture_output=True, text=True)
    assert done.returncode == 0, f"{block.id} failed:\n{done.stdout[-2000:]}\n{done.stderr[-4000:]}"


@pytest.mark.parametrize("page", _pages())
def test_page_runs_top_to_bottom(page, tmp_path):
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    for block in _runnable(page):
        _run(block, tmp_path)


def test_a_page_that_reads_what_no_earlier_block_made_fails(tmp_path):
    """The harness itself: a block reading a model no earlier block of its page wrote fails
    in the page's fresh directory (nothing is provided beside examples/)."""
    page = tmp_path / "page.md"
    page.write_text('```python\nimport jaxflex\njaxflex.load_model("plate.npz")\n```\n')
    folder = tmp_path / "run"
    folder.mkdir()
    with pytest.raises(AssertionError, match=r"page\.md:1 failed"):
        for block in _runnable(page):
            _run(block, folder)
