"""The notebooks in notebooks/: every one executes without a cell error, and every one is
committed with its outputs stripped.

Each notebook runs in a fresh kernel ("python3", which jupyter_client starts with this
interpreter: checked by ``test_kernel_runs_this_interpreter``) in a temporary working
directory, with ``JAXFLEX_NOTEBOOK_QUICK=1`` so that it uses its small settings (coarse
meshes, few layouts, few modes; < 60 s each on 2 cores). The notebooks write only into their
working directory; the test checks that notebooks/ is unchanged afterwards.
"""

from __future__ import annotations

import ast
import importlib
import sys
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK_DIR = ROOT / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
QUICK_ENV = "JAXFLEX_NOTEBOOK_QUICK"
KERNEL = "python3"
PROJECT = ("jaxflex", "fem", "optim", "fmu")
CELL_TIMEOUT_S = 600  # generous: the machine may be shared; the quick budget is ~60 s in all


def _execute(nb: nbformat.NotebookNode, cwd: Path) -> nbformat.NotebookNode:
    client = NotebookClient(
        nb,
        timeout=CELL_TIMEOUT_S,
        kernel_name=KERNEL,
        resources={"metadata": {"path": str(cwd)}},
    )
    return client.execute()  # raises CellExecutionError (with the traceback) on any error


def _snapshot(directory: Path) -> dict[str, int]:
    return {str(p.relative_to(directory)): p.stat().st_mtime_ns for p in directory.rglob("*")}


def _stdout(nb: nbformat.NotebookNode) -> str:
    return "".join(
        out.get("text", "")
        for cell in nb.cells
        if cell.cell_type == "code"
        for out in cell.outputs
        if out.output_type == "stream" and out.name == "stdout"
    )


def test_notebooks_exist():
    names = {p.name for p in NOTEBOOKS}
    assert {"gripper_layouts.ipynb", "fmu_round_trip.ipynb"} <= names, names


def test_kernel_runs_this_interpreter(tmp_path):
    """nbclient's "python3" kernel is this virtualenv's Python (jupyter_client replaces the
    kernel spec's bare "python" by sys.executable), so the notebooks see the installed
    jaxflex, fem, optim and fmu."""
    nb = nbformat.v4.new_notebook()
    nb.cells.append(nbformat.v4.new_code_cell("import sys\nprint(sys.prefix)\nimport jaxflex"))
    executed = _execute(nb, tmp_path)
    assert _stdout(executed).strip() == sys.prefix


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_executes(path, tmp_path, monkeypatch):
    monkeypatch.setenv(QUICK_ENV, "1")  # the kernel inherits this process's environment
    before = _snapshot(NOTEBOOK_DIR)
    nb = nbformat.read(path, as_version=4)
    _execute(nb, tmp_path)
    assert _snapshot(NOTEBOOK_DIR) == before, "a notebook wrote into notebooks/"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_outputs_stripped(path):
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    dirty = [
        i
        for i, cell in enumerate(nb.cells)
        if cell.cell_type == "code" and (cell.outputs or cell.execution_count is not None)
    ]
    assert not dirty, f"{path.name}: cells {dirty} have outputs; strip them before committing"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebooks_use_the_public_packages_only(path):
    """Every name a notebook imports from the project is in a package's ``__all__`` (no
    module paths into the packages, no internals such as a sweep's result store)."""
    nb = nbformat.read(path, as_version=4)
    code = "\n".join(
        "\n".join(line for line in cell.source.splitlines() if not line.startswith("%"))
        for cell in nb.cells
        if cell.cell_type == "code"
    )
    for node in ast.walk(ast.parse(code)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] in PROJECT:
                    assert alias.name in PROJECT, f"{path.name}: import {alias.name}"
        elif isinstance(node, ast.ImportFrom) and node.module.split(".")[0] in PROJECT:
            public = importlib.import_module(node.module).__dict__.get("__all__")
            assert public is not None, f"{path.name}: {node.module} is not a public package"
            for alias in node.names:
                assert alias.name in public, f"{path.name}: {node.module}.{alias.name}"
