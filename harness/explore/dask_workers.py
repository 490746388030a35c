"""Engines as Dask tasks: ``harness explore --backend dask --scheduler ADDRESS``.

One task per ``--workers`` engine (worker ``i`` seeds ``seed + i``), spread over the
cluster's workers; the stop flag is a ``distributed.Event`` named for the search, so the
first engine to find a failure stops the others' generation wherever they run. The deadline
travels as wall-clock time (each worker converts it to its own monotonic clock).

The workers must see the scenario, its files and ``--out`` at the same paths (a local
cluster, or a shared disk): engines write their scratch and kept examples there, and the
shared example database is a folder. ``harness run --backend dask`` ships files to workers
that share no disk (:mod:`harness.scenario.dask_backend`); explore does not yet.
"""

from __future__ import annotations

import importlib
import time
import uuid
from dataclasses import replace
from pathlib import Path
from typing import Any

from harness.explore.engine import EngineOutcome
from harness.explore.errors import ExploreError

__all__ = ["DaskFlag", "dask_search", "run_dask_engine"]


class DaskFlag:
    """A :class:`~harness.explore.engine.StopFlag` over a ``distributed.Event``."""

    def __init__(self, name: str) -> None:
        distributed: Any = importlib.import_module("distributed")
        self._event: Any = distributed.Event(name)

    def is_set(self) -> bool:
        return bool(self._event.is_set())

    def set(self) -> None:
        self._event.set()


def run_dask_engine(
    source: str, options: Any, worker: int, wall_deadline: float | None, event: str
) -> EngineOutcome:
    """One engine on a Dask worker (a task)."""
    from harness.explore.workers import run_worker

    deadline = None
    if wall_deadline is not None:
        deadline = time.monotonic() + (wall_deadline - time.time())
    return run_worker(Path(source), options, worker, deadline, DaskFlag(event))


def dask_search(source: Path, options: Any, deadline: float | None) -> list[EngineOutcome]:
    """Run ``options.workers`` engines on the cluster at ``options.scheduler``."""
    try:
        distributed: Any = importlib.import_module("distributed")
    except ImportError:
        raise ExploreError(
            "--backend dask needs the dask extra (pip install 'harness[dask]')"
        ) from None
    wall_deadline = None if deadline is None else time.time() + (deadline - time.monotonic())
    event = f"harness-explore-{uuid.uuid4().hex}"
    local = replace(options, scheduler=None)
    try:
        client: Any = distributed.Client(options.scheduler, timeout=10, set_as_default=False)
    except OSError as exc:
        raise ExploreError(f"--scheduler {options.scheduler}: cannot connect: {exc}") from None
    with client:
        futures = [
            client.submit(
                run_dask_engine,
                str(source),
                local,
                i,
                wall_deadline,
                event,
                pure=False,
                key=f"harness-explore-{event[-8:]}-{i}",
            )
            for i in range(options.workers)
        ]
        try:
            outcomes: list[EngineOutcome] = client.gather(futures)
        except Exception as exc:
            raise ExploreError(f"--backend dask: an engine failed: {exc}") from None
    return outcomes
