"""``harness repair IN OUT``: write the intact contents of a damaged or truncated recording
(a killed recorder's file, a file with a bad chunk) as a complete recording; exit 0 when
``OUT`` was written (what was lost is listed), 2 when ``IN`` is not a readable recording."""

from __future__ import annotations

import argparse

from harness.recording.repair import repair

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``harness repair``."""
    parser.add_argument("source", metavar="IN", help="a damaged or truncated MCAP recording")
    parser.add_argument("target", metavar="OUT", help="where to write the repaired recording")


def run(args: argparse.Namespace) -> int:
    """Repair and print what was kept and what was lost."""
    print(repair(args.source, args.target).format())
    return 0
