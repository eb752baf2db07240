"""The packages stand in layers: a module imports only from its own layer and the ones below,
anywhere in the module (also inside functions). The core imports none of its users; the
`jaxflex` command finds theirs through entry points (jaxflex/cli.py)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# bottom to top; a module belongs to the longest of these names that its own name starts with
LAYERS = ("jaxflex", "fem", "optim", "optim.sweep", "fmu")


def _layer(module: str) -> int | None:
    """Index in LAYERS of a dotted module name (None: not one of ours)."""
    matches = [
        i for i, name in enumerate(LAYERS) if module == name or module.startswith(name + ".")
    ]
    return max(matches, key=lambda i: len(LAYERS[i])) if matches else None


def _imports(path: Path) -> set[str]:
    """Every absolute dotted name imported anywhere in ``path`` (``from a import b``: a.b)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def test_layer_of_a_name():
    assert _layer("jaxflex.cli") == 0
    assert _layer("optim.limits") == 2
    assert _layer("optim.sweep.run") == 3
    assert _layer("optimization") is None and _layer("numpy") is None


@pytest.mark.parametrize("layer", LAYERS)
def test_no_module_imports_a_higher_layer(layer):
    index = LAYERS.index(layer)
    modules = {
        ".".join(path.relative_to(ROOT).with_suffix("").parts): path
        for path in (ROOT / layer.replace(".", "/")).rglob("*.py")
    }
    upward = {
        module: sorted(name for name in _imports(path) if (_layer(name) or 0) > index)
        for module, path in modules.items()
        if _layer(module) == index
    }
    assert modules and {module: names for module, names in upward.items() if names} == {}
