"""The search: engines on workers, their outcomes merged.

:func:`search` runs one hypothesis engine per worker (:mod:`harness.explore.engine`): in this
process for one worker, else one process each (``spawn``), or one Dask task each
(:mod:`harness.explore.dask_workers`). Worker ``i`` seeds its engine with ``seed + i``; all
share the example database and a stop flag (set by ``--time`` through each engine's deadline,
and by the first engine that finds a failure: the others stop generating, it shrinks).

With local processes, worker 0 runs in this process while the others start: this process has
its imports done already, and a spawned worker spends seconds importing before its first
example (time the ``--time`` budget counts). Worker 0 reads the plan from the file as a
spawned worker does. (hypothesis also draws, now and then, a constant found in the local
modules its process has imported: worker 0 draws with the caller's modules, as the one-worker
search always did. Under ``harness explore`` the caller holds two modules a spawned worker
does not, ``harness.explore._cli`` and ``report``, whose only constant the others lack is the
integer 2000.)
"""

from __future__ import annotations

import multiprocessing
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness.explore.engine import EngineOutcome, FailureTrack, run_engine
from harness.explore.episode import Example
from harness.explore.errors import ExploreConfigError, ExploreError
from harness.explore.plan import ExplorePlan
from harness.explore.workers import SearchOptions, engine_options, episode_runner, run_worker
from harness.scenario import warm_clients

__all__ = ["SearchOptions", "SearchResult", "search"]


@dataclass
class SearchResult:
    """The merged outcomes: every example, the failures by signature (each with its shrink
    path and minimal example), and per-engine facts."""

    plan: ExplorePlan
    outcomes: list[EngineOutcome]
    wall_seconds: float
    failures: dict[str, FailureTrack] = field(default_factory=dict)

    @property
    def examples(self) -> list[Example]:
        return [e for o in self.outcomes for e in o.examples]

    @property
    def generated(self) -> int:
        return sum(1 for e in self.examples if e.phase == "generate")

    @property
    def mismatches(self) -> list[str]:
        """Kept examples whose fast-path result differed from ``harness run``'s."""
        return [m for o in self.outcomes for m in o.mismatches]

    def primary(self) -> FailureTrack | None:
        """The first failure found (the earliest in its engine; workers in order)."""
        tracks = list(self.failures.values())
        return tracks[0] if tracks else None


def _check_options(options: SearchOptions) -> None:
    if options.examples < 1:
        raise ExploreConfigError(f"--examples: {options.examples} must be at least 1")
    if options.workers < 1:
        raise ExploreConfigError(f"--workers: {options.workers} must be at least 1")
    if options.seconds is not None and not options.seconds > 0:
        raise ExploreConfigError(f"--time: {options.seconds} must be > 0 seconds")
    if options.seed < 0:
        raise ExploreConfigError(f"--seed: {options.seed} must be >= 0")


_STOP: Any = None


def _init_worker(stop: Any) -> None:
    global _STOP
    _STOP = stop


def _process_worker(
    source: Path, options: SearchOptions, worker: int, deadline: float | None
) -> EngineOutcome:
    with warm_clients(options.fast):  # Python client programs start warm on the fast path
        return run_worker(source, options, worker, deadline, _STOP)


def search(
    plan: ExplorePlan,
    options: SearchOptions,
    on_example: Callable[[Example], None] | None = None,
) -> SearchResult:
    """Search ``plan`` (see the module docstring). Raises :class:`ExploreError` when a kept
    example's fast-path result differed from ``harness run``'s (an error of the search:
    :mod:`harness.explore.kernel`)."""
    _check_options(options)
    started = time.monotonic()
    deadline = None if options.seconds is None else started + options.seconds
    if options.scheduler is not None:
        from harness.explore.dask_workers import dask_search

        outcomes = dask_search(plan.source, options, deadline)
    elif options.workers == 1:
        with warm_clients(options.fast):
            outcomes = [
                run_engine(
                    plan,
                    episode_runner(plan, options, 0),
                    engine_options(options, 0, deadline),
                    threading.Event(),
                    on_example,
                )
            ]
    else:
        context = multiprocessing.get_context("spawn")
        stop = context.Event()
        with ProcessPoolExecutor(
            options.workers - 1, mp_context=context, initializer=_init_worker, initargs=(stop,)
        ) as pool:
            futures = [
                pool.submit(_process_worker, plan.source, options, i, deadline)
                for i in range(1, options.workers)
            ]
            try:
                with warm_clients(options.fast):
                    first = run_worker(plan.source, options, 0, deadline, stop)
            except BaseException:
                stop.set()  # the others stop generating: the pool's exit waits for them
                raise
            outcomes = [first, *(f.result() for f in futures)]
    result = SearchResult(plan, outcomes, time.monotonic() - started)
    for outcome in outcomes:
        for signature, track in outcome.failures.items():
            if signature not in result.failures:
                result.failures[signature] = track
    mismatches = result.mismatches
    if mismatches:
        more = f" (and {len(mismatches) - 1} more)" if len(mismatches) > 1 else ""
        raise ExploreError(
            f"{plan.source}: the fast path is not harness run: {mismatches[0]}{more}"
        )
    return result
