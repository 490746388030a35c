"""Runner throughput: the same batch of iterations on 1 and on 2 local workers, and on one
Dask worker process that shares no files with the client.

Two batches, each real work:

- the session-backed runner ``harness run`` uses (one Session per iteration: the demo arm on
  its table, recorded to MCAP, loggers, state digest every step; no client, fast clock, so the
  runner steps the duration), and
- StepLoadRunner (a small MuJoCo arm stepped without a Session: the runner machinery alone).

The limit is the 1-worker throughput measured in the same run; the target is a 2-worker
speed-up of at least 1.7 (the machine must have 2 free cores). The Dask row runs the session
batch on a ``dask worker`` process (scheduler and worker on 127.0.0.1) through
``DaskBackend``: scenario files sent as blobs, recordings returned to the client; its limit
is one local worker process, its target at least 0.85 of it (what shipping costs; the local
pool starts its spawned process inside its timing, the Dask worker is already running).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import Row

from harness.scenario import (
    DaskBackend,
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


def _dask_row(name: str, scenario: str, iterations: int) -> Row:
    import distributed

    runner = session_iteration_runner()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "s.yaml").write_text(scenario)
        specs = iteration_specs(load_run_file(folder / "s.yaml"), folder / "out", iterations)
        env = {
            **os.environ,
            "HARNESS_WORKER_DIR": str(folder / "worker"),
            "PYTHONPATH": os.pathsep.join([str(Path(__file__).resolve().parents[1]), *sys.path]),
        }
        with distributed.LocalCluster(
            n_workers=0,
            processes=False,
            protocol="tcp://",
            host="127.0.0.1",
            dashboard_address="127.0.0.1:0",
        ) as cluster:
            address = cluster.scheduler_address
            worker = subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", address, "--host",
                 "127.0.0.1", "--nthreads", "1", "--no-nanny", "--no-dashboard"],
                env=env,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )  # fmt: skip
            try:
                run_iterations(runner, specs[:1], DaskBackend(address))  # warm the worker
                _throughput(1, specs[:1], runner)  # warm the spawn path
                one = _throughput(1, specs, runner)
                backend = DaskBackend(address)
                start = time.perf_counter()
                results = run_iterations(runner, specs, backend)
                dask = len(specs) / (time.perf_counter() - start)
                assert all(r.error is None for r in results), [r.error for r in results]
            finally:
                worker.terminate()
                worker.wait(timeout=30)
    log = backend.transfers
    ratio = dask / one
    return Row(
        name=name,
        ours=dask,
        limit=one,
        unit="it/s",
        target="ratio >= 0.85",
        passed=ratio >= 0.85,
        note=f"returned {log.returned_bytes / 1e6:.1f} MB ({log.returned_files} files), "
        f"sent {log.sent_bytes} B once",
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
        _dask_row(
            f"runner (Session, recorded): {iterations} iterations x {session_s:g} sim s, "
            "1 Dask worker sharing no files vs 1 local worker",
            session_scenario,
            iterations,
        ),
    ]
