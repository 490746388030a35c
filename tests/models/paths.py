"""Where the model tests find their robots (shared by the fixtures, the tests and corpus.py)."""

from __future__ import annotations

import sysconfig
from pathlib import Path

__all__ = ["robots_dir"]


def robots_dir() -> Path:
    """Where the PyPI package example-robot-data installs its robots."""
    for key in ("purelib", "platlib"):
        candidate = (
            Path(sysconfig.get_paths()[key]) / "cmeel.prefix/share/example-robot-data/robots"
        )
        if candidate.is_dir():
            return candidate
    raise RuntimeError("example-robot-data is not installed (a test dependency)")
