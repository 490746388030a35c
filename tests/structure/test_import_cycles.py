"""No module of ``harness`` is part of an import cycle (issue 32).

The graph is read from the source (:mod:`tests.structure.importgraph`): module-level imports,
imports inside functions and imports under ``if TYPE_CHECKING:`` all count, so a cycle cannot
hide behind a lazy import. A failure prints each cycle as a closed path of modules.

"""

from __future__ import annotations

from pathlib import Path

from tests.structure.importgraph import ROOT, cycle_in, cycles, import_graph


def _report(graph: dict[str, set[str]], found: list[frozenset[str]]) -> str:
    return "\n".join(
        f"  {len(c)} modules: " + " -> ".join(cycle_in(graph, c)) + f"  (all: {sorted(c)})"
        for c in found
    )


def test_no_import_cycle_in_harness() -> None:
    graph = import_graph()
    found = cycles(graph)
    assert not found, f"{len(found)} import cycle(s) in harness/:\n" + _report(graph, found)


def test_the_session_core_is_a_layer_of_its_own() -> None:
    """The session's core modules form no cycle with anything, the 7-module one included
    (the reason this test exists: it hid behind TYPE_CHECKING and lazy imports)."""
    graph = import_graph()
    session = [c for c in cycles(graph) if any(m.startswith("harness.session") for m in c)]
    assert not session, _report(graph, session)
    assert (ROOT / "session" / "core" / "engine.py").is_file()


def _package(root: Path, files: dict[str, str]) -> Path:
    package = root / "pkg"
    for name, text in files.items():
        path = package / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return package


def test_lazy_and_type_checking_imports_count(tmp_path: Path) -> None:
    """The reader itself: a cycle made only of an ``if TYPE_CHECKING:`` import and an import
    inside a function (relative, from the package) is found; plain one-way imports are not."""
    package = _package(
        tmp_path,
        {
            "__init__.py": "",
            "a.py": "import typing\nif typing.TYPE_CHECKING:\n    from pkg.b import B\n",
            "b.py": "def f():\n    from . import a\n    return a\nclass B: ...\n",
            "c.py": "import pkg.d\nfrom pkg import a\n",
            "d.py": "import json\n",
            "sub/__init__.py": "from .e import E\n",
            "sub/e.py": "from ..c import *\nclass E: ...\n",
        },
    )
    graph = import_graph(package)
    assert graph["pkg.a"] == {"pkg.b"}
    assert graph["pkg.b"] == {"pkg.a"}
    assert graph["pkg.c"] == {"pkg.a", "pkg.d"}
    assert graph["pkg.sub"] == {"pkg.sub.e"}
    assert graph["pkg.sub.e"] == {"pkg.c"}
    found = cycles(graph)
    assert found == [frozenset({"pkg.a", "pkg.b"})]
    assert cycle_in(graph, found[0]) == ["pkg.a", "pkg.b", "pkg.a"]


def test_an_old_path_counts_as_its_package(tmp_path: Path) -> None:
    """An import of a module that has no file (an old path :mod:`harness._moved` aliases)
    is an edge to its nearest package: that package's ``__init__`` makes the alias."""
    package = _package(
        tmp_path,
        {
            "__init__.py": "from pkg.new import thing\n",
            "new.py": "thing = 1\n",
            "user.py": "from pkg.old import thing\n",
        },
    )
    assert import_graph(package)["pkg.user"] == {"pkg"}
