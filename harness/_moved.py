"""Old import paths of modules that moved, kept for one release.

A package whose modules moved calls :func:`alias_modules` from its ``__init__`` with a mapping
of old module names to new ones. Importing an old name then imports the new module, binds it
under the old name in ``sys.modules`` (so both names are the same module object, with one
copy of its state) and warns once with a :class:`DeprecationWarning` naming the new path.

No file stays at the old path, so version control sees a move as a rename.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from collections.abc import Mapping, Sequence
from types import ModuleType

__all__ = ["alias_modules", "moved_modules"]

_MOVED: dict[str, str] = {}


class _AliasLoader(importlib.abc.Loader):
    def __init__(self, old: str, new: str) -> None:
        self._old = old
        self._new = new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        warnings.warn(
            f"{self._old} moved to {self._new}; the old path goes away in the next release",
            DeprecationWarning,
            stacklevel=2,
        )
        return importlib.import_module(self._new)

    def exec_module(self, module: ModuleType) -> None:
        # The new module is already executed; keep it bound under the old name too.
        sys.modules[self._old] = module


class _AliasFinder(importlib.abc.MetaPathFinder):
    def find_spec(
        self,
        fullname: str,
        path: Sequence[str] | None,
        target: ModuleType | None = None,
    ) -> importlib.machinery.ModuleSpec | None:
        new = _MOVED.get(fullname)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _AliasLoader(fullname, new))


_FINDER = _AliasFinder()


def alias_modules(mapping: Mapping[str, str]) -> None:
    """Make each old module name (key) import the module now at the new name (value)."""
    _MOVED.update(mapping)
    if _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)


def moved_modules() -> dict[str, str]:
    """The old module names registered so far, with their new names."""
    return dict(_MOVED)
