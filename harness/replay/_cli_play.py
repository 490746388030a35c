"""``harness play FILE``: serve a recording's topics to rosbridge clients on its schedule, like
``ros2 bag play``."""

from __future__ import annotations

import argparse
import asyncio
import os
from pathlib import Path

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``play`` subcommand's options."""
    parser.add_argument("file", type=Path, help="the recording (.mcap)")
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    parser.add_argument("--port", type=int, default=9090, help="WebSocket port (0: any free)")
    parser.add_argument(
        "--token",
        default=os.environ.get("HARNESS_TOKEN") or None,
        help="clients must present this token: ws://HOST:PORT/?token=TOKEN "
        "(default: $HARNESS_TOKEN; none when unset)",
    )
    parser.add_argument("--rate", type=float, default=1.0, help="sim time per wall time")
    parser.add_argument(
        "--start",
        choices=("now", "paused", "on_client"),
        default="on_client",
        help="when the clock starts: on_client (default: when a client subscribes to a played "
        "topic), paused (on /harness/step or /harness/resume), now",
    )
    parser.add_argument("--loop-forever", action="store_true", help="keep serving at the end")


async def _main(args: argparse.Namespace) -> int:
    from harness.replay.play import Player

    player = Player(
        args.file,
        host=args.host,
        port=args.port,
        rate=args.rate,
        start=args.start,
        token=args.token,
    )
    url = await player.start()
    print(f"playing {args.file} on {url} ({len(player.items)} messages, steps "
          f"{player.first_step}..{player.last_step}, rate {args.rate:g})", flush=True)  # fmt: skip
    if player.assets is not None:
        print(f"meshes of robot_description served on {player.assets.url}", flush=True)
    try:
        await player.run()
        print(f"finished at step {player.step}", flush=True)
        if args.loop_forever:
            await asyncio.Event().wait()
    finally:
        await player.stop()
    return 0


def run(args: argparse.Namespace) -> int:
    """Serve until the recording ends (Ctrl-C stops)."""
    return asyncio.run(_main(args))
