"""``harness diff A.mcap B.mcap``: compare two recordings with per-quantity tolerances."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``diff`` subcommand's options (one per :class:`~harness.replay.diff.Tolerances`)."""
    parser.add_argument("a", type=Path, help="the reference recording (e.g. the golden)")
    parser.add_argument("b", type=Path, help="the recording to compare with it")
    parser.add_argument("--joint-position", type=float, default=0.0, metavar="TOL")
    parser.add_argument("--joint-velocity", type=float, default=0.0, metavar="TOL")
    parser.add_argument("--link-position", type=float, default=0.0, metavar="M")
    parser.add_argument("--link-rotation", type=float, default=0.0, metavar="RAD")
    parser.add_argument("--collision-time-ns", type=int, default=0, metavar="NS")
    parser.add_argument("--message-count", type=int, default=0, metavar="N")
    parser.add_argument(
        "--ignore-after-last-step",
        action="store_true",
        help="leave out the bridge frames applied after each recording's last step (a "
        "client's goodbye), as golden checks do",
    )
    parser.add_argument("--report", type=Path, default=None, help="write the report as JSON")


def run(args: argparse.Namespace) -> int:
    """Exit 0: same within tolerances; 1: different."""
    from harness.replay.diff import Tolerances, diff

    tolerances = Tolerances(
        joint_position=args.joint_position,
        joint_velocity=args.joint_velocity,
        link_position=args.link_position,
        link_rotation=args.link_rotation,
        collision_time_ns=args.collision_time_ns,
        message_count=args.message_count,
    )
    report = diff(args.a, args.b, tolerances, ignore_after_last_step=args.ignore_after_last_step)
    print(report.format())
    if args.report is not None:
        args.report.write_text(json.dumps(report.to_json(), indent=2, default=str) + "\n")
    return 0 if report.same else 1
