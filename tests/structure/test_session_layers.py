"""The session's two layers (issue 32): ``harness.session.core`` is sans-I/O and knows no file
format; ``harness.session.live`` is the shell around it.

Read from the source, direct imports only (at any level of a module, TYPE_CHECKING included).
What another package loads in turn is that package's business, so a core module may import
``harness.rosbridge`` (the protocol), not ``websockets``.
"""

from __future__ import annotations

import ast
import importlib
import sys
import warnings
from pathlib import Path

import pytest

from tests.structure.importgraph import ROOT, import_graph, modules_of

CORE = ROOT / "session" / "core"
IO_MODULES = (
    "asyncio",
    "concurrent",
    "mcap",
    "multiprocessing",
    "selectors",
    "socket",
    "subprocess",
    "threading",
    "time",
    "websockets",
)
"""What the core must not import: sockets, threads, the wall clock, the MCAP library."""


def _imported_names(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            names.add(node.module)
    return names


def _core_modules() -> dict[str, Path]:
    return {m: p for m, p in modules_of().items() if m.startswith("harness.session.core")}


def test_the_core_has_modules() -> None:
    assert {"harness.session.core.engine", "harness.session.core.bridge"} <= set(_core_modules())


@pytest.mark.parametrize("banned", IO_MODULES)
def test_the_core_imports_no_io_or_wall_clock(banned: str) -> None:
    offenders = {
        module: sorted(n for n in _imported_names(path) if n.split(".")[0] == banned)
        for module, path in _core_modules().items()
    }
    offenders = {m: n for m, n in offenders.items() if n}
    assert not offenders, f"the session core imports {banned}: {offenders}"


def test_the_core_imports_neither_the_shell_nor_recording_internals() -> None:
    graph = import_graph()
    wrong = {
        module: sorted(
            target
            for target in graph[module]
            if target.startswith("harness.session.live")
            or target == "harness.session"
            or target.startswith("harness.recording.")
        )
        for module in _core_modules()
    }
    wrong = {m: t for m, t in wrong.items() if t}
    assert not wrong, f"the session core imports the shell or recording submodules: {wrong}"


def test_no_session_module_rewrites_mcap() -> None:
    users = {
        m: p
        for m, p in modules_of().items()
        if m.startswith("harness.session") and any(n.startswith("mcap") for n in _imported_names(p))
    }
    assert not users, f"file formats belong to harness.recording: {sorted(users)}"


OLD_PATHS = {
    "harness.session.bridge": "harness.session.core.bridge",
    "harness.session.control": "harness.session.core.control",
    "harness.session.options": "harness.session.core.options",
    "harness.session.markers": "harness.session.core.markers",
    "harness.session.session": "harness.session.live.session",
    "harness.session.polling": "harness.session.live.polling",
    "harness.session._cli": "harness.session.live._cli",
    "harness.session.snapshot": "harness.recording.snapshot",
}


def test_no_file_at_an_old_path() -> None:
    known = modules_of()
    assert not [old for old in OLD_PATHS if old in known]
    assert all(new in known for new in OLD_PATHS.values())


@pytest.mark.parametrize("old", sorted(OLD_PATHS))
def test_an_old_path_imports_the_new_module_with_a_warning(old: str) -> None:
    import harness.session  # noqa: F401  (registers the old paths)

    sys.modules.pop(old, None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        module = importlib.import_module(old)
    assert module is importlib.import_module(OLD_PATHS[old])
    assert any(
        issubclass(w.category, DeprecationWarning) and OLD_PATHS[old] in str(w.message)
        for w in caught
    ), [str(w.message) for w in caught]
