"""Rooms of plug-ins: a package whose modules register themselves (controller types, sensor
kinds) when imported, found by importing every module of the package once, on first use."""

from __future__ import annotations

import importlib
import pkgutil
import threading

__all__ = ["Room"]


class Room:
    """The package ``package``: :meth:`discover` imports each of its modules whose name does
    not start with ``_``, once per process."""

    def __init__(self, package: str) -> None:
        self.package = package
        self._found = False
        self._lock = threading.RLock()  # a module of the room may ask the room while it loads

    def discover(self) -> None:
        """Import every module of the room (each registers what it brings)."""
        if self._found:
            return
        with self._lock:  # two sessions started at once in threads: the second waits for all
            if self._found:
                return
            package = importlib.import_module(self.package)
            for info in sorted(pkgutil.iter_modules(package.__path__), key=lambda m: m.name):
                if not info.name.startswith("_"):
                    importlib.import_module(f"{self.package}.{info.name}")
            self._found = True
