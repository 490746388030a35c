"""Engines as Dask tasks (``harness explore --backend dask --scheduler ADDRESS``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from harness.explore.errors import ExploreError

__all__ = ["dask_search"]


def dask_search(source: Path, options: Any, deadline: float | None) -> list[Any]:
    """Not in yet."""
    raise ExploreError("--backend dask: not available yet")
