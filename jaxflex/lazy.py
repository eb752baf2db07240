"""Names of a module imported on first use (PEP 562), so that importing a package or a
public module costs nothing until one of its names is used: ``jaxflex --version``, ``--help``
and argument errors answer without loading JAX, SciPy or scikit-fem (docs/design.md, "A
command answers at the speed of its work").

A module imports its lazy names under ``if TYPE_CHECKING:`` (what type checkers and readers
see) and hands itself to :func:`lazy_names`, which reads those imports from its source::

    from typing import TYPE_CHECKING

    from jaxflex.lazy import lazy_names

    if TYPE_CHECKING:
        from optim.options import Search

    __getattr__, __dir__ = lazy_names(__name__)

Light (the standard library only): every package's ``__init__`` uses it. The core also
sets JAX up as JAX is imported, not before (:func:`after_import`: float64, the persistent
compilation cache), so that what runs without JAX never loads it.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import sys
import threading
import types
from collections.abc import Callable, Mapping
from pathlib import Path

__all__ = ["lazy_names"]


class _LazyModule(types.ModuleType):
    """A module whose lazily imported names stay what its imports say: importing a submodule
    that shares a public name (``optim.optimize``) does not replace the name by the submodule
    (the import system binds every submodule to its package's attribute); the name is the
    function, as when the package imported it eagerly."""

    _lazy_sources: Mapping[str, str] = {}

    def __setattr__(self, name: str, value) -> None:
        if isinstance(value, types.ModuleType) and name in self._lazy_sources:
            return
        super().__setattr__(name, value)


def type_checking_imports(source: str) -> dict[str, tuple[str, str]]:
    """{name: (module, attribute)} of the ``from MODULE import ATTRIBUTE [as NAME]`` lines in
    the top-level ``if TYPE_CHECKING:`` blocks of the Python ``source``."""
    found = {}
    for node in ast.parse(source).body:
        if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING":
            for line in node.body:
                if isinstance(line, ast.ImportFrom) and line.level == 0 and line.module:
                    for alias in line.names:
                        found[alias.asname or alias.name] = (line.module, alias.name)
    return found


def lazy_names(module_name: str) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of module ``module_name``: each name its
    ``if TYPE_CHECKING:`` block imports is imported from its module on first use and then
    kept in the module's namespace."""
    module = sys.modules[module_name]
    sources = type_checking_imports(Path(module.__file__).read_text(encoding="utf-8"))

    def __getattr__(name: str):
        if name not in sources:
            submodule = _submodule(module, name)
            if submodule is None:
                raise AttributeError(f"module {module_name!r} has no attribute {name!r}")
            return submodule
        source, attribute = sources[name]
        value = getattr(importlib.import_module(source), attribute)
        module.__dict__[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*module.__dict__, *sources})

    module.__class__ = _LazyModule
    module._lazy_sources = sources
    return __getattr__, __dir__


def _submodule(package: types.ModuleType, name: str) -> types.ModuleType | None:
    """The submodule ``name`` of ``package``, imported (None: the package has none of that
    name). A package that imported its names eagerly had every submodule they come from bound
    as an attribute (``fem.materials.PRESETS`` after ``import fem``); a lazy package binds one
    only when it is imported, so without this an attribute would work or not depending on
    what the process had imported before."""
    if name.startswith("__") or "__path__" not in package.__dict__:  # not a package
        return None
    full = f"{package.__name__}.{name}"
    if full not in sys.modules and importlib.util.find_spec(full) is None:
        return None
    return importlib.import_module(full)


_after: dict[str, list[Callable[[types.ModuleType], None]]] = {}  # module name: callbacks
_after_lock = threading.Lock()


def after_import(name: str, callback: Callable[[types.ModuleType], None]) -> None:
    """Call ``callback(module)`` once the module ``name`` (``jax``, ``matplotlib.pyplot``) is
    imported: now if it is, else right after its import (before anything can use it). The
    core's set-up of JAX (float64, the compilation cache) runs this way, so that a command
    that needs no JAX does not load it."""
    with _after_lock:
        module = sys.modules.get(name)
        if module is None:
            if name not in _after:
                _after[name] = []
                sys.meta_path.insert(0, _AfterImport(name))
            _after[name].append(callback)
            return
    callback(module)


class _AfterImport:
    """A finder and loader of the import system (sys.meta_path) for one module:
    it loads the module with the module's own loader, then calls the module's
    :func:`after_import` callbacks."""

    def __init__(self, name: str) -> None:
        self._name = name
        self._loader = None

    def find_spec(self, fullname, path=None, target=None):
        if fullname != self._name:
            return None
        sys.meta_path.remove(self)  # once; the other finders find the module
        spec = importlib.util.find_spec(fullname)
        if spec is None or spec.loader is None:
            return spec
        self._loader = spec.loader
        spec.loader = self
        return spec

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module) -> None:
        module.__spec__.loader = module.__loader__ = self._loader  # its own from now on
        self._loader.exec_module(module)
        with _after_lock:
            callbacks = _after.pop(self._name, [])
        for callback in callbacks:
            callback(module)
