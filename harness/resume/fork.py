"""A fork: the core of a recording brought to a step, with its edits, before a live shell
takes it over (``Session.resume``, ``harness serve --from RUN.mcap --at K``:
:mod:`harness.session.live`).

The core is brought to the step by :func:`harness.resume.seek.seek`, the fork edits are
applied at that step boundary (recorded as that step's input), then a live
:class:`~harness.session.Session` shell takes the core over on the chosen transport (the
embedded rosbridge server, ``connect_to``, ``ros2``). A lockstep run stays in lockstep: time
moves only when a client or Python steps it. A free-running (fast, realtime) run is paused at
the step (a recorded ``pause`` marker): ``session.resume()`` or ``/harness/pause`` false
starts it. The recorded clients whose connections were open at the step are ghost peers:
their subscriptions, advertised topics, services and goals live on in the core, and what the
core sends them is recorded in the child recording but sent nowhere. New clients get the
connection ids after theirs, as they would have in the parent.

The robot software's own state is not restored by the harness: a node attaching to a resumed
session starts from its own initial state (``preroll`` plays it the recorded traffic before
the step so that its state can catch up).
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from pathlib import Path

from harness.resume.edits import Edit, apply_edits, parse_edits
from harness.resume.seek import Fork, seek

__all__ = ["close_fork", "open_fork"]


def open_fork(
    path: str | Path,
    *,
    step: int | None = None,
    at_time: float | None = None,
    record_to: str | Path | None = None,
    edits: Sequence[Edit | str] = (),
) -> Fork:
    """The core of the recording at ``path`` at the step, with ``edits`` applied and a
    free-running clock paused (see ``Session.resume``), not yet in a shell."""
    parsed = parse_edits(edits)
    fork = seek(
        path,
        step=step,
        at_time=at_time,
        record_to=record_to,
        edits=[e.to_json() for e in parsed],
    )
    try:
        core = fork.core
        apply_edits(core, parsed)
        if core.clock != "lockstep" and not core.paused:
            core.set_paused(True)
        core.record_frames()
        assert core.bridge is not None
        core.bridge.drain()
        if core.sensors is not None:
            # An OpenGL context is bound to the thread that made it current (the seek's):
            # the shell's thread starts its own at the next camera frame.
            core.sensors.close()
    except BaseException:
        close_fork(fork, discard=True)
        raise
    return fork


def close_fork(fork: Fork, *, discard: bool = False) -> None:
    """Close a fork no shell took over: its child recording is closed (``discard``: and
    removed, for a resume that did not start)."""
    try:
        if discard:
            with contextlib.suppress(Exception):  # it may have been finished already
                fork.core.finish()
        else:
            fork.core.finish()
    finally:
        if fork.recorder is not None:
            fork.recorder.close()  # idempotent
            if discard:
                with contextlib.suppress(OSError):
                    fork.recorder.path.unlink()
