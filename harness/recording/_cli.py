"""``harness inspect FILE [--json]``: exit 0 when sound, 1 when truncated or damaged, 2 when
the file cannot be read as a recording at all."""

from __future__ import annotations

import argparse
import json

from harness.recording.inspect import VERDICT_OK, format_report, inspect

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``harness inspect``."""
    parser.add_argument("file", help="an MCAP recording")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")


def run(args: argparse.Namespace) -> int:
    """Print the report; the exit code is the verdict."""
    report = inspect(args.file)
    print(json.dumps(report, indent=2) if args.json else format_report(report))
    return 0 if report["verdict"] == VERDICT_OK else 1
