"""``--preroll SECONDS``: what a client attaching to a resumed session receives before its
live traffic, so that its own state (a filter, a TF buffer, a controller's last command
time) can catch up: the harness restores the simulation, never the robot software's state.

When a client that connected after the resume (not a ghost peer) subscribes to a topic, it
is first sent that topic's recorded messages of the ``SECONDS`` of sim time up to the resume
step (``/clock``, ``/joint_states``, ``/tf``, sensors; topics recorded only as outgoing
frames from their ``publish`` frames), as ``publish`` frames; then live messages follow as
usual. These
frames are a playback of the parent, not part of the resumed run: they are sent, not
recorded (the client's reaction to them is, as its incoming frames).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from harness.recording import Recording, to_plain
from harness.replay import open_recording
from harness.resume.errors import ResumeError
from harness.resume.seek import Fork
from harness.rosbridge import OutgoingFrame

__all__ = ["install_preroll", "preroll_frames"]


def preroll_frames(path: str | Path, step: int, seconds: float) -> dict[str, list[str | bytes]]:
    """Topic -> the ``publish`` frames of the ``seconds`` of sim time up to ``step`` of the
    recording at ``path``: each recorded message of a typed channel (``/joint_states``,
    ``/clock``, ``/tf``, sensors), and for topics without one the recorded outgoing
    ``publish`` frames (one per step, as a ghost peer received it)."""
    if not seconds >= 0:
        raise ResumeError(f"--preroll must be >= 0 seconds, not {seconds!r}")
    out: dict[str, list[str | bytes]] = {}
    rec: Recording
    with open_recording(path, allow_damaged=True) as rec:
        dt_ns = rec.timestep_ns
        first = max(0, step - round(seconds * 1e9 / dt_ns))
        typed = [t for t in rec.topics if not t.startswith("/harness/")]
        for message in rec.messages(typed, start_step=first, stop_step=step + 1, decode=True):
            frame = {"op": "publish", "topic": message.topic, "msg": to_plain(message.msg)}
            out.setdefault(message.topic, []).append(json.dumps(frame))
        seen: set[tuple[int, str]] = set()
        for recorded in rec.bridge_frames(first, step + 1):
            topic = recorded.topic
            if recorded.direction != 1 or recorded.op != "publish" or recorded.step > step:
                continue
            if topic in typed or (recorded.step, topic) in seen:
                continue
            seen.add((recorded.step, topic))
            out.setdefault(topic, []).append(recorded.payload)
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
    receive: Callable[[int, str | bytes, int], list[OutgoingFrame]] = bridge.receive

    def with_preroll(connection: int, data: str | bytes, now_ns: int) -> list[OutgoingFrame]:
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
            out = [OutgoingFrame(connection, f, "publish", topic) for f in frames[topic]] + out
        return out

    setattr(bridge, "receive", with_preroll)  # noqa: B010 (the instance's, not the class's)
