"""What one worker runs: its share of the search options, its example runner, its engine.

Shared by the local backends (:mod:`harness.explore.search`) and the Dask one
(:mod:`harness.explore.dask_workers`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from harness.explore.engine import EngineOptions, EngineOutcome, StopFlag, run_engine
from harness.explore.episode import EpisodeRunner, Example
from harness.explore.plan import ExplorePlan, load_plan

__all__ = ["SearchOptions", "engine_options", "episode_runner", "run_worker"]


@dataclass(frozen=True)
class SearchOptions:
    """``examples``: the generation budget over all workers; ``seconds``: stop generating
    after this wall time (None: the budget only); ``seed``: worker ``i`` seeds ``seed + i``;
    ``workers``: engines side by side; ``work``: the scratch folder; ``database``: the shared
    hypothesis example database (None: none); ``keep_passing``: passing examples per worker
    whose scenario and recording are kept; ``runner``: an iteration-runner factory (None: the
    product's); ``scheduler``: a Dask scheduler address (None: local)."""

    work: Path
    examples: int = 200
    seconds: float | None = None
    seed: int = 0
    workers: int = 1
    database: Path | None = None
    keep_passing: int = 0
    scheduler: str | None = None
    fast: bool = True


def engine_options(options: SearchOptions, worker: int, deadline: float | None) -> EngineOptions:
    """Worker ``worker``'s share of the budget and its seed."""
    share = -(-options.examples // options.workers)
    return EngineOptions(
        examples=share,
        seed=options.seed + worker,
        deadline=deadline,
        keep_passing=options.keep_passing,
        database=options.database,
    )


def episode_runner(plan: ExplorePlan, options: SearchOptions, worker: int) -> EpisodeRunner:
    """Worker ``worker``'s example runner: the fast path when ``options.fast`` (warm worlds
    and the generation kernel, :class:`harness.explore.kernel.KernelRunner`), else the
    product's runner for every example (``--cold``)."""
    scratch = options.work / f"worker-{worker}"
    if options.fast:
        from harness.explore.kernel import KernelRunner

        return KernelRunner(plan, scratch, worker=worker)
    return EpisodeRunner(plan, scratch, worker=worker)


def run_worker(
    source: Path,
    options: SearchOptions,
    worker: int,
    deadline: float | None,
    stop: StopFlag | None,
    on_example: Callable[[Example], None] | None = None,
) -> EngineOutcome:
    """One worker's engine over the scenario file ``source`` (loaded here: in a worker
    process the plan is read from the file, as the parent did)."""
    plan = load_plan(source)
    return run_engine(
        plan,
        episode_runner(plan, options, worker),
        engine_options(options, worker, deadline),
        stop,
        on_example,
    )
