"""The upper layers (fem, optim, fmu) enter the core only through its public interface:
`jaxflex` and the submodules listed in jaxflex/__init__.py's docstring (docs/design.md,
"The public core"), each name in that module's ``__all__``. Every other core module is
private by name (``_x.py``) and free to change. Read from the sources (ast), nothing imported."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PUBLIC = (
    "jaxflex",
    "jaxflex.model",
    "jaxflex.defaults",
    "jaxflex.errors",
    "jaxflex.isolated",
    "jaxflex.stdout",
    "jaxflex.response",
    "jaxflex.geometry",
    "jaxflex.files",
    "jaxflex.runtime",
    "jaxflex.reference",
    "jaxflex.plots",
    "jaxflex.cli",
    "jaxflex.lazy",
)
UPPER = ("fem", "optim", "fmu")


def _source(module: str) -> Path:
    path = ROOT / module.replace(".", "/")
    return path / "__init__.py" if path.is_dir() else path.with_suffix(".py")


def _declared(module: str) -> set[str]:
    """The names in ``module``'s literal ``__all__``."""
    for node in ast.parse(_source(module).read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets
        ):
            return set(ast.literal_eval(node.value))
    raise AssertionError(f"{module}: no literal __all__")


def _defined(module: str) -> set[str]:
    """Names bound at the top level of ``module`` (definitions, assignments, imports; the
    imports of an ``if TYPE_CHECKING:`` block are the names jaxflex.lazy imports on first
    use)."""
    names = set()
    body = ast.parse(_source(module).read_text(encoding="utf-8")).body
    lazy = [n for n in body if isinstance(n, ast.If) and ast.unparse(n.test) == "TYPE_CHECKING"]
    for node in [*body, *(line for block in lazy for line in block.body)]:
        if isinstance(node, ast.FunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Assign):
            names.update(t.id for t in node.targets if isinstance(t, ast.Name))
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, ast.ImportFrom | ast.Import):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
    return names


def core_uses(source: str) -> set[tuple[str, str]]:
    """(module, name) of every core name ``source`` uses: ``from jaxflex.X import Y``,
    ``import jaxflex.X`` (name ""), and ``jaxflex.Y`` / ``jaxflex.X.Y`` attributes."""
    uses = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module.split(".")[0] == "jaxflex":
                uses.update((node.module, a.name) for a in node.names)
        elif isinstance(node, ast.Import):
            uses.update((a.name, "") for a in node.names if a.name.startswith("jaxflex."))
        elif isinstance(node, ast.Attribute):
            chain = [node.attr]
            value = node.value
            while isinstance(value, ast.Attribute):
                chain.append(value.attr)
                value = value.value
            if not (isinstance(value, ast.Name) and value.id == "jaxflex"):
                continue
            if len(chain) == 1 and f"jaxflex.{chain[0]}" not in PUBLIC:
                uses.add(("jaxflex", chain[0]))  # jaxflex.y; jaxflex.x alone: a module
            elif len(chain) > 1 and f"jaxflex.{chain[-1]}" in PUBLIC:
                uses.add((f"jaxflex.{chain[-1]}", chain[-2]))  # jaxflex.x.y
    return uses


def private_uses(source: str) -> list[str]:
    """The uses in ``source`` of a core module or name that is not public."""
    bad = []
    for module, name in sorted(core_uses(source)):
        if module not in PUBLIC:
            bad.append(f"{module} (a private module)")
        elif name and name != "__version__" and name not in _declared(module):
            bad.append(f"{module}.{name} (not in its __all__)")
    return bad


def test_the_scan_finds_private_uses():
    source = (
        "import jaxflex\nimport jaxflex._engine\nfrom jaxflex._engine import state_map\n"
        "from jaxflex import simulate, _private\nfrom jaxflex.response import state_map\n"
        "jaxflex._collision.min_distance()\njaxflex.simulate()\n"
    )
    assert private_uses(source) == [
        "jaxflex._collision (not in its __all__)",
        "jaxflex._private (not in its __all__)",
        "jaxflex._engine (a private module)",
        "jaxflex._engine (a private module)",
    ]


def test_privacy_is_in_the_module_names():
    """A core module is public exactly when its name has no leading underscore: the plain
    names are PUBLIC's, every other module (or sub-package) is private by name, ``_x.py``
    (docs/design.md, "The public core")."""
    core = ROOT / "jaxflex"
    modules = {p.stem for p in core.glob("*.py")} - {"__init__", "__main__"}
    modules |= {p.parent.name for p in core.glob("*/__init__.py")}
    public = {module.removeprefix("jaxflex.") for module in PUBLIC[1:]}
    assert {m for m in modules if not m.startswith("_")} == public


@pytest.mark.parametrize("module", PUBLIC)
def test_public_modules_declare_what_they_define(module):
    declared = _declared(module)
    assert declared and not declared - _defined(module)
    assert all(not name.startswith("_") for name in declared)


def test_public_modules_are_documented():
    doc = ast.get_docstring(ast.parse(_source("jaxflex").read_text(encoding="utf-8")))
    design = (ROOT / "docs" / "design.md").read_text(encoding="utf-8")
    for module in PUBLIC[1:]:
        assert f"``{module}``" in doc and f"`{module}`" in design, module


@pytest.mark.parametrize("layer", UPPER)
def test_upper_layers_use_only_the_public_core(layer):
    bad = {
        str(path.relative_to(ROOT)): found
        for path in sorted((ROOT / layer).rglob("*.py"))
        if (found := private_uses(path.read_text(encoding="utf-8")))
    }
    assert bad == {}


def test_readers_load_in_their_child_process():
    """A reader run by jaxflex.isolated is imported in a child where the packages are bare
    namespaces (their __init__ does not run): neither it nor what it imports may take names
    from a package's __init__ (e.g. ``from jaxflex import X``), and none loads JAX (a second
    of CPU in every read's child for nothing: the readers use NumPy and their libraries)."""
    readers = sorted(
        ".".join(path.relative_to(ROOT).with_suffix("").parts)
        for layer in UPPER
        for path in (ROOT / layer).rglob("*.py")
        if "@isolated(" in path.read_text(encoding="utf-8")
    )
    assert readers  # fem's ANSYS, CAD and mesh-file readers at least
    program = (
        "import importlib, sys, types\n"
        f"sys.path.insert(0, {str(ROOT)!r})\n"
        f"for name in ('jaxflex', *{UPPER!r}):\n"
        "    package = types.ModuleType(name)\n"
        f"    package.__path__ = [{str(ROOT)!r} + '/' + name]\n"
        "    sys.modules[name] = package\n"
        f"for module in {readers!r}:\n"
        "    importlib.import_module(module)\n"
        "    if 'jax' in sys.modules:\n"
        "        sys.exit(module + ' loads JAX')\n"
    )
    done = subprocess.run([sys.executable, "-I", "-c", program], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]


# docs/design.md is the developers' map of the modules (its "The public core" and "Where each
# concern lives" name the private modules on purpose); the other pages are for users
USER_PAGES = [
    ROOT / "README.md",
    *sorted(p for p in (ROOT / "docs").glob("*.md") if p.name != "design.md"),
]


def private_mentions(text: str) -> list[str]:
    """``line N: name`` for every private core name ``text`` names: a ``jaxflex.X`` that is
    neither a public module nor a name of the public ``jaxflex`` namespace (nor an entry-point
    group of pyproject.toml), a ``jaxflex.M.Y`` of a public module ``M`` whose ``__all__``
    lacks ``Y``, or a ``jaxflex/X.py`` file of a private module."""
    top = _declared("jaxflex")
    groups = set(re.findall(r"project\.entry-points\.\"?jaxflex\.([a-z_]+)", _pyproject()))
    found = []
    for number, line in enumerate(text.splitlines(), start=1):
        named = set(re.findall(r"\bjaxflex\.([A-Za-z_]\w*)", line)) - groups
        members = set(re.findall(r"\bjaxflex\.([a-z_]+)\.([A-Za-z_]\w*)", line))
        files = set(re.findall(r"\bjaxflex/([a-z_]+)\.py", line))
        private = {f"jaxflex.{n}" for n in named if f"jaxflex.{n}" not in PUBLIC and n not in top}
        private |= {
            f"jaxflex.{m}.{n}"
            for m, n in members
            if f"jaxflex.{m}" in PUBLIC and n not in _declared(f"jaxflex.{m}")
        }
        private |= {f"jaxflex/{f}.py" for f in files if f"jaxflex.{f}" not in PUBLIC}
        found += [f"line {number}: {name}" for name in sorted(private)]
    return found


def test_the_mention_scan_finds_private_names():
    text = (
        "`jaxflex.simulate`, `jaxflex.Turn` and `jaxflex.response.state_map`, `jaxflex.cli`\n"
        "see `jaxflex._turning_bound` and jaxflex/_engine.py, not jaxflex/cli.py\n"
        "`jaxflex.Private`, `jaxflex.response.blocks_of`, `jaxflex._turning.Turn`\n"
    )
    assert private_mentions(text) == [
        "line 2: jaxflex._turning_bound",
        "line 2: jaxflex/_engine.py",
        "line 3: jaxflex.Private",
        "line 3: jaxflex._turning",
        "line 3: jaxflex.response.blocks_of",
    ]


@pytest.mark.parametrize("page", USER_PAGES, ids=lambda page: page.name)
def test_the_user_docs_name_only_public_core_names(page):
    """The README and the user pages of docs/ send users to public names only: every
    ``jaxflex.X`` they name is a public module or a name of the public ``jaxflex``
    namespace, every ``jaxflex.M.Y`` of a public module a name in its ``__all__``, and no
    ``jaxflex/X.py`` file of a private module (the private modules are free to change).
    docs/design.md is left out: it is the developers' map of the modules and names the
    private ones on purpose; a user page points there for the internals."""
    found = private_mentions(page.read_text(encoding="utf-8"))
    assert not found, f"{page.relative_to(ROOT)} names private core names: " + "; ".join(found)


def _pyproject() -> str:
    return (ROOT / "pyproject.toml").read_text(encoding="utf-8")


def test_a_lazy_package_gives_its_submodules_whatever_was_imported_before():
    """In a fresh interpreter, ``import fem`` then ``fem.materials.PRESETS``: a submodule is an
    attribute of its lazy package as it was of the eager one, not only after something else
    imported it; a name that is neither a lazy name nor a submodule is an AttributeError."""
    code = (
        "import fem, optim\n"
        "assert fem.materials.PRESETS['steel'].E_pa > 1e11\n"
        "assert optim.sweep.read_table\n"
        "try:\n    fem.no_such_module\nexcept AttributeError:\n    print('refused')\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "refused"
