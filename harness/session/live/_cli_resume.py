"""``harness serve --from RUN.mcap --at STEP|--at-time SECONDS``: a recording continued live.

Prints the URL on its first line, as ``harness serve`` does, with the step, the ghost peers
and the child recording; stops on SIGINT/SIGTERM with the child recording complete. Bad input
(a step beyond the recording, a damaged stretch before it, another MuJoCo or harness version)
is one line on stderr and exit code 2 (:class:`~harness.resume.ResumeError` is a
:class:`~harness.errors.HarnessError`).
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path
from types import FrameType
from typing import Any

from harness.recording import Recording
from harness.replay import open_recording
from harness.resume import ResumeError, resolve_step
from harness.session.live.session import Session

__all__ = ["child_path", "run_resumed"]

# serve's options that say what to simulate: a resumed run simulates what the recording did
_FROM_RECORDING = (
    ("robot", "--robot", "demo"),
    ("scene", "--scene", None),
    ("controllers", "--controllers", None),
    ("namespace", "--namespace", ""),
    ("clock", "--clock", None),
    ("mode", "--mode", "position"),
    ("kinematic_limits", "--kinematic-limits", "clamp"),
)


def child_path(parent: Path, step: int) -> Path:
    """The default child recording of ``parent`` resumed at ``step``: ``STEM.at-STEP.mcap``
    in the current directory."""
    return Path(f"{parent.stem}.at-{step}.mcap")


def _step_of(parent: Path, step: int | None, at_time: float | None) -> int:
    rec: Recording
    with open_recording(parent, allow_damaged=True) as rec:
        return resolve_step(parent, rec.last_step, rec.timestep_ns, step, at_time)


def run_resumed(args: argparse.Namespace) -> int:
    """Serve the resumed run until SIGINT/SIGTERM; exit 0 after a clean shutdown."""
    for name, flag, default in _FROM_RECORDING:
        if getattr(args, name, default) != default:
            raise ResumeError(
                f"{flag} does not apply with --from: a resumed run simulates what "
                f"{args.resume_from} recorded (its robot, world, controllers and clock)"
            )
    if args.preroll < 0:
        raise ResumeError(f"--preroll must be >= 0 seconds, not {args.preroll:g}")
    parent = Path(args.resume_from)
    step = _step_of(parent, args.resume_at, args.resume_at_time)
    record = Path(args.record) if args.record else child_path(parent, step)
    if record.resolve() == parent.resolve():
        raise ResumeError(f"--record {record}: the child recording cannot overwrite its parent")
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    previous: dict[int, Any] = {}
    try:
        with Session.resume(
            parent,
            step=step,
            record_to=record,
            edits=list(args.resume_edits),
            preroll=args.preroll,
            host=args.host,
            port=args.port,
            token=args.token,
            connect_to=args.connect,
            connect_allow_refused=args.connect_allow_refused,
            ros2=args.ros2,
        ) as session:
            previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
            bridge = session.core.bridge
            ghosts = [] if bridge is None else bridge.connections
            ghost_text = (
                f"ghost peers: connection{'s' if len(ghosts) > 1 else ''} "
                + ", ".join(str(c) for c in ghosts)
                if ghosts
                else "no ghost peers"
            )
            clock = session.clock + (" (paused)" if session.clock != "lockstep" else "")
            extra = f", ROS 2 on domain {session.ros_domain_id}" if args.ros2 else ""
            print(
                f"harness serve: {session.url} resumed {parent} at step {step} "
                f"({step * session.dt_ns / 1e9:g} s), robot {session.robot_name}, clock "
                f"{clock}{extra}, {ghost_text}; recording {record}; Ctrl-C to stop",
                flush=True,
            )
            while not stop.wait(0.5) and session.failure is None:
                pass
            reached = session.step_index
            failure = session.failure
        if failure is not None:
            print(f"harness serve: error: {failure}, recording {record} closed", file=sys.stderr)
            return 1
        print(
            f"harness serve: stopped at step {reached}, recording {record} closed (harness diff "
            f"{parent} {record}: the first divergence after the fork)",
            flush=True,
        )
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0
