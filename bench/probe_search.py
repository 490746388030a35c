"""Pure-search throughput of ``harness explore``: the kernel stubbed out (a measuring probe).

PYTHONPATH=<checkout> [PROBE_LEVEL=core|run] [PROBE_CONCRETE=1] [PROBE_PROFILE=FILE] \
    python bench/probe_search.py [--seconds S | --examples N] [--workers 1 2] [--repeat R]

The search of ``clear.yaml`` (tests/explore/data) with the per-example kernel replaced by a
stub, so that what is timed is everything between two kernel runs: the hypothesis engine,
drawing values, the worker processes and what they send back. Prints examples/s (wall), each
engine's examples and seconds, and the CPU milliseconds per example of this process's engine.

- ``PROBE_LEVEL=core`` (default): ``run_core`` and the warm world are stubbed (a passing
  result and a clearance margin that varies with the obstacle's position, so ``target()`` has
  work); ``KernelRunner.run`` keeps its own work (``apply_values``, ``Scenario.from_mapping``);
- ``PROBE_LEVEL=run``: ``KernelRunner.run`` returns a fixed passing Example at once;
- ``PROBE_CONCRETE=1``: the kernel's ``apply_values`` + ``Scenario.from_mapping`` behave as
  :meth:`harness.explore.ExplorePlan.concrete` (the schema at the parameters' places only);
- ``PROBE_PROFILE=FILE``: every process writes a cProfile to ``FILE.<pid>``.

The stubs are installed at import (module level), so ``spawn`` workers get them too.
Not a ``bench_*`` module: ``bench/run.py`` does not run it.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from harness.explore import SearchOptions, load_plan, search
from harness.explore import kernel as _kernel
from harness.explore.episode import Example
from harness.scenario import IterationResult, Scenario

DATA = Path(__file__).resolve().parents[1] / "tests" / "explore" / "data"
LEVEL = os.environ.get("PROBE_LEVEL", "core")
PROFILE = os.environ.get("PROBE_PROFILE")


class _Minimum:
    def __init__(self, distance: float) -> None:
        self.distance = distance


class _Clearance:
    def __init__(self, distance: float) -> None:
        self.minimum = _Minimum(distance)


def _run(self: Any, values: Any, *, keep: Path | None = None) -> Example:
    index = self.count
    self.count += 1
    return Example(worker=self.worker, index=index, values=dict(values), passed=True,
                   signature="", reason="", margins={}, digest="0" * 64)  # fmt: skip


def _get(self: Any, scenario: Any, document: Any) -> tuple[Any, Any, float]:
    return None, None, 0.002


def _run_core(scenario: Any, planned: Any, world: Any, timestep: float, clearance: Any = None):
    result = IterationResult(scenario.name, 1, (), 1.5, 750, state_digest="0" * 64)
    x, y, _ = scenario.objects[0].pose.xyz
    return result, _Clearance(abs(x + 0.4) + abs(y + 0.6))


if os.environ.get("PROBE_CONCRETE") and LEVEL == "core":
    # what KernelRunner.run does with plan.concrete(values) in place of apply_values +
    # Scenario.from_mapping (the lead's kernel.py; not edited here)
    _last: dict[str, Any] = {}
    _apply = _kernel.apply_values

    def _apply_values(document: Any, parameters: Any, values: Any) -> Any:
        _last["values"] = values
        return _apply(document, parameters, values)

    class _Scenario:
        @staticmethod
        def from_mapping(document: Any, *, base_dir: Any, source: Any) -> Any:
            from harness.explore.plan import load_plan as _load

            plan = _PLANS.get(source) or _PLANS.setdefault(source, _load(source))
            checker = plan.value_checker
            ok = checker is not None and checker.valid(_last["values"])
            return Scenario.from_mapping(document, base_dir=base_dir, source=source, schema=not ok)

    _PLANS: dict[Any, Any] = {}
    _kernel.apply_values = _apply_values  # type: ignore[assignment]
    _kernel.Scenario = _Scenario  # type: ignore[assignment,misc]

if LEVEL == "run":
    _kernel.KernelRunner.run = _run  # type: ignore[method-assign]
else:
    _kernel.WarmWorlds.get = _get  # type: ignore[method-assign]
    _kernel.run_core = _run_core  # type: ignore[assignment]
    if hasattr(_kernel.KernelRunner, "_quiet"):  # a kernel with quiet runs: the full one
        _kernel.KernelRunner._quiet = lambda self, *args: None

if PROFILE:  # each process profiles itself, written at exit
    import atexit

    _prof = cProfile.Profile()
    _prof.enable()
    atexit.register(lambda: _prof.dump_stats(f"{PROFILE}.{os.getpid()}"))


def rate(
    workers: int, seconds: float | None, database: bool = False, examples: int = 100_000
) -> tuple[float, str]:
    with tempfile.TemporaryDirectory() as tmp:
        options = SearchOptions(work=Path(tmp), examples=examples, seconds=seconds,
                                workers=workers, seed=11,
                                database=Path(tmp) / "db" if database else None)  # fmt: skip
        start, cpu = time.perf_counter(), time.process_time()
        result = search(load_plan(DATA / "clear.yaml"), options)
        elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
        assert not result.failures
        engines = ", ".join(
            f"w{o.worker}: {len(o.examples)} in {o.wall_seconds:.2f} s" for o in result.outcomes
        )
        n = len(result.examples)
        own = len(result.outcomes[0].examples)  # this process's engine (worker 0)
        here = f"this process {cpu / own * 1e3:.2f} cpu ms/ex"
        text = f"{n} examples in {elapsed:.2f} s; {engines}; {here}"
        return n / elapsed, text


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--database", action="store_true")
    parser.add_argument("--examples", type=int, default=None, help="a budget, no time limit")
    args = parser.parse_args()
    rate(1, 0.5)  # imports
    for w in args.workers:
        for _ in range(args.repeat):
            if args.examples:
                r, text = rate(w, None, args.database, args.examples)
            else:
                r, text = rate(w, args.seconds, args.database)
            db = " db" if args.database else ""
            print(f"level={LEVEL}{db} workers={w}: {r:.1f} ex/s ({text})")
            sys.stdout.flush()


if __name__ == "__main__":
    main()
