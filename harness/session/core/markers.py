"""Markers: inputs that are not frames a client sent, yet change what the session core does.

They are recorded as ``/harness/bridge`` frames with ``direction`` 0 (in), ``connection`` 0
(real connections count from 1), ``op`` ``""``, ``topic`` one of :data:`MARKERS` and a JSON
``text``; ``seq`` is the sequence number the next real frame gets (markers do not consume
one), ``step`` and ``sim_time_ns`` as for incoming frames (the step before which it took
effect):

- ``harness/disconnect`` ``{"connection": c}``: a client's socket closed;
- ``harness/call_timeout`` ``{"call": key}``: a service call routed to a client timed out on
  the wall clock (the transport's timer);
- ``harness/transport_status`` ``{"connection": c, "level": l, "msg": m}``: a ``status``
  frame the transport sent by itself (subscription frames dropped for a slow reader, a
  client-mode link lost or back);
- ``harness/python`` ``{"call": "command" | "set_positions" | "reset" | "pause" |
  "set_parameter" | "set_sensor_noise" | "set_body_pose", ...}``:
  a call of the session's Python API that changes the run (stepping from Python needs no
  marker: replay steps to the recorded steps); a free-running clock started by its first
  client (``start="on_client"``) is recorded as ``{"call": "pause", "paused": false}``;
- ``harness/close`` ``{"step": k}``: the session closed after step ``k``, once every frame
  it received was processed; only ``harness/disconnect`` markers of connections still open
  follow it. It changes nothing (replay re-records it);
- ``harness/unbudgeted`` ``{"connection": c}``: connection ``c`` is the harness's own link
  (client mode's connection to the external server), sent everything without a send budget
  (:mod:`harness.rosbridge.budget`).

A connection opening needs no marker: a connection has no effect until its first frame, and
ids are given in order, so replay opens connection ``c`` when its first frame (or marker)
appears. :func:`replay_marker` applies a recorded marker to a core as the live session did.
"""

from __future__ import annotations

import json
from collections.abc import Container, Mapping, Sequence
from typing import Any, Protocol

from harness.rosbridge import DIRECTION_IN
from harness.session.errors import SessionError

__all__ = [
    "MARKERS",
    "MARKER_CALL_TIMEOUT",
    "MARKER_CLOSE",
    "MARKER_DISCONNECT",
    "MARKER_PYTHON",
    "MARKER_TRANSPORT_STATUS",
    "MARKER_UNBUDGETED",
    "MarkedBridge",
    "MarkedCore",
    "is_marker",
    "open_connection",
    "replay_marker",
]

MARKER_DISCONNECT = "harness/disconnect"
MARKER_CALL_TIMEOUT = "harness/call_timeout"
MARKER_TRANSPORT_STATUS = "harness/transport_status"
MARKER_PYTHON = "harness/python"
MARKER_CLOSE = "harness/close"
MARKER_UNBUDGETED = "harness/unbudgeted"
MARKERS = (
    MARKER_DISCONNECT,
    MARKER_CALL_TIMEOUT,
    MARKER_TRANSPORT_STATUS,
    MARKER_PYTHON,
    MARKER_CLOSE,
    MARKER_UNBUDGETED,
)
"""The ``topic`` of every marker frame (see the module docstring)."""


def is_marker(direction: int, connection: int, op: str, topic: str) -> bool:
    """Whether a recorded ``/harness/bridge`` frame is a marker, not a frame a client sent."""
    return direction == DIRECTION_IN and connection == 0 and op == "" and topic in MARKERS


class MarkedBridge(Protocol):
    """What replaying a marker does to a bridge (the session's
    :class:`~harness.session.core.bridge.SessionBridge` is one): declared here, so that the
    bridge, which records markers, and this module, which replays them, do not import each
    other."""

    @property
    def connections(self) -> Container[int]: ...

    def connect(self, peer: str = "") -> int: ...

    def disconnect(self, connection: int) -> object: ...

    def time_out_call(self, key: int) -> object: ...

    def transport_status(self, connection: int, level: str, msg: str) -> None: ...

    def exempt_from_budget(self, connection: int) -> None: ...


class MarkedCore(Protocol):
    """What replaying a marker does to a core (:class:`~harness.session.core.SessionCore` is
    one, which imports this module)."""

    @property
    def bridge(self) -> MarkedBridge | None: ...

    def record_close(self) -> None: ...

    def command(
        self,
        joint: str,
        *,
        position: float | None = None,
        velocity: float | None = None,
        effort: float | None = None,
    ) -> object: ...

    def set_positions(self, positions: Mapping[str, float]) -> object: ...

    def reset(self) -> object: ...

    def set_paused(self, paused: bool) -> object: ...

    def set_parameter(self, controller: str, name: str, value: float) -> None: ...

    def set_sensor_noise(self, sensor: str, stddev: float) -> None: ...

    def set_body_pose(
        self, body: str, position: Sequence[float], orientation: Sequence[float] | None = None
    ) -> None: ...


def open_connection(bridge: MarkedBridge, connection: int) -> None:
    """Open ``connection`` (and any lower id not yet opened) as the live bridge did."""
    while connection not in bridge.connections and bridge.connect() < connection:
        pass


def replay_marker(core: MarkedCore, topic: str, payload: str | bytes) -> None:
    """Apply one recorded marker to ``core`` at the current step boundary (its bridge: the
    core's own); a malformed marker raises :class:`SessionError` naming it."""
    bridge = core.bridge
    if bridge is None:
        raise SessionError("replay needs the session's own bridge (not client mode)")
    try:
        args = json.loads(payload)
        if not isinstance(args, dict):
            raise TypeError("not an object")
        if topic == MARKER_DISCONNECT:
            open_connection(bridge, int(args["connection"]))
            bridge.disconnect(int(args["connection"]))
        elif topic == MARKER_CALL_TIMEOUT:
            bridge.time_out_call(int(args["call"]))
        elif topic == MARKER_TRANSPORT_STATUS:
            bridge.transport_status(int(args["connection"]), str(args["level"]), str(args["msg"]))
        elif topic == MARKER_CLOSE:
            core.record_close()
        elif topic == MARKER_UNBUDGETED:
            open_connection(bridge, int(args["connection"]))
            bridge.exempt_from_budget(int(args["connection"]))
        else:
            _replay_python(core, args)
    except (ValueError, TypeError, KeyError) as exc:
        raise SessionError(f"marker {topic} {payload!r} is malformed: {exc}") from None


def _replay_python(core: MarkedCore, args: Mapping[str, Any]) -> None:
    call = args["call"]
    if call == "command":
        core.command(
            str(args["joint"]),
            position=args.get("position"),
            velocity=args.get("velocity"),
            effort=args.get("effort"),
        )
    elif call == "set_positions":
        core.set_positions({str(k): float(v) for k, v in args["positions"].items()})
    elif call == "reset":
        core.reset()
    elif call == "pause":
        core.set_paused(bool(args["paused"]))
    elif call == "set_parameter":
        core.set_parameter(str(args["controller"]), str(args["name"]), float(args["value"]))
    elif call == "set_sensor_noise":
        core.set_sensor_noise(str(args["sensor"]), float(args["stddev"]))
    elif call == "set_body_pose":
        orientation = args.get("orientation")
        core.set_body_pose(
            str(args["body"]),
            [float(v) for v in args["position"]],
            None if orientation is None else [float(v) for v in orientation],
        )
    else:
        raise ValueError(f"unknown call {call!r}")
