"""The import graph of the ``harness`` package, read from its source (no module is imported).

An edge ``a -> b`` is any ``import`` statement in module ``a`` naming module ``b`` of the package:
at module level, inside functions and under ``if TYPE_CHECKING:`` alike, since each of them is
a dependency a reader has to follow and a lazy import only hides a cycle from the interpreter.
``from p import name`` is an edge to ``p.name`` when that is a module, else to ``p``; a name
whose module does not exist (an old path kept by :mod:`harness._moved`) counts as its nearest
existing package. Importing a submodule also runs its packages' ``__init__``; that implicit
edge is left out, as import linters do, or every re-exporting package would be a cycle.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

__all__ = ["ROOT", "cycle_in", "cycles", "import_graph", "modules_of"]

ROOT = Path(__file__).resolve().parents[2] / "harness"


def modules_of(root: Path = ROOT) -> dict[str, Path]:
    """Every module of the package under ``root``, by dotted name (a package by its name)."""
    found: dict[str, Path] = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def _resolve(name: str, known: Mapping[str, Path]) -> str | None:
    while name and name not in known:
        name = name.rpartition(".")[0]
    return name or None


def _imports(module: str, path: Path, known: Mapping[str, Path]) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    targets: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            for alias in node.names:
                full = f"{source}.{alias.name}"
                targets.add(full if full in known else source)
    root = next(iter(known)).split(".")[0]
    edges = set()
    for target in targets:
        if target == root or target.startswith(root + "."):
            resolved = _resolve(target, known)
            if resolved is not None and resolved != module:
                edges.add(resolved)
    return edges


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Each module of the package with the package modules it imports."""
    known = modules_of(root)
    return {module: _imports(module, path, known) for module, path in known.items()}


def cycles(graph: Mapping[str, Iterable[str]]) -> list[frozenset[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[frozenset[str]] = []
    counter = 0
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    component = set()
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.add(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        found.append(frozenset(component))
    return sorted(found, key=lambda c: (-len(c), sorted(c)))


def cycle_in(graph: Mapping[str, Iterable[str]], component: frozenset[str]) -> list[str]:
    """A shortest closed path through the component's first module: ``[a, b, ..., a]``."""
    start = min(component)
    parent: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for child in sorted(graph[node]):
                if child == start:
                    path = [node]
                    while path[-1] != start:
                        path.append(parent[path[-1]])
                    return [start, *reversed(path[:-1]), start]
                if child in component and child not in parent:
                    parent[child] = node
                    following.append(child)
        frontier = following
    raise ValueError(f"no cycle through {start}")
