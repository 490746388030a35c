"""Worker processes for a cold load's slow, independent jobs (a robot's concave link meshes
decomposed by CoACD: :mod:`harness.models.build.decompose`).

:func:`in_processes` runs a module-level function over jobs in spawned processes
(:class:`~concurrent.futures.ProcessPoolExecutor`); :func:`workers_for` says how many: at most
the CPUs this process may use, capped by ``$HARNESS_DECOMPOSE_WORKERS`` (1: none, the caller
runs the jobs itself).
"""

from __future__ import annotations

import contextlib
import os
import sys
import types
import warnings
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import Future
from typing import Any, TypeVar

from harness.models.errors import ModelStructureError, ModelWarning

__all__ = ["WORKERS_VARIABLE", "in_processes", "workers_for"]

WORKERS_VARIABLE = "HARNESS_DECOMPOSE_WORKERS"
"""The environment variable that caps the worker processes (1: the caller's process only)."""

_Result = TypeVar("_Result")


def workers_for(jobs: int, workers: int | None = None) -> int:
    """Processes for ``jobs`` jobs: ``workers`` (else ``$HARNESS_DECOMPOSE_WORKERS``, else
    the CPUs this process may use), never more than those CPUs nor than ``jobs``; at least 1."""
    available = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 0
    available = available or os.cpu_count() or 1
    if workers is None:
        text = os.environ.get(WORKERS_VARIABLE, "").strip()
        try:
            workers = int(text) if text else available
        except ValueError:
            raise ModelStructureError(
                f"${WORKERS_VARIABLE}: {text!r} is not a number of processes"
            ) from None
    return max(1, min(workers, available, jobs))


def in_processes(
    function: Callable[..., _Result],
    arguments: Mapping[int, tuple[Any, ...]],
    count: int,
    *,
    what: str = "working",
) -> dict[int, _Result]:
    """``function(*arguments[i])`` for each job ``i`` in ``count`` spawned processes, the
    jobs in the order given (put the longest first). ``function`` must be importable by its
    module and name. Spawned, not forked: a native library's OpenMP runtime (CoACD's) and the
    caller's threads do not survive a fork. The workers start without the caller's
    ``__main__`` (they need nothing of it): spawn would run a script without the ``if
    __name__ == "__main__":`` guard again in each of them. When the pool breaks (a worker
    killed, no processes to be had) one :class:`ModelWarning` says so and the jobs it did not
    finish are left out: the caller runs them itself. An exception of ``function`` is
    raised here, as it was raised there."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    futures: dict[int, Future[_Result]] = {}
    context = multiprocessing.get_context("spawn")
    try:
        with ProcessPoolExecutor(max_workers=count, mp_context=context) as pool:
            with _without_main():  # the processes start as the jobs are submitted
                futures = {i: pool.submit(function, *args) for i, args in arguments.items()}
            return {i: futures[i].result() for i in sorted(arguments)}
    except (BrokenProcessPool, OSError) as exc:
        warnings.warn(
            f"{what} in this process: the worker processes failed ({exc})",
            ModelWarning,
            stacklevel=3,
        )
        return {
            i: f.result()
            for i, f in futures.items()
            if f.done() and not f.cancelled() and f.exception() is None
        }


@contextlib.contextmanager
def _without_main() -> Iterator[None]:
    """``sys.modules["__main__"]`` an empty module meanwhile: a process spawned then does not
    import the caller's main script or module."""
    main = sys.modules.get("__main__")
    sys.modules["__main__"] = types.ModuleType("__main__")
    try:
        yield
    finally:
        if main is not None:
            sys.modules["__main__"] = main
