"""One hypothesis engine: generation, ``target()``-guided search and shrinking of one worker.

Each worker runs one engine (seed ``S + worker``) over the plan's delta strategy
(:mod:`harness.explore.strategies`), all sharing one example database (its key: the plan's
digest). An example's failure is raised as an exception class of its *signature*
(:func:`harness.explore.episode.signature_of`), so hypothesis shrinks each distinct failure
on its own (its ``report_multiple_bugs``) and de-duplicates the rest.

Where hypothesis falls short:

- **stopping**: ``--time`` and "another worker found a failure" set a :class:`StopFlag`; the
  next example of an engine that has no failure yet raises :class:`_Stop` (a
  ``BaseException``: hypothesis lets it through and ends the engine at once). An engine with
  a failure keeps shrinking it.
- **determinism**: a failure's first example runs twice; different state digests mean the
  example is not deterministic (a wall clock in the client's loop, ...): it is reported as
  such and not shrunk (its shrink steps would be meaningless).
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol

from hypothesis import HealthCheck, Phase, Verbosity, given, seed, settings, target
from hypothesis.database import DirectoryBasedExampleDatabase, ExampleDatabase
from hypothesis.errors import FlakyFailure

from harness.explore.episode import EpisodeRunner, Example, drive_value
from harness.explore.plan import ExplorePlan
from harness.explore.strategies import delta_strategy, to_values

__all__ = [
    "EngineOptions",
    "EngineOutcome",
    "ExampleFailed",
    "FailureTrack",
    "StopFlag",
    "run_engine",
]


class StopFlag(Protocol):
    """``threading.Event``, ``multiprocessing.Event`` or a Dask ``Event``-like flag."""

    def is_set(self) -> bool: ...

    def set(self) -> None: ...


class ExampleFailed(Exception):
    """An example failed; one subclass per signature (hypothesis tells failures by type)."""

    signature = ""

    def __init__(self, values: dict[str, Any], example: Example) -> None:
        super().__init__(example.signature)
        self.values = values
        self.example = example


class _Stop(BaseException):
    """Ends an engine at once (hypothesis does not catch a BaseException)."""


@dataclass(frozen=True)
class EngineOptions:
    """``examples``: this engine's generation budget; ``deadline``: ``time.monotonic()``
    after which no new search starts (None: none); ``keep_passing``: how many passing examples
    keep their scenario and recording (the fast path's byte-identity check);
    ``database``: the shared example database folder (None: none); ``max_shrinks``: see
    below."""

    examples: int
    seed: int
    deadline: float | None = None
    keep_passing: int = 0
    database: Path | None = None
    shrink: bool = True
    max_shrinks: int = 150
    """Shrink examples after which the smallest failing example so far is the minimal one."""


@dataclass
class FailureTrack:
    """One failure signature: its first example, every failing example in the order shrinking
    met them (``path``), the minimal one, and whether it was deterministic."""

    signature: str
    first: Example
    path: list[Example] = field(default_factory=list)
    minimal: Example | None = None
    deterministic: bool = True
    note: str = ""


@dataclass
class EngineOutcome:
    """What one engine did: every example (generation and shrinking), the failures by
    signature, why it stopped, and its wall time."""

    worker: int
    seed: int
    examples: list[Example] = field(default_factory=list)
    failures: dict[str, FailureTrack] = field(default_factory=dict)
    stopped: str = "budget"
    wall_seconds: float = 0.0
    process: int = field(default_factory=os.getpid)
    """The id of the process the engine ran in."""
    mismatches: list[str] = field(default_factory=list)
    """Kept examples whose fast-path result differed from ``harness run``'s (one line each:
    :attr:`harness.explore.kernel.KernelRunner.mismatches`)."""


def _failure_class(cache: dict[str, type[ExampleFailed]], signature: str) -> type[ExampleFailed]:
    if signature not in cache:
        cache[signature] = type(f"Failure{len(cache)}", (ExampleFailed,), {"signature": signature})
    return cache[signature]


def _database(path: Path | None) -> ExampleDatabase | None:
    return None if path is None else DirectoryBasedExampleDatabase(str(path))


def run_engine(
    plan: ExplorePlan,
    episodes: EpisodeRunner,
    options: EngineOptions,
    stop: StopFlag | None = None,
    on_example: Callable[[Example], None] | None = None,
) -> EngineOutcome:
    """Search ``plan`` with one hypothesis engine (see the module docstring). ``stop``: the
    shared stop flag (set here when this engine finds a failure); ``on_example``: called after
    every example (progress)."""
    started = time.monotonic()
    flag: StopFlag = stop if stop is not None else threading.Event()
    outcome = EngineOutcome(worker=episodes.worker, seed=options.seed)
    classes: dict[str, type[ExampleFailed]] = {}
    kept_passing = 0
    kept_values: set[str] = set()
    keep_root = episodes.scratch / "kept"
    shrinks = 0

    def record(example: Example) -> Example:
        nonlocal shrinks
        outcome.examples.append(example)
        shrinks += example.phase == "shrink"
        if on_example is not None:
            on_example(example)
        return example

    def prop(deltas: dict[str, Any]) -> None:
        nonlocal kept_passing
        shrinking = bool(outcome.failures)
        if shrinking and shrinks >= options.max_shrinks:
            outcome.stopped = "shrink limit"
            raise _Stop
        if not shrinking:
            if options.deadline is not None and time.monotonic() >= options.deadline:
                outcome.stopped = "time"
                raise _Stop
            if flag.is_set():
                outcome.stopped = "stopped"
                raise _Stop
        values = to_values(plan, deltas)
        keep = None
        key = ""
        if kept_passing < options.keep_passing and not shrinking:
            key = repr(sorted(values.items()))
            if key not in kept_values:
                keep = keep_root / f"w{episodes.worker}-{episodes.count:05d}"
        example = episodes.run(values, keep=keep)
        example = replace(example, phase="shrink" if shrinking else "generate")
        if keep is not None and example.passed:
            kept_passing += 1
            kept_values.add(key)
        if plan.target is not None:
            value = drive_value(plan.target, example.margins)
            if value is not None:
                target(value, label=plan.target)
        if example.passed:
            record(example)
            return
        track = outcome.failures.get(example.signature)
        if track is None:
            folder = keep_root / f"w{episodes.worker}-fail{len(outcome.failures)}"
            # run again, kept: the determinism check, and on the fast path the product's run
            # with the recorder (checked against the kernel's: harness.explore.kernel)
            again = episodes.run(values, keep=folder)
            example = replace(example, kept=again.kept, check=again.check)
            track = FailureTrack(example.signature, example)
            outcome.failures[example.signature] = track
            flag.set()  # the other engines stop generating: this one shrinks
            if again.digest != example.digest or again.signature != example.signature:
                track.deterministic = False
                track.note = (
                    "not deterministic: the same example ran twice gave different state "
                    "streams (wall clock or randomness outside the seed?); not shrunk"
                )
                record(example)
                outcome.stopped = "nondeterministic"
                raise _Stop
        record(example)
        track.path.append(example)
        raise _failure_class(classes, example.signature)(values, example)

    test = given(delta_strategy(plan))(prop)
    test = settings(
        max_examples=max(1, options.examples),
        deadline=None,
        database=_database(options.database),
        suppress_health_check=list(HealthCheck),
        phases=[Phase.explicit, Phase.reuse, Phase.generate, Phase.target]
        + ([Phase.shrink] if options.shrink else []),
        report_multiple_bugs=True,
        derandomize=False,  # the seed below decides (a test profile may derandomize)
        verbosity=Verbosity.quiet,
        print_blob=False,
    )(test)
    test = seed(options.seed)(test)
    test.hypothesis.inner_test._hypothesis_internal_add_digest = plan.digest  # type: ignore[attr-defined]
    try:
        test()
    except _Stop:
        # the shrink limit (or a stop): each failure's smallest example so far is its minimal
        for track in outcome.failures.values():
            if track.minimal is None and track.path and track.deterministic:
                track.minimal = track.path[-1]
    except ExampleFailed as exc:
        _minimal(outcome, [exc])
    except FlakyFailure as exc:
        for track in outcome.failures.values():
            track.deterministic = False
            track.note = f"not deterministic while shrinking: {exc}"
    except Exception as exc:  # an exception group of several failures (3.10: the backport)
        group = getattr(exc, "exceptions", None)
        found = [e for e in group or () if isinstance(e, ExampleFailed)]
        if not found or len(found) != len(group or ()):
            raise
        _minimal(outcome, found)
    finally:
        outcome.mismatches = list(getattr(episodes, "mismatches", ()))
    outcome.wall_seconds = time.monotonic() - started
    return outcome


def _minimal(outcome: EngineOutcome, found: list[ExampleFailed]) -> None:
    """The minimal example of each failure: the one hypothesis raised last (its final replay)."""
    for exc in found:
        track = outcome.failures.get(exc.example.signature)
        if track is not None:
            track.minimal = exc.example
