"""The ``harness`` command.

Each subcommand lives next to the code it drives, in a module exposing
``add_arguments(parser)`` and ``run(args) -> int``; this module only dispatches, importing a
subcommand's module when that subcommand runs, so ``harness --version`` stays instant.
Any :class:`~harness.errors.HarnessError` becomes one line on stderr and exit code 2; a
warning is one line, ``harness: warning: <message>``, said once (:mod:`harness.cli_warnings`);
output into a closed pipe (``harness inspect FILE | head``) ends quietly with exit code 141, as a
shell reports SIGPIPE.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import os
import signal
import sys
from collections.abc import Sequence
from types import ModuleType
from typing import NamedTuple

from harness._version import __version__
from harness.cli_warnings import one_line_warnings
from harness.errors import HarnessError

__all__ = ["main"]


class Command(NamedTuple):
    module: str
    help: str


# One line per subcommand: name -> (module with add_arguments/run, one-line help).
COMMANDS: dict[str, Command] = {
    "demo": Command("harness.demo", "run the embedded demo end to end"),
    "inspect-model": Command("harness.models._cli", "links, joints and frames of a robot model"),
    "check-model": Command("harness.models.check._cli", "does a robot load, hold, step, stand"),
    "run": Command("harness.scenario._cli", "run a scenario or runner file's iterations"),
    "explore": Command(
        "harness.explore._cli", "search a scenario's parameters for a failure and shrink it"
    ),
    "inspect": Command("harness.recording._cli", "contents and validity of a recording"),
    "repair": Command(
        "harness.recording._cli_repair", "rewrite a damaged recording's intact parts"
    ),
    "serve": Command("harness.session.live._cli", "serve a simulated robot on a rosbridge server"),
    "replay": Command("harness.replay._cli_replay", "verify a recording replays bit for bit"),
    "play": Command("harness.replay._cli_play", "serve a recording's frames to rosbridge clients"),
    "diff": Command("harness.replay._cli_diff", "compare two recordings with tolerances"),
}


def _build_parser() -> tuple[argparse.ArgumentParser, dict[str, argparse.ArgumentParser]]:
    parser = argparse.ArgumentParser(
        prog="harness",
        description="Deterministic record-replay simulation tests for ROS robot software.",
    )
    parser.add_argument("--version", action="version", version=f"harness {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    subparsers = {
        name: sub.add_parser(name, help=cmd.help, description=cmd.help)
        for name, cmd in COMMANDS.items()
    }
    return parser, subparsers


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``harness`` console script; returns the exit code."""
    parser, subparsers = _build_parser()
    args_list = list(sys.argv[1:] if argv is None else argv)
    name = next((a for a in args_list if not a.startswith("-")), None)
    if name in COMMANDS:
        module = importlib.import_module(COMMANDS[name].module)
        module.add_arguments(subparsers[name])
    args = parser.parse_args(args_list)
    if args.command is None:
        parser.print_help()
        return 2
    module = importlib.import_module(COMMANDS[args.command].module)
    with one_line_warnings():
        return _run(module, args)


def _run(module: ModuleType, args: argparse.Namespace) -> int:
    """``module.run(args)`` with the command's exit-code conventions."""
    try:
        code = int(module.run(args))
        sys.stdout.flush()  # a closed pipe raises here, not at exit
        return code
    except BrokenPipeError:
        _silence_stdout()
        return 128 + signal.SIGPIPE
    except HarnessError as exc:
        print(f"harness {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


def _silence_stdout() -> None:
    """The reader of stdout went away: what is still buffered goes to /dev/null, so that
    Python's flush at exit does not raise BrokenPipeError again (the recipe of the
    :mod:`signal` documentation)."""
    with contextlib.suppress(OSError, io.UnsupportedOperation, ValueError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())


if __name__ == "__main__":
    sys.exit(main())
