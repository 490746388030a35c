"""Running every iteration of a run file: planning, local or Dask workers, determinism.

The runner machinery does not know how an iteration runs: it hands :class:`IterationSpec`\\ s
to an :class:`~harness.scenario.results.IterationRunner` on a :class:`Backend` and collects
:class:`~harness.scenario.results.IterationResult`\\ s. :func:`session_iteration_runner` is
the one place where the product's (session-backed) runner is wired in.
"""

from __future__ import annotations

import multiprocessing
import re
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Protocol

from harness.recording import RecordingBusyError
from harness.scenario import interrupt
from harness.scenario.errors import ScenarioError
from harness.scenario.results import IterationResult, IterationRunner, IterationSpec, Verdict
from harness.scenario.runfile import RunConfig

__all__ = [
    "Backend",
    "LocalBackend",
    "check_runnable",
    "iteration_specs",
    "judge_determinism",
    "run_iterations",
    "session_iteration_runner",
]

OnResult = Callable[[IterationResult], None]


def session_iteration_runner() -> IterationRunner:
    """The iteration runner ``harness run`` uses: one :class:`harness.Session` per iteration
    (:class:`harness.scenario.session_runner.SessionIterationRunner`)."""
    from harness.scenario.session_runner import SessionIterationRunner

    return SessionIterationRunner()


def check_runnable(config: RunConfig) -> None:
    """Refuse, before anything runs, a run file whose scenarios the session-backed runner
    cannot run (several robots, ...): :class:`ScenarioError` naming each key path."""
    from harness.scenario.world import check_runnable as problems_of

    seen: set[int] = set()
    problems: list[str] = []
    for plan in config.simulations:
        if id(plan.scenario) not in seen:
            seen.add(id(plan.scenario))
            problems.extend(problems_of(plan.scenario))
    if problems:
        raise ScenarioError(problems)


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "-", name).strip("-") or "simulation"


def iteration_specs(
    config: RunConfig, out_dir: Path, iterations: int | None = None
) -> list[IterationSpec]:
    """One spec per iteration: each with a free port (0), its own folder
    ``<out>/<simulation>/iteration-NNN/`` and recording ``recording.mcap`` in it; every
    iteration of a simulation uses the scenario's seed, so iterations are comparable."""
    specs: list[IterationSpec] = []
    for plan in config.simulations:
        count = iterations if iterations is not None else plan.iterations
        for i in range(1, count + 1):
            folder = out_dir.resolve() / _slug(plan.name) / f"iteration-{i:03d}"
            specs.append(
                IterationSpec(
                    simulation=plan.name,
                    iteration=i,
                    scenario=plan.scenario,
                    client=plan.client,
                    sim_time_limit=plan.sim_time_limit,
                    seed=plan.scenario.seed,
                    host=plan.scenario.bridge.ip,
                    port=0,
                    out_dir=folder,
                    recording_path=folder / "recording.mcap",
                )
            )
    return specs


def _failed(spec: IterationSpec, error: str, recording: Path | None = None) -> IterationResult:
    return IterationResult(
        simulation=spec.simulation,
        iteration=spec.iteration,
        verdicts=(),
        sim_time=0.0,
        steps=0,
        recording=recording,
        error=error,
    )


_FileState = tuple[int, int, int, int] | None


def _file_state(path: Path) -> _FileState:
    """What tells one file at ``path`` from another: device, inode, size, mtime (None: none)."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns


def _written(path: Path, before: _FileState) -> Path | None:
    """``path`` when this iteration wrote a file there (a stale file of an earlier run in the
    same folder, left as it was, is not this iteration's recording)."""
    now = _file_state(path)
    return path if now is not None and now != before and path.is_file() else None


def run_one(runner: IterationRunner, spec: IterationSpec) -> IterationResult:
    """Run ``spec`` in this process; an exception becomes a failed result with its reason
    (and the recording, when the iteration wrote one before it stopped: a session closes its
    recording as a valid file while the exception unwinds it)."""
    if interrupt.worker_stopping():
        return _failed(spec, interrupt.NOT_RUN)
    spec.out_dir.mkdir(parents=True, exist_ok=True)
    before = _file_state(spec.recording_path)
    try:
        with interrupt.worker_running():
            return runner(spec)
    except interrupt.Interrupted as exc:
        recording = _written(spec.recording_path, before)
        return _failed(spec, f"{exc}: the iteration was stopped", recording)
    except Exception as exc:
        where = traceback.extract_tb(exc.__traceback__)[-1]
        return _failed(
            spec,
            f"runner raised {type(exc).__name__}: {exc} "
            f"({Path(where.filename).name}:{where.lineno})",
            # Refused because another writer holds the path: the file there is theirs.
            None if isinstance(exc, RecordingBusyError) else _written(spec.recording_path, before),
        )


class Backend(Protocol):
    """Where iterations run."""

    def run(
        self, runner: IterationRunner, specs: Sequence[IterationSpec], on_result: OnResult
    ) -> list[IterationResult]:
        """Run every spec; call ``on_result`` as each finishes; return results in spec order."""
        ...


@dataclass(frozen=True)
class LocalBackend:
    """``workers`` local processes (spawned, so no state leaks from the parent)."""

    workers: int = 1

    def run(
        self, runner: IterationRunner, specs: Sequence[IterationSpec], on_result: OnResult
    ) -> list[IterationResult]:
        """Run every spec in the process pool; a dead worker fails its iterations."""
        results: dict[int, IterationResult] = {}
        context = multiprocessing.get_context("spawn")
        workers = max(1, min(self.workers, len(specs)))
        with ProcessPoolExecutor(
            max_workers=workers, mp_context=context, initializer=interrupt.worker_initializer
        ) as pool:
            futures: dict[Future[IterationResult], int] = {
                pool.submit(run_one, runner, spec): index for index, spec in enumerate(specs)
            }
            try:
                for future in as_completed(futures):
                    index = futures[future]
                    try:
                        result = future.result()
                    except BrokenProcessPool:
                        result = _failed(specs[index], "the worker process running it died")
                    results[index] = result
                    on_result(result)
            except interrupt.Interrupted as exc:
                ran = interrupt.collect_interrupted(pool, futures, results)
                finished = [ran[i] for i in sorted(ran) if ran[i].error != interrupt.NOT_RUN]
                raise interrupt.RunInterrupted(exc.signum, finished, len(specs)) from None
            except BaseException:
                pool.shutdown(wait=True, cancel_futures=True)
                raise
        return [results[i] for i in range(len(specs))]


def judge_determinism(results: Sequence[IterationResult]) -> list[IterationResult]:
    """Add a ``determinism`` verdict to every result: within a simulation, every iteration's
    state-stream digest must equal the first iteration's."""
    first: dict[str, IterationResult] = {}
    counts: dict[str, int] = {}
    for r in results:
        first.setdefault(r.simulation, r)
        counts[r.simulation] = counts.get(r.simulation, 0) + 1
    judged = []
    for r in results:
        ref = first[r.simulation]
        if counts[r.simulation] < 2:
            verdict = Verdict("determinism", False, "needs at least 2 iterations to compare")
        elif r.state_digest is None or ref.state_digest is None:
            verdict = Verdict("determinism", False, "no state stream to compare")
        elif r.state_digest == ref.state_digest:
            verdict = Verdict(
                "determinism",
                True,
                f"state stream identical to iteration {ref.iteration} "
                f"(sha256 {r.state_digest[:12]})",
            )
        else:
            verdict = Verdict(
                "determinism",
                False,
                f"state stream differs from iteration {ref.iteration} "
                f"({r.state_digest[:12]} != {ref.state_digest[:12]})",
            )
        judged.append(replace(r, verdicts=(*r.verdicts, verdict)))
    return judged


def run_iterations(
    runner: IterationRunner,
    specs: Sequence[IterationSpec],
    backend: Backend,
    check_determinism: bool = False,
    on_result: OnResult | None = None,
) -> list[IterationResult]:
    """Run ``specs`` on ``backend``; judge determinism when asked or when a scenario's
    criteria ask for it. Results come back in spec order."""
    results = backend.run(runner, specs, on_result or (lambda _r: None))
    wanted = {s.simulation for s in specs if check_determinism or s.scenario.criteria.deterministic}
    if wanted:
        judged = iter(judge_determinism([r for r in results if r.simulation in wanted]))
        results = [next(judged) if r.simulation in wanted else r for r in results]
    return results
