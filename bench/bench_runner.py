"""Runner throughput: the same batch of CPU-bound iterations on 1 and on 2 local workers.

Each iteration is real work: StepLoadRunner steps a small MuJoCo arm (contacts, limits, state
digest every step). The limit is the 1-worker throughput measured in the same run; the target
is a 2-worker speed-up of at least 1.7 (the machine must have 2 free cores).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from common import Row

from harness.scenario import LocalBackend, iteration_specs, load_run_file, run_iterations
from harness.scenario.standins import StepLoadRunner


def _throughput(workers: int, specs: list, runner: StepLoadRunner) -> float:
    start = time.perf_counter()
    results = run_iterations(runner, specs, LocalBackend(workers))
    elapsed = time.perf_counter() - start
    assert all(r.error is None for r in results), [r.error for r in results]
    return len(specs) / elapsed


def run(quick: bool) -> list[Row]:
    iterations = 4 if quick else 8
    duration = 80.0 if quick else 160.0  # sim seconds at 2 ms: 40k / 80k steps per iteration
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "s.yaml").write_text(f"robots: [{{robot: demo}}]\nduration: {duration}\n")
        specs = iteration_specs(load_run_file(folder / "s.yaml"), folder / "out", iterations)
        runner = StepLoadRunner()
        _throughput(2, specs[:2], runner)  # warm the spawn path and the file cache
        one = _throughput(1, specs, runner)
        two = _throughput(2, specs, runner)
    ratio = two / one
    return [
        Row(
            name=f"runner: {iterations} iterations x {duration:g} sim s, 2 vs 1 worker",
            ours=two,
            limit=one,
            unit="it/s",
            target="ratio >= 1.7",
            passed=ratio >= 1.7,
            note=f"1 worker {one:.3f} it/s, 2 workers {two:.3f} it/s",
        )
    ]
