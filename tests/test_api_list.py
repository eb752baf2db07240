"""docs/api.md lists every public name once, with what it is (docs/make_api.py writes it from
the packages' __all__ and docstrings): the page and the code cannot drift apart, and every
public name has a docstring or a value to show."""

from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))

import make_api  # noqa: E402  (docs/ is not a package)


def test_the_page_is_what_the_code_says():
    page = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    assert page == make_api.page(), "docs/api.md is out of date: run python docs/make_api.py"


def test_every_public_name_is_listed_once_with_a_description():
    page = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| `([^`]+)` \| (\w+) \| (.*) \|$", page, flags=re.M)
    listed = [name for name, kind, _ in rows if kind != "namespace"]
    every = {
        name
        for space in make_api.namespaces()
        for name in getattr(importlib.import_module(space), "__all__", [])
    }
    names = [name for name, _, _ in rows if not name.startswith(("jaxflex", "fem", "optim", "fmu"))]
    assert sorted(set(names)) == sorted(names), "a name listed twice"
    assert every <= set(listed), f"not listed: {sorted(every - set(listed))}"
    empty = [name for name, _, text in rows if not text.strip()]
    assert not empty, f"no description: {empty}"


def test_a_first_sentence_is_cut_at_its_full_stop():
    def documented():
        """Cup reactions in N (n+1, K). The rest is detail, e.g. the units."""

    assert make_api.first_sentence(documented) == "Cup reactions in N (n+1, K)."
    assert make_api.first_sentence(lambda: None) == ""
