"""``harness explore FILE``: search a scenario's ``explore`` parameters for a failure, shrink
it, and write the minimal case, its recording, a regression test and the report.

Exit codes: 1 a failure was found, 0 none within the budget (the summary says how many
examples ran), 2 a bad file or option (one line on stderr).
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from rich.console import Console

from harness.errors import ConfigError
from harness.explore.outputs import write_minimal, write_summary
from harness.explore.plan import load_plan
from harness.explore.report import print_report, write_html
from harness.explore.search import SearchOptions, search

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``harness explore``."""
    parser.add_argument("file", type=Path, help="a scenario file with an explore: section")
    parser.add_argument(
        "--examples", type=int, default=200, metavar="N", help="examples to generate (all workers)"
    )
    parser.add_argument(
        "--time", type=float, metavar="SECONDS", help="stop generating after this wall time"
    )
    parser.add_argument("--seed", type=int, default=0, metavar="S", help="worker i seeds S+i")
    parser.add_argument("--workers", type=int, default=1, metavar="K", help="engines side by side")
    parser.add_argument("--backend", choices=("local", "dask"), default="local")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler (--backend dask)")
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("harness-explore"),
        metavar="DIR",
        help="minimal.yaml, minimal.mcap, test_minimal.py, summary.json, report.html",
    )
    parser.add_argument(
        "--database",
        type=Path,
        metavar="DIR",
        help="hypothesis example database shared by the workers (default: DIR/.hypothesis)",
    )
    parser.add_argument(
        "--keep-passing",
        type=int,
        default=0,
        metavar="N",
        help="keep the scenario and recording of N passing examples per worker",
    )
    parser.add_argument(
        "--cold",
        action="store_true",
        help="compile the world for every example (no reuse of a compiled world)",
    )


def run(args: argparse.Namespace) -> int:
    """``harness explore``: exit 1 when a failure was found, 0 when none."""
    if args.backend == "dask" and not args.scheduler:
        raise ConfigError("--backend dask needs --scheduler ADDRESS (e.g. tcp://127.0.0.1:8786)")
    if args.backend == "local" and args.scheduler:
        raise ConfigError("--scheduler is only used with --backend dask")
    if args.keep_passing < 0:
        raise ConfigError(f"--keep-passing: {args.keep_passing} must be >= 0")
    plan = load_plan(args.file)
    clock = plan.document.get("clock")
    if not isinstance(clock, dict) or clock.get("mode", "realtime") == "realtime":
        print(
            f"harness explore: note: {plan.source.name} runs a realtime clock (no clock section "
            "or mode realtime): every example takes its duration in wall time; "
            "clock: {mode: lockstep} makes examples as fast as the machine",
            file=sys.stderr,
        )
    out: Path = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    for stale in ("minimal.yaml", "minimal.mcap", "test_minimal.py"):
        (out / stale).unlink(missing_ok=True)
    work = out / ".work"
    shutil.rmtree(work, ignore_errors=True)
    options = SearchOptions(
        work=work,
        examples=args.examples,
        seconds=args.time,
        seed=args.seed,
        workers=args.workers,
        database=(args.database or out / ".hypothesis").resolve(),
        keep_passing=args.keep_passing,
        scheduler=args.scheduler if args.backend == "dask" else None,
        fast=not args.cold,
    )
    console = Console()
    result = search(plan, options)
    primary = result.primary()
    minimal = write_minimal(result, primary, out) if primary is not None else None
    summary = write_summary(result, minimal, out, {"seed": args.seed, "workers": args.workers})
    html = write_html(result, minimal, out)
    print_report(result, minimal, console)
    console.print(f"summary: {summary}\nreport: {html}", highlight=False)
    if primary is None:
        print(
            f"harness explore: no failure in {len(result.examples)} examples "
            f"({result.generated} generated)",
            file=sys.stderr,
        )
        return 0
    return 1
