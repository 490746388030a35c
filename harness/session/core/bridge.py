"""The session's side of the rosbridge graph: :class:`SessionBridge` (the rosbridge protocol
core of a session, at simulation time, reporting the inputs that are not client frames as
markers: :mod:`harness.session.core.markers`), the :class:`Graph` the core publishes on (an
in-process bridge, :class:`BridgePort`, or a client of an external server) and
:class:`RosoutSink` (log events on ``/rosout``)."""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from typing import Any, ClassVar, Protocol

from harness.events import JointSample, LogMessage, SinkReport
from harness.events.events import Event
from harness.rosbridge import DIRECTION_IN, ActionGoal, Bridge, Message, OutgoingFrame, TapRecord
from harness.rosbridge.limits import SendBudget
from harness.session.core.markers import (
    MARKER_CALL_TIMEOUT,
    MARKER_DISCONNECT,
    MARKER_TRANSPORT_STATUS,
    MARKER_UNBUDGETED,
)
from harness.session.core.topics import HARNESS_NODE, TYPE_LOG, log_msg

__all__ = [
    "BridgePort",
    "Graph",
    "MessageCallback",
    "Publisher",
    "RosoutSink",
    "ServiceHandler",
    "SessionBridge",
]

ROSOUT = "/rosout"
DEFAULT_BUDGET = SendBudget()

MessageCallback = Callable[[Mapping[str, Any], int], None]
ServiceHandler = Callable[[Mapping[str, Any]], Mapping[str, Any]]


class Graph(Protocol):
    """The core's view of the ROS graph it publishes on (an in-process bridge or a client of
    an external server): synchronous, called only between steps."""

    def has_subscribers(self, topic: str) -> bool: ...

    def advertise(self, topic: str, type: str, *, node: str, latch: bool = False) -> None:
        """Put ``topic`` on the graph with its type before anything is published, as a
        publisher belonging to ``node`` (``latch``: transient local)."""
        ...

    def publish(
        self, topic: str, type: str, msg: Mapping[str, Any], now_ns: int, *, latch: bool = False
    ) -> None: ...

    def subscribe(
        self, topic: str, type: str, callback: MessageCallback, *, node: str = HARNESS_NODE
    ) -> None:
        """Call ``callback`` with each message on ``topic``, as a subscriber of ``node``."""
        ...

    def serve(
        self, service: str, type: str, handler: ServiceHandler, *, node: str = HARNESS_NODE
    ) -> None:
        """Answer ``service`` with ``handler``, as a service of ``node``."""
        ...

    def status(self, connection: int, level: str, text: str) -> None:
        """Tell one client something (a ``status`` frame), where the transport can."""
        ...


class SessionBridge(Bridge):
    """The session's rosbridge protocol core: every frame is processed at the simulation's
    current time (``clock``), and inputs that are not client frames (a socket closing, a
    wall-clock call timeout, a status the transport sends by itself: :meth:`transport_status`)
    are kept as markers (:mod:`harness.session.core.markers`) among its :meth:`frames`, before
    what they cause, so that a recording can hold them (``keep_frames``).

    ``peer_status(connection, level, msg)`` gets every ``status`` frame a connection sends
    (an external rosbridge server's answers in client mode, the ROS 2 gateway's warnings)
    while it is processed: the core turns them into events, live and in a replay alike (what
    such an event publishes must come out where the status came in, so it is not drained
    later as the frames are).

    Each client has a send budget (:class:`~harness.rosbridge.limits.SendBudget`, default
    :data:`~harness.rosbridge.limits.SEND_FRAMES_PER_S` frames or
    :data:`~harness.rosbridge.limits.SEND_BYTES_PER_S` bytes per second of simulation time):
    a client over it has its subscription messages dropped rather than the simulation
    slowed down by the work of sending them (the harness's own links are exempt:
    :meth:`exempt_from_budget`)."""

    def __init__(
        self,
        clock: Callable[[], int],
        *,
        keep_frames: bool = False,
        peer_status: Callable[[int, str, str], None] | None = None,
        send_budget: SendBudget | None = DEFAULT_BUDGET,
    ) -> None:
        super().__init__(keep_frames=keep_frames, send_budget=send_budget)
        self._clock = clock
        self._peer_status = peer_status

    @property
    def _now_ns(self) -> int:
        """The session bridge's time is always the simulation's (deferred answers, feedback
        and in-process publishes are stamped with it)."""
        return self._clock()

    @_now_ns.setter
    def _now_ns(self, value: int) -> None:
        pass  # the time given with an input is the simulation's already

    def mark(self, topic: str, args: Mapping[str, Any]) -> None:
        """Keep a marker (``topic``, JSON ``args``) among the frames: at the next frame's
        ``seq``, which it does not consume."""
        if self._frames is not None:
            text = json.dumps(args, sort_keys=True)
            self._frames.append(TapRecord(self.seq, 0, DIRECTION_IN, text, "", topic, self._now_ns))

    def receive(self, connection: int, data: str | bytes, now_ns: int) -> list[OutgoingFrame]:
        """Process one frame at the simulation's time (``now_ns`` is ignored: a step request
        earlier in the same batch may have moved time)."""
        return super().receive(connection, data, self._clock())

    def disconnect(self, connection: int) -> list[OutgoingFrame]:
        if connection in self.connections:
            self.mark(MARKER_DISCONNECT, {"connection": connection})
        return super().disconnect(connection)

    def time_out_call(self, key: int) -> list[OutgoingFrame]:
        self.mark(MARKER_CALL_TIMEOUT, {"call": key})
        return super().time_out_call(key)

    def exempt_from_budget(self, connection: int) -> None:
        """The harness's own link, without a send budget; recorded as a marker first."""
        if connection in self.connections:
            self.mark(MARKER_UNBUDGETED, {"connection": connection})
        super().exempt_from_budget(connection)

    def transport_status(self, connection: int, level: str, msg: str) -> None:
        """A status the transport sends by itself, recorded as a marker first."""
        self.mark(MARKER_TRANSPORT_STATUS, {"connection": connection, "level": level, "msg": msg})
        super().transport_status(connection, level, msg)

    def _op_peer_status(self, c: int, obj: Mapping[str, Any]) -> None:
        Bridge._OPS["status"](self, c, obj)  # validates level and msg
        if self._peer_status is not None:
            self._peer_status(c, str(obj.get("level", "info")), str(obj.get("msg", "")))

    _OPS: ClassVar[dict[str, Callable[[Bridge, int, Mapping[str, Any]], None]]] = {
        **Bridge._OPS,
        "status": _op_peer_status,  # type: ignore[dict-item]
    }


class BridgePort:
    """The in-process graph of a :class:`SessionBridge` (the embedded server's side).

    A subscriber callback that raises (a bug: refused commands are reported, not raised)
    does not escape into the transport: ``fail(exc)`` stops the run (the core's
    :meth:`~harness.session.core.SessionCore.fail`), live and in a replay alike."""

    def __init__(
        self, bridge: SessionBridge, fail: Callable[[BaseException], None] | None = None
    ) -> None:
        self.bridge = bridge
        self._fail = fail

    def has_subscribers(self, topic: str) -> bool:
        return bool(self.bridge.subscribers_of(topic))

    def advertise(self, topic: str, type: str, *, node: str, latch: bool = False) -> None:
        self.bridge.advertise(topic, type, latch=latch, node=node)

    def publish(
        self, topic: str, type: str, msg: Mapping[str, Any], now_ns: int, *, latch: bool = False
    ) -> None:
        self.bridge.publish(topic, type, msg, now_ns, latch=latch)

    def subscribe(
        self, topic: str, type: str, callback: MessageCallback, *, node: str = HARNESS_NODE
    ) -> None:
        fail = self._fail

        def deliver(message: Message) -> None:
            try:
                callback(message.msg, message.connection)
            except Exception as exc:
                if fail is None:
                    raise
                fail(exc)

        self.bridge.subscribe(topic, deliver, type, node=node)

    def serve(
        self, service: str, type: str, handler: ServiceHandler, *, node: str = HARNESS_NODE
    ) -> None:
        self.bridge.advertise_service(service, type, lambda call: handler(call.args), node=node)

    def serve_action(
        self,
        action: str,
        type: str,
        handler: Callable[[ActionGoal], None],
        *,
        node: str = HARNESS_NODE,
    ) -> None:
        """Serve an action in-process as ``node`` (the controllers' actions)."""
        self.bridge.advertise_action(action, type, handler, node=node)

    def status(self, connection: int, level: str, text: str) -> None:
        self.bridge.status(connection, level, text)


class Publisher(Protocol):
    """What :class:`RosoutSink` publishes through (the session core)."""

    def publish(
        self,
        topic: str,
        type: str,
        build: Callable[[], Mapping[str, Any]],
        *,
        latch: bool = False,
        record: bool = True,
    ) -> None: ...


class RosoutSink:
    """Publishes every event except joint samples on ``/rosout`` over the graph (not
    recorded as a message: the frames sent are)."""

    name = "bridge-rosout"

    def __init__(self, publisher: Publisher) -> None:
        self._publisher = publisher
        self._delivered = 0

    def emit(self, event: Event) -> None:
        if isinstance(event, JointSample):
            return
        name = event.name if isinstance(event, LogMessage) else f"harness.{event.kind}"
        self._publisher.publish(
            ROSOUT,
            TYPE_LOG,
            lambda: log_msg(event.sim_time_ns, int(event.level), name, event.message()),
            record=False,
        )
        self._delivered += 1

    def close(self) -> SinkReport:
        return SinkReport(self.name, self._delivered, 0)
