"""Packages are entered through their ``__init__``: a module of one harness package imports
another package's names only from a package (``from harness.<package> import <name>``, or a
subpackage such as ``harness.session.core``), and only names that package lists in ``__all__``
(issue 32). Plain modules are their package's own business."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

HARNESS = Path(__file__).resolve().parents[2] / "harness"
PACKAGES = {p.name for p in HARNESS.iterdir() if (p / "__init__.py").is_file()}
# The plugin's pytest11 entry point lives beside its package, as pytest plugins do.
OWNER = {"pytest_plugin.py": "plugin"}


def _is_package(module: str) -> bool:
    return (HARNESS.parent.joinpath(*module.split(".")) / "__init__.py").is_file()


def _imports() -> list[tuple[str, int, str, tuple[str, ...]]]:
    found = []
    for path in sorted(HARNESS.rglob("*.py")):
        parts = path.relative_to(HARNESS).parts
        own = parts[0] if len(parts) > 1 else OWNER.get(parts[0])
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.ImportFrom) or node.level or not node.module:
                continue
            names = node.module.split(".")
            if names[0] != "harness" or len(names) < 2 or names[1] not in PACKAGES:
                continue
            if names[1] != own:
                where = f"{path.relative_to(HARNESS.parent)}:{node.lineno}"
                found.append((where, node.lineno, node.module, tuple(a.name for a in node.names)))
    return found


def test_no_package_imports_another_packages_submodule() -> None:
    wrong = [
        f"{where}: from {module} import {', '.join(names)}"
        for where, _, module, names in _imports()
        if not _is_package(module)
    ]
    assert not wrong, "enter these packages through their __init__:\n" + "\n".join(wrong)


def test_names_imported_across_packages_are_in_the_packages_all() -> None:
    wrong = []
    for where, _, module, names in _imports():
        if not _is_package(module):
            continue
        exported = set(importlib.import_module(module).__all__)
        wrong += [f"{where}: {module}.{n}" for n in names if n not in exported]
    assert not wrong, "not in the package's __all__:\n" + "\n".join(wrong)
