"""The recorded form of the bridge's frames and of the core's markers.

Every frame the session's bridge sends or receives, and every marker
(:mod:`harness.session.core.markers`), is recorded as a ``/harness/bridge``
:class:`~harness.recording.records.BridgeFrame` at the step it crossed at: an incoming
frame or a marker took effect before the next step (``step`` is that step), an outgoing
frame was sent at the current one. :func:`tap_frame` makes the record of a frame the bridge
kept (a :class:`~harness.rosbridge.TapRecord`), :func:`marker_frame` that of a marker; the
core writes them to its :class:`~harness.session.core.RecordSink`.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from harness.recording import BridgeFrame
from harness.rosbridge import DIRECTION_IN, TapRecord

__all__ = ["marker_frame", "tap_frame"]


def tap_frame(record: TapRecord, dt_ns: int) -> BridgeFrame:
    """The record of a frame the bridge kept, in a simulation of time step ``dt_ns``."""
    seq, connection, direction, data, op, name, now_ns = record
    k = now_ns // dt_ns  # the step it crossed at
    step = k + 1 if direction == DIRECTION_IN else k
    # positional (tuple.__new__): every frame in and out is recorded through here
    if isinstance(data, bytes):
        fields = (step, k * dt_ns, direction, connection, seq, op, name, True, "", data)
    else:
        fields = (step, k * dt_ns, direction, connection, seq, op, name, False, data, b"")
    return _new(BridgeFrame, fields)


_new = tuple.__new__


def marker_frame(
    topic: str, args: Mapping[str, Any], *, step: int, dt_ns: int, seq: int
) -> BridgeFrame:
    """The record of marker ``topic`` with ``args`` (its JSON text) applied at step
    boundary ``step``; ``seq``: the sequence number the bridge's next frame gets."""
    return BridgeFrame(
        step=step + 1,
        sim_time_ns=step * dt_ns,
        direction=DIRECTION_IN,
        connection=0,
        seq=seq,
        op="",
        topic=topic,
        binary=False,
        text=json.dumps(args, sort_keys=True),
        data=b"",
    )
