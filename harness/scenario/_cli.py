"""``harness run FILE``: run a scenario or runner file's iterations and write the reports."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from rich.console import Console

from harness.errors import ConfigError
from harness.scenario.dask_backend import DaskBackend
from harness.scenario.execute import run_scenarios
from harness.scenario.interrupt import Interrupted, RunInterrupted, raise_on_signals
from harness.scenario.runfile import RunConfig, load_run_file
from harness.scenario.runner import (
    Backend,
    LocalBackend,
    check_runnable,
    session_iteration_runner,
)

__all__ = ["add_arguments", "run"]


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
            results = run_scenarios(
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
