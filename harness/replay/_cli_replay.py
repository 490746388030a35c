"""``harness replay FILE.mcap``: verify that a recording replays (exit 0), or re-simulate it
with every joint kinematic or a servo (``--actuation``; ``--mode`` is its deprecated
spelling)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from harness.vocabulary import ACTUATION_INPUTS, ACTUATIONS, Actuation

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``replay`` subcommand's options."""
    parser.add_argument("file", type=Path, help="the recording (.mcap)")
    parser.add_argument("--atol", type=float, default=0.0, help="absolute tolerance (0: exact)")
    parser.add_argument("--rtol", type=float, default=0.0, help="relative tolerance (0: exact)")
    parser.add_argument(
        "--level",
        choices=("physics", "full"),
        default="physics",
        help=(
            "physics: states from inputs; full: also re-run the session's bridge pipeline "
            "and compare every frame, applied input and state"
        ),
    )
    switch = parser.add_mutually_exclusive_group()
    switch.add_argument(
        "--actuation",
        choices=ACTUATIONS,
        default=None,
        help="re-simulate the recorded joint commands with every joint kinematic, or every "
        "joint a position servo; a recording with a mobile base controller: re-run its "
        "/cmd_vel with a planar (kinematic) or a diff drive (servo) base",
    )
    switch.add_argument(
        "--mode",
        choices=ACTUATION_INPUTS,
        default=None,
        help="deprecated spelling of --actuation (position and dynamic mean servo)",
    )
    parser.add_argument("--report", type=Path, default=None, help="write the report as JSON")
    parser.add_argument(
        "--allow-damaged", action="store_true", help="replay what precedes damage in the file"
    )
    parser.add_argument("--max-tracking-error", type=float, default=None, metavar="RAD")
    parser.add_argument("--max-limit-violation", type=float, default=None, metavar="RAD")
    parser.add_argument("--max-velocity-ratio", type=float, default=None, metavar="RATIO")
    parser.add_argument("--max-penetration", type=float, default=None, metavar="M")
    parser.add_argument("--max-energy-jump", type=float, default=None, metavar="J")


def run(args: argparse.Namespace) -> int:
    """Exit 0: reproduced (or no threshold exceeded with --mode); 1: diverged (exceeded)."""
    from harness.replay.progress import progress_bar

    if args.mode is not None:
        print(
            f"harness replay: --mode is deprecated, use --actuation "
            f"{Actuation.parse(args.mode).value}",
            file=sys.stderr,
        )
        args.actuation = args.mode
    if args.actuation is not None:
        from harness.replay.resim import resimulate
        from harness.replay.resim_report import Thresholds

        defaults = Thresholds()
        thresholds = Thresholds(
            **{
                name: getattr(args, name) if getattr(args, name) is not None else value
                for name, value in defaults._asdict().items()
            }
        )
        mode = Actuation.parse(args.actuation)
        from harness.replay.base_resim import is_base_recording, resimulate_base

        if is_base_recording(args.file):
            base = resimulate_base(args.file, mode, allow_damaged=args.allow_damaged)
            print(base.format())
            if args.report is not None:
                args.report.write_text(json.dumps(base.to_json(), indent=2) + "\n")
            limit = args.max_tracking_error  # a base's: the path deviation in metres
            return 0 if limit is None or base.max_path_deviation <= limit else 1
        with progress_bar(f"re-simulating ({mode})") as progress:
            resim = resimulate(
                args.file,
                mode,
                thresholds=thresholds,
                allow_damaged=args.allow_damaged,
                progress=progress,
            )
        print(resim.format())
        if args.report is not None:
            args.report.write_text(json.dumps(resim.to_json(), indent=2) + "\n")
        return 0 if resim.passed else 1

    from harness.replay.verify import verify

    with progress_bar("replaying") as progress:
        report = verify(
            args.file,
            atol=args.atol,
            rtol=args.rtol,
            level=args.level,
            allow_damaged=args.allow_damaged,
            progress=progress,
        )
    print(report.format())
    if args.report is not None:
        args.report.write_text(json.dumps(report.to_json(), indent=2) + "\n")
    sys.stdout.flush()
    return 0 if report.reproduced else 1
