"""``harness run FILE``: run a scenario or runner file's iterations and write the reports."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from harness.errors import ConfigError
from harness.scenario.dask_backend import DaskBackend
from harness.scenario.interrupt import Interrupted, RunInterrupted, raise_on_signals
from harness.scenario.reports import print_summary, write_reports
from harness.scenario.results import IterationResult, IterationRunner
from harness.scenario.runfile import RunConfig, load_run_file
from harness.scenario.runner import (
    Backend,
    LocalBackend,
    check_runnable,
    iteration_specs,
    run_iterations,
    session_iteration_runner,
)

__all__ = ["add_arguments", "execute", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``harness run``."""
    parser.add_argument("file", type=Path, help="a scenario file or a runner config (JSON/YAML)")
    parser.add_argument("--iterations", type=int, metavar="N", help="iterations per simulation")
    parser.add_argument(
        "--workers",
        type=int,
        metavar="K",
        help="local worker processes (default: the file's 'workers', else the CPU count)",
    )
    parser.add_argument(
        "--check-determinism",
        action="store_true",
        help="require identical state streams across iterations (runs at least 2)",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("harness-results"),
        metavar="DIR",
        help="results folder: junit.xml, results.json, report.html, recordings",
    )
    parser.add_argument("--backend", choices=("local", "dask"), default="local")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler (--backend dask)")


def _backend(args: argparse.Namespace, config: RunConfig) -> Backend:
    if args.backend == "dask":
        if not args.scheduler:
            raise ConfigError("--backend dask needs --scheduler ADDRESS (e.g. tcp://host:8786)")
        return DaskBackend(args.scheduler)
    if args.scheduler:
        raise ConfigError("--scheduler is only used with --backend dask")
    workers = args.workers or config.workers or os.cpu_count() or 1
    if workers < 1:
        raise ConfigError(f"--workers: {workers} must be at least 1")
    return LocalBackend(workers)


def execute(
    config: RunConfig,
    runner: IterationRunner,
    backend: Backend,
    out_dir: Path,
    console: Console,
    iterations: int | None = None,
    check_determinism: bool = False,
) -> list[IterationResult]:
    """Run every iteration of ``config`` with ``runner`` on ``backend`` (live progress on a
    terminal), write the reports into ``out_dir`` and print the summary table."""
    if iterations is not None and iterations < 1:
        raise ConfigError(f"--iterations: {iterations} must be at least 1")
    if check_determinism or any(p.scenario.criteria.deterministic for p in config.simulations):
        # Determinism is judged across iterations: every judged simulation runs at least 2.
        plans = []
        for plan in config.simulations:
            count = iterations if iterations is not None else plan.iterations
            if count < 2 and (check_determinism or plan.scenario.criteria.deterministic):
                console.print(
                    f"note: {plan.name}: running 2 iterations to check determinism", style="yellow"
                )
                count = 2
            plans.append(replace(plan, iterations=count))
        config = replace(config, simulations=tuple(plans))
        iterations = None
    specs = iteration_specs(config, out_dir, iterations)
    if console.is_terminal:
        with Progress(
            TextColumn("[bold]harness run"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[last]}"),
            TimeElapsedColumn(),
            console=console,
            transient=True,
        ) as progress:
            task = progress.add_task("iterations", total=len(specs), last="")

            def advance(result: IterationResult) -> None:
                mark = "PASS" if result.passed else "FAIL"
                progress.update(
                    task, advance=1, last=f"{result.simulation} #{result.iteration} {mark}"
                )

            try:
                results = run_iterations(runner, specs, backend, check_determinism, advance)
            except RunInterrupted as exc:
                _write_partial(exc, out_dir, config, console)
                raise
    else:
        try:
            results = run_iterations(runner, specs, backend, check_determinism)
        except RunInterrupted as exc:
            _write_partial(exc, out_dir, config, console)
            raise
    paths = write_reports(results, out_dir, config.source)
    print_summary(results, console)
    if isinstance(backend, DaskBackend):  # what crossed the network, with sizes
        for line in backend.transfers.summary():
            console.print(line, highlight=False, markup=False, soft_wrap=True)
    for name, path in paths.items():
        console.print(f"{name}: {path}")
    return results


def _write_partial(exc: RunInterrupted, out_dir: Path, config: RunConfig, console: Console) -> None:
    """The reports of an interrupted run: the iterations that ran, nothing else."""
    paths = write_reports(exc.results, out_dir, config.source)
    print_summary(exc.results, console)
    for name, path in paths.items():
        console.print(f"{name}: {path}")


def run(args: argparse.Namespace) -> int:
    """``harness run``: exit 0 when every iteration passed, 1 otherwise."""
    config = load_run_file(args.file)
    check_runnable(config)
    console = Console()
    for notice in config.notices:
        print(f"harness run: note: {notice}", file=sys.stderr)
    backend = _backend(args, config)
    runner = session_iteration_runner()
    try:
        with raise_on_signals():
            results = execute(
                config, runner, backend, args.out, console, args.iterations, args.check_determinism
            )
    except RunInterrupted as exc:
        print(f"harness run: {exc}; reports written to {args.out}", file=sys.stderr)
        return exc.exit_code
    except Interrupted as exc:
        print(f"harness run: {exc}", file=sys.stderr)
        return 128 + exc.signum
    return 0 if all(r.passed for r in results) else 1


def main(argv: Sequence[str] | None = None) -> int:  # pragma: no cover - convenience
    parser = argparse.ArgumentParser(prog="harness run")
    add_arguments(parser)
    return run(parser.parse_args(argv))
