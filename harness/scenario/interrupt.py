"""SIGINT and SIGTERM during ``harness run``: stop the iterations, keep what finished.

The main process turns its first SIGINT or SIGTERM into :class:`Interrupted` (raised where it
waits for results; later signals are ignored while it cleans up). The local backend then
cancels the iterations not started and sends SIGTERM to its worker processes. Workers ignore
SIGINT (a terminal's Ctrl-C reaches the whole process group; the main process decides) and
turn SIGTERM into :class:`Interrupted` inside a running iteration, so the iteration unwinds:
its client's process group is stopped (SIGTERM, then SIGKILL after the grace period), its
session and recording are closed, and it comes back as a failed result saying it was
interrupted. An iteration a worker would start afterwards is not run. The backend raises
:class:`RunInterrupted` with the results of every iteration that finished (or was
interrupted), and ``harness run`` writes the reports for those and exits 128 + the signal
number.
"""

from __future__ import annotations

import contextlib
import os
import signal
from collections.abc import Iterator, Mapping
from concurrent.futures import Future, ProcessPoolExecutor
from types import FrameType
from typing import Any

from harness.scenario.errors import RunnerError
from harness.scenario.results import IterationResult

__all__ = [
    "NOT_RUN",
    "Interrupted",
    "RunInterrupted",
    "collect_interrupted",
    "raise_on_signals",
    "worker_initializer",
    "worker_running",
    "worker_stopping",
]

SIGNALS = (signal.SIGINT, signal.SIGTERM)
NOT_RUN = "not run: the run was interrupted before this iteration started"


class Interrupted(Exception):
    """A stop signal arrived (``signum``)."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        super().__init__(f"interrupted by {signal.Signals(signum).name}")


class RunInterrupted(RunnerError):
    """The run was stopped by a signal; ``results`` are those of the iterations that ran."""

    def __init__(self, signum: int, results: list[IterationResult], planned: int) -> None:
        self.signum = signum
        self.results = results
        self.planned = planned
        super().__init__(
            f"interrupted by {signal.Signals(signum).name}: {len(results)} of {planned} "
            "iterations ran (finished or stopped)"
        )

    @property
    def exit_code(self) -> int:
        """128 + the signal number, as a shell reports a process a signal ended."""
        return 128 + self.signum


@contextlib.contextmanager
def raise_on_signals() -> Iterator[None]:
    """In the main thread: the first SIGINT/SIGTERM raises :class:`Interrupted`, later ones
    are ignored (cleanup is under way); the previous handlers are restored on exit."""
    fired: list[int] = []

    def handler(signum: int, frame: FrameType | None) -> None:
        if not fired:
            fired.append(signum)
            raise Interrupted(signum)

    previous = {s: signal.signal(s, handler) for s in SIGNALS}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


# -- worker processes -------------------------------------------------------------------

_state = {"running": False, "stopping": False}


def _on_worker_signal(signum: int, frame: FrameType | None) -> None:
    _state["stopping"] = True
    if _state["running"]:
        _state["running"] = False  # raised once: the unwinding itself must not be cut short
        raise Interrupted(signum)


def worker_initializer() -> None:
    """Run in each local worker process: ignore SIGINT, turn SIGTERM into
    :class:`Interrupted` while an iteration runs (see the module docstring)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _on_worker_signal)


def worker_stopping() -> bool:
    """Whether this worker was told to stop (no further iteration may start)."""
    return _state["stopping"]


@contextlib.contextmanager
def worker_running() -> Iterator[None]:
    """Mark an iteration as running in this worker (SIGTERM interrupts it)."""
    _state["running"] = True
    try:
        yield
    finally:
        _state["running"] = False


def collect_interrupted(
    pool: ProcessPoolExecutor,
    futures: Mapping[Future[IterationResult], int],
    results: dict[int, IterationResult],
) -> dict[int, IterationResult]:
    """Stop ``pool`` after an :class:`Interrupted`: cancel what has not started, SIGTERM the
    workers, wait for the running iterations to unwind; ``results`` plus theirs."""
    processes: dict[int, Any] = dict(getattr(pool, "_processes", None) or {})  # shutdown clears it
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes.values():
        with contextlib.suppress(ProcessLookupError, OSError, AttributeError):
            os.kill(process.pid, signal.SIGTERM)
    collected = dict(results)
    for future, index in futures.items():
        if index in collected or future.cancelled():
            continue
        try:
            collected[index] = future.result()
        except BaseException:
            continue
    pool.shutdown(wait=True)
    return collected
