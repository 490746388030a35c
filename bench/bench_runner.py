"""Runner throughput: the same batch of iterations on 1 and on 2 local workers.

Two batches, each real work:

- the session-backed runner ``harness run`` uses (one Session per iteration: the demo arm on
  its table, recorded to MCAP, loggers, state digest every step; no client, fast clock, so the
  runner steps the duration), and
- StepLoadRunner (a small MuJoCo arm stepped without a Session: the runner machinery alone).

The limit is the 1-worker throughput measured in the same run; the target is a 2-worker
speed-up of at least 1.7 (the machine must have 2 free cores).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from common import Row

from harness.scenario import (
    IterationRunner,
    LocalBackend,
    iteration_specs,
    load_run_file,
    run_iterations,
    session_iteration_runner,
)
from tests.scenario.standins import StepLoadRunner


def _throughput(workers: int, specs: list, runner: IterationRunner) -> float:
    start = time.perf_counter()
    results = run_iterations(runner, specs, LocalBackend(workers))
    elapsed = time.perf_counter() - start
    assert all(r.error is None for r in results), [r.error for r in results]
    return len(specs) / elapsed


def _row(name: str, runner: IterationRunner, scenario: str, iterations: int) -> Row:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "s.yaml").write_text(scenario)
        specs = iteration_specs(load_run_file(folder / "s.yaml"), folder / "out", iterations)
        _throughput(2, specs[:2], runner)  # warm the spawn path and the file cache
        one = _throughput(1, specs, runner)
        two = _throughput(2, specs, runner)
    ratio = two / one
    return Row(
        name=name,
        ours=two,
        limit=one,
        unit="it/s",
        target="ratio >= 1.7",
        passed=ratio >= 1.7,
        note=f"1 worker {one:.3f} it/s, 2 workers {two:.3f} it/s",
    )


def run(quick: bool) -> list[Row]:
    iterations = 4 if quick else 8
    session_s = 4.0 if quick else 8.0  # sim seconds at 2 ms: 2k / 4k recorded steps
    load_s = 80.0 if quick else 160.0  # 40k / 80k steps per iteration
    session_scenario = (
        "robots: [{robot: demo}]\nenvironment: {map: table}\n"
        f"duration: {session_s}\nclock: {{mode: fast}}\n"
        "criteria: {allowed_collisions: [['*', box]]}\n"
    )
    return [
        _row(
            f"runner (Session, recorded): {iterations} iterations x {session_s:g} sim s, "
            "2 vs 1 worker",
            session_iteration_runner(),
            session_scenario,
            iterations,
        ),
        _row(
            f"runner (StepLoadRunner): {iterations} iterations x {load_s:g} sim s, 2 vs 1 worker",
            StepLoadRunner(),
            f"robots: [{{robot: demo}}]\nduration: {load_s}\n",
            iterations,
        ),
    ]
