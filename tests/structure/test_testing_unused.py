"""``harness/testing.py`` (the test client) is for users' tests: no module of the package imports
it (issue 32: replay re-ran mobile bases through it). Read from the source, so that an import
inside a function, under ``TYPE_CHECKING`` or by ``importlib`` counts as much as one at the top."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2] / "harness"
TESTING = "harness.testing"


def _module(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imported(path: Path, text: str | None = None) -> list[tuple[int, str]]:
    """(line, dotted name) of every module ``path`` imports (its text, or ``text`` as if it
    were there), relative imports resolved, and of every string constant naming one
    (``importlib.import_module("...")``)."""
    module = _module(path)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    source = path.read_text(encoding="utf-8") if text is None else text
    found: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(source, filename=str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            origin = node.module or ""
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                origin = ".".join([*base, *([node.module] if node.module else [])])
            found += [(node.lineno, origin)]
            found += [(node.lineno, f"{origin}.{alias.name}") for alias in node.names]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            found += [(node.lineno, node.value)]
    return found


def test_no_module_of_the_package_imports_the_test_client() -> None:
    users = [
        f"{path.relative_to(ROOT.parent)}:{line}: {name}"
        for path in sorted(ROOT.rglob("*.py"))
        if path != ROOT / "testing.py"
        for line, name in _imported(path)
        if name == TESTING or name.startswith(TESTING + ".")
    ]
    assert users == [], "harness/testing.py is for users' tests; imported by: " + "; ".join(users)


def test_the_check_sees_every_form_of_import() -> None:
    forms = {
        "top.py": "import harness.testing\n",
        "inner.py": "def f():\n    from harness.testing import connect\n",
        "package.py": "from harness import testing\n",
        "sub/relative.py": "from ..testing import connect\n",
        "dynamic.py": "import importlib\nimportlib.import_module('harness.testing')\n",
    }
    for name, text in forms.items():
        assert TESTING in [n for _, n in _imported(ROOT / name, text)], name
