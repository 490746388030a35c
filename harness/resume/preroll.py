"""``--preroll SECONDS``: what a client attaching to a resumed session receives before its
live traffic, so that its own state (a filter, a TF buffer, a controller's last command
time) can catch up: the harness restores the simulation, never the robot software's state.

When a client that connected after the resume (not a ghost peer) subscribes to a topic, it
is first sent the recorded ``publish`` frames of that topic from the ``SECONDS`` of sim time
before the resume step (one copy per step, as a ghost peer received them), and for
``/clock`` the recorded clock of those steps; then live messages follow as usual. These
frames are a playback of the parent, not part of the resumed run: they are sent, not
recorded (the client's reaction to them is, as its incoming frames).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from harness.recording import Recording
from harness.replay import open_recording
from harness.resume.errors import ResumeError
from harness.resume.seek import Fork
from harness.rosbridge import Output

__all__ = ["CLOCK", "install_preroll", "preroll_frames"]

CLOCK = "/clock"


def preroll_frames(path: str | Path, step: int, seconds: float) -> dict[str, list[str | bytes]]:
    """Topic -> the recorded ``publish`` frames of the ``seconds`` of sim time up to ``step``
    of the recording at ``path`` (one per step and topic), ``/clock`` from its recorded clock
    when no client subscribed to it."""
    if not seconds >= 0:
        raise ResumeError(f"--preroll must be >= 0 seconds, not {seconds!r}")
    out: dict[str, list[str | bytes]] = {}
    rec: Recording
    with open_recording(path, allow_damaged=True) as rec:
        dt_ns = rec.timestep_ns
        first = max(0, step - round(seconds * 1e9 / dt_ns))
        seen: set[tuple[int, str]] = set()
        for frame in rec.bridge_frames(first, step + 1):
            if frame.direction != 1 or frame.op != "publish" or frame.step > step:
                continue
            if (frame.step, frame.topic) in seen:
                continue
            seen.add((frame.step, frame.topic))
            out.setdefault(frame.topic, []).append(frame.payload)
        if CLOCK not in out:
            clock: list[str | bytes] = []
            for message in rec.messages(CLOCK, start_step=first, stop_step=step + 1):
                ns = message.sim_time_ns
                msg = {"clock": {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}}
                clock.append(json.dumps({"op": "publish", "topic": CLOCK, "msg": msg}))
            if clock:
                out[CLOCK] = clock
    return out


def install_preroll(fork: Fork, path: str | Path, seconds: float) -> None:
    """Make ``fork``'s bridge send each client that connects from now on the preroll of a
    topic (:func:`preroll_frames`) before the answer to its first subscription of it."""
    frames = preroll_frames(path, fork.step, seconds)
    bridge = fork.core.bridge
    if bridge is None or not frames:
        return
    first_live = bridge.opened + 1
    served: set[tuple[int, str]] = set()
    receive: Callable[[int, str | bytes, int], list[Output]] = bridge.receive

    def with_preroll(connection: int, data: str | bytes, now_ns: int) -> list[Output]:
        out = receive(connection, data, now_ns)
        if connection < first_live or not isinstance(data, str) or '"subscribe"' not in data:
            return out
        try:
            frame = json.loads(data)
            topic = str(frame["topic"]) if frame.get("op") == "subscribe" else ""
        except (ValueError, KeyError, TypeError, AttributeError):
            return out
        if topic in frames and (connection, topic) not in served:
            served.add((connection, topic))
            out = [Output(connection, f, "publish", topic) for f in frames[topic]] + out
        return out

    setattr(bridge, "receive", with_preroll)  # noqa: B010 (the instance's, not the class's)
