"""The rosbridge v2 protocol as a sans-I/O state machine.

One :class:`Bridge` holds the shared graph (topics, services, actions, params) and the state
of every connection. ``receive(connection, text_or_bytes, now_ns)`` processes one incoming
frame and returns the :class:`Output` frames to send; there are no sockets and no clocks: the
caller passes the current simulation time. The simulation side uses the same graph
in-process (:meth:`Bridge.advertise`, :meth:`Bridge.publish`, :meth:`Bridge.subscribe`,
:meth:`Bridge.advertise_service`, :meth:`Bridge.advertise_action`), each registration under a
ROS node name (``node=``, default ``/harness``) that rosapi shows (see
:mod:`harness.rosbridge.graph`).

Outputs produced outside ``receive`` (a deferred service answer, an in-process publish)
collect in an outbox; :meth:`Bridge.drain` returns them and ``on_pending`` (if set) is called
when the outbox becomes non-empty. Every frame in and out passes the ``tap`` with a sequence
number. The same inputs in the same order produce the same frames, byte for byte.
"""

from __future__ import annotations

import base64
import contextlib
import json
import math
import re
import struct
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Final, NamedTuple

from harness.rosbridge.convert import dumps, from_json, publish_prefix, to_cbor, to_cdr
from harness.rosbridge.deadlines import MAX_TIMEOUT_S, bounded_timeout
from harness.rosbridge.errors import ConversionError, FrameError, TypeNameError, UnknownTypeError
from harness.rosbridge.graph import (
    COMPRESSION_RANK,
    HARNESS_NODE,
    ActionEntry,
    Graph,
    LocalSubscriber,
    Message,
    ServiceEntry,
    SubParams,
    Subscription,
    TopicEntry,
    normalize,
)
from harness.rosbridge.rosapi import install as install_rosapi
from harness.rosbridge.types import TypeRegistry

__all__ = [
    "DEFERRED",
    "DIRECTION_IN",
    "DIRECTION_OUT",
    "LEVELS",
    "ActionGoal",
    "Bridge",
    "FrameTap",
    "Message",
    "Output",
    "ServiceCall",
    "TapRecord",
]

DIRECTION_IN: Final = 0
DIRECTION_OUT: Final = 1
LEVELS: Final = {"info": 0, "warning": 1, "error": 2, "none": 3}
_NAME = re.compile(r"~?/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*/?\Z")
_BAD_INPUT = (FrameError, ConversionError, TypeNameError, UnknownTypeError)
_DECODER = json.JSONDecoder()
GOAL_SUCCEEDED: Final = 4
GOAL_CANCELED: Final = 5
GOAL_ABORTED: Final = 6


class _Deferred:
    def __repr__(self) -> str:
        return "DEFERRED"


DEFERRED: Final = _Deferred()
"""Returned by a service handler that will answer later through its :class:`ServiceCall`."""


class Output(NamedTuple):
    """One frame to send: ``queue_limit`` > 0 marks a subscription frame the server may drop
    (oldest first, per ``(connection, name)``) when the client reads too slowly."""

    connection: int
    data: str | bytes
    op: str
    name: str
    queue_limit: int = 0


class TapRecord(NamedTuple):
    """A frame seen by the tap: ``direction`` is :data:`DIRECTION_IN` or
    :data:`DIRECTION_OUT`; ``seq`` counts every frame of the bridge from 0."""

    seq: int
    connection: int
    direction: int
    data: str | bytes
    op: str
    name: str


FrameTap = Callable[[TapRecord], None]


def _png(text: str) -> str:
    """rosbridge's png compression: the UTF-8 bytes as an RGB image padded with newlines."""
    raw = text.encode("utf-8")
    width = max(1, math.floor(math.sqrt(len(raw) / 3.0)))
    height = max(1, math.ceil(len(raw) / 3.0 / width))
    raw += b"\n" * (width * height * 3 - len(raw))
    rows = b"".join(b"\x00" + raw[r * width * 3 : (r + 1) * width * 3] for r in range(height))

    def chunk(tag: bytes, body: bytes) -> bytes:
        crc = zlib.crc32(tag + body) & 0xFFFFFFFF
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", crc)

    png = (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(rows))
        + chunk(b"IEND", b"")
    )
    return base64.b64encode(png).decode("ascii")


def _kind(value: object) -> str:
    if isinstance(value, bool):
        return "a bool"
    return {
        int: "an int",
        float: "a float",
        str: "a string",
        list: "a list",
        dict: "an object",
    }.get(type(value), "null")


_EXPECT = {str: "a string", bool: "a bool", int: "an int", float: "a number", dict: "an object"}


def _field(obj: Mapping[str, Any], op: str, key: str, kind: type, default: Any = ...) -> Any:
    """A typed field of an op; missing or wrong-typed raises :class:`FrameError`."""
    if key not in obj:
        if default is ...:
            raise FrameError(f"{op}: Expected a {key} field but none was found.")
        return default
    value = obj[key]
    ok = isinstance(value, kind) and not (kind in (int, float) and isinstance(value, bool))
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        ok = True
    if not ok:
        raise FrameError(
            f"{op}: Expected field {key} to be {_EXPECT[kind]}, got {_kind(value)} "
            f"({json.dumps(value)[:40]})"
        )
    return value


def _name_field(obj: Mapping[str, Any], op: str, key: str) -> str:
    value: str = _field(obj, op, key, str)
    if not _NAME.match(value):
        raise FrameError(f"{op}: Invalid {key} name {value!r}")
    return value


@dataclass
class _Connection:
    id: int
    peer: str
    level: int = LEVELS["error"]
    fragment_size: int | None = None
    fragments: dict[Any, tuple[int, dict[int, str]]] = field(default_factory=dict)
    fragment_bytes: int = 0
    fragment_count: int = 0


class ServiceCall:
    """One call of an in-process service. The handler returns the response values, or
    :data:`DEFERRED` and later calls :meth:`respond` or :meth:`fail` exactly once."""

    def __init__(
        self,
        bridge: Bridge,
        key: int,
        service: str,
        type: str,
        args: dict[str, Any],
        connection: int,
    ) -> None:
        self._bridge = bridge
        self.key = key
        self.service = service
        self.type = type
        self.args = args
        self.connection = connection
        self.done = False

    def respond(self, values: Mapping[str, Any]) -> None:
        """Answer the call with ``values`` (validated against the response type)."""
        self._bridge._finish_call(self.key, True, values)

    def fail(self, message: str) -> None:
        """Answer the call with ``result: false`` and ``message``."""
        self._bridge._finish_call(self.key, False, message)


class ActionGoal:
    """One goal of an in-process action server: send :meth:`feedback`, then :meth:`finish`
    once. ``cancel_requested`` turns true on ``cancel_action_goal``; ``on_cancel`` (if set)
    is called then, else the goal finishes as canceled at once."""

    def __init__(
        self,
        bridge: Bridge,
        key: int,
        action: str,
        type: str,
        goal: dict[str, Any],
        connection: int,
    ) -> None:
        self._bridge = bridge
        self.key = key
        self.action = action
        self.type = type
        self.goal = goal
        self.connection = connection
        self.cancel_requested = False
        self.on_cancel: Callable[[ActionGoal], None] | None = None
        self.done = False

    def feedback(self, values: Mapping[str, Any]) -> None:
        """Send feedback (validated against the feedback type) to the goal's client."""
        self._bridge._goal_feedback(self.key, values)

    def finish(self, result: Mapping[str, Any], status: int = GOAL_SUCCEEDED) -> None:
        """Send the result: status 4 succeeded, 5 canceled, 6 aborted."""
        self._bridge._goal_result(self.key, result, status, True)


@dataclass
class _PendingCall:
    caller: int
    caller_id: Any
    spelled: str
    service: ServiceEntry
    provider_id: str | None
    callback: Callable[[bool, Any], None] | None = None
    call: ServiceCall | None = None


@dataclass
class _PendingGoal:
    caller: int
    caller_id: Any
    spelled: str
    action: ActionEntry
    feedback: bool
    provider_id: str | None
    goal: ActionGoal | None = None


class Bridge(Graph):
    """The shared rosbridge graph and every connection's protocol state (sans-I/O).

    ``tap`` sees every frame in and out; ``call_timeout_s`` is the default service-call
    timeout the owner enforces through ``on_call_started``/:meth:`time_out_call` (action goals
    too, ``goal_timeout_s`` by default; a client's ``timeout`` is bounded by
    :func:`harness.rosbridge.deadlines.bounded_timeout`; ``on_call_ended`` says when a call or
    goal is gone, answered or not);
    ``default_queue_length`` bounds a subscription's unsent frames when the client asks for
    ``queue_length`` 0.
    """

    def __init__(
        self,
        registry: TypeRegistry | None = None,
        *,
        tap: FrameTap | None = None,
        call_timeout_s: float = 30.0,
        default_queue_length: int = 1000,
        max_fragment_bytes: int = 16 * 2**20,
        max_fragmented_messages: int = 64,
        rosapi: bool = True,
        distro: str = "humble",
    ) -> None:
        super().__init__()
        self.registry = registry if registry is not None else TypeRegistry()
        self.tap = tap
        self.call_timeout_s = call_timeout_s
        self.default_queue_length = default_queue_length
        self.max_fragment_bytes = max_fragment_bytes
        self.max_fragmented_messages = max_fragmented_messages
        self.distro = distro
        self.params: dict[str, str] = {}
        self.on_pending: Callable[[], None] | None = None
        self.on_call_started: Callable[[int, float], None] | None = None
        self.on_call_ended: Callable[[int], None] | None = None
        self.goal_timeout_s = MAX_TIMEOUT_S
        self._seq = 0
        self._next_conn = 1
        self._next_key = 1
        self._conns: dict[int, _Connection] = {}
        self._calls: dict[int, _PendingCall] = {}
        self._call_by_provider: dict[tuple[int, str], int] = {}
        self._goals: dict[int, _PendingGoal] = {}
        self._goal_by_provider: dict[tuple[int, str], int] = {}
        self._goal_by_caller: dict[tuple[int, Any, str], int] = {}
        self._outbox: list[Output] = []
        self._now_ns = 0
        if rosapi:
            install_rosapi(self)

    # -- connections ---------------------------------------------------------------------

    def connect(self, peer: str = "") -> int:
        """Open a connection; returns its id (counting from 1 per bridge)."""
        cid = self._next_conn
        self._next_conn += 1
        self._conns[cid] = _Connection(cid, peer)
        return cid

    @property
    def connections(self) -> list[int]:
        """Ids of the open connections."""
        return list(self._conns)

    def disconnect(self, connection: int) -> list[Output]:
        """Close a connection: its publishers, subscriptions, services and actions go; calls
        routed to its services fail; returns the outputs this produced."""
        if self._conns.pop(connection, None) is None:
            return self.drain()
        for t in list(self._topics.values()):
            t.publishers.pop(connection, None)
            t.latching.discard(connection)
            t.subscribers.pop(connection, None)
            self._gc_topic(t)
        for s in [s for s in self._services.values() if s.provider == connection]:
            del self._services[s.name]
        for a in [a for a in self._actions.values() if a.provider == connection]:
            del self._actions[a.name]
        for key, call in list(self._calls.items()):
            if call.service.provider == connection:
                self._finish_call(key, False, f"Service {call.service.name} provider disconnected")
            elif call.caller == connection:
                self._drop_call(key)
        for key, goal in list(self._goals.items()):
            if goal.action.provider == connection:
                self._goal_result(key, f"Action {goal.action.name} server disconnected", 0, False)
            elif goal.caller == connection:
                self._drop_goal(key)
                self._cancel_orphaned_goal(goal)
        return self.drain()

    def _cancel_orphaned_goal(self, pending: _PendingGoal) -> None:
        """Tell the action server to stop working on a goal whose client left (the goal is
        already dropped: whatever the server sends for it goes nowhere)."""
        goal = pending.goal
        if goal is not None:
            goal.cancel_requested = True
            if goal.on_cancel is not None:
                with contextlib.suppress(Exception):  # the client is gone: nobody to tell
                    goal.on_cancel(goal)
        elif pending.provider_id is not None and pending.action.provider in self._conns:
            frame = {
                "op": "cancel_action_goal",
                "id": pending.provider_id,
                "action": pending.action.spelled,
            }
            self._send(
                pending.action.provider, dumps(frame), "cancel_action_goal", pending.action.name
            )

    # -- outputs ------------------------------------------------------------------------

    def drain(self) -> list[Output]:
        """Every output produced so far and not yet taken."""
        out, self._outbox = self._outbox, []
        return out

    def _tap(self, connection: int, direction: int, data: str | bytes, op: str, name: str) -> None:
        if self.tap is not None:
            self.tap(TapRecord(self._seq, connection, direction, data, op, name))
        self._seq += 1

    def _emit(
        self, connection: int, data: str | bytes, op: str, name: str, queue_limit: int = 0
    ) -> None:
        if connection not in self._conns:
            return
        self._tap(connection, DIRECTION_OUT, data, op, name)
        was_empty = not self._outbox
        self._outbox.append(Output(connection, data, op, name, queue_limit))
        if was_empty and self.on_pending is not None:
            self.on_pending()

    def _send(
        self,
        connection: int,
        text: str,
        op: str,
        name: str,
        frag_id: Any = None,
        fragment_size: int | None = None,
        queue_limit: int = 0,
    ) -> None:
        conn = self._conns.get(connection)
        if conn is None:
            return
        size = fragment_size if fragment_size is not None else conn.fragment_size
        if size is None or len(text) <= size:
            self._emit(connection, text, op, name, queue_limit)
            return
        if frag_id is None:
            conn.fragment_count += 1
            frag_id = f"fragment:{conn.fragment_count}"
        chunks = [text[i : i + size] for i in range(0, len(text), size)]
        for num, chunk in enumerate(chunks):
            frame = dumps(
                {"op": "fragment", "id": frag_id, "data": chunk, "num": num, "total": len(chunks)}
            )
            self._emit(connection, frame, "fragment", name, queue_limit)

    def status(self, connection: int, level: str, msg: str, id: Any = None) -> None:
        """Send a ``status`` frame if the connection's ``set_level`` lets ``level`` through."""
        conn = self._conns.get(connection)
        if conn is None or LEVELS[level] < conn.level:
            return
        frame: dict[str, Any] = {"op": "status", "level": level, "msg": msg}
        if id is not None:
            frame["id"] = id
        self._emit(connection, dumps(frame), "status", "")

    # -- incoming -----------------------------------------------------------------------

    def receive(self, connection: int, data: str | bytes, now_ns: int) -> list[Output]:
        """Process one incoming frame (several concatenated JSON objects are processed in
        order); returns every output produced, bad input answered with a ``status``."""
        if connection not in self._conns:
            raise FrameError(f"receive: connection {connection} is not open")
        self._now_ns = now_ns
        objects: list[Any] = []
        error: str | None = None
        if isinstance(data, (bytes, bytearray, memoryview)):
            try:
                text = bytes(data).decode("utf-8")
            except UnicodeDecodeError as exc:
                text, error = "", f"Binary frame is not UTF-8 JSON: {exc}"
        else:
            text = data
        if error is None:
            objects, error = self._split(text)
        first = objects[0] if objects else None
        op = first.get("op") if isinstance(first, dict) else None
        self._tap(
            connection,
            DIRECTION_IN,
            data if isinstance(data, str) else bytes(data),
            op if isinstance(op, str) else "",
            self._frame_name(first),
        )
        for obj in objects:
            self._process(connection, obj)
        if error is not None:
            self.status(connection, "error", error)
        return self.drain()

    @staticmethod
    def _frame_name(obj: object) -> str:
        if isinstance(obj, dict):
            for key in ("topic", "service", "action"):
                value = obj.get(key)
                if isinstance(value, str):
                    return value
        return ""

    @staticmethod
    def _split(text: str) -> tuple[list[Any], str | None]:
        objects: list[Any] = []
        pos, end = 0, len(text)
        while True:
            while pos < end and text[pos] in " \t\r\n":
                pos += 1
            if pos >= end:
                break
            try:
                obj, pos = _DECODER.raw_decode(text, pos)
            except json.JSONDecodeError as exc:
                return objects, f"Invalid JSON: {exc.msg} at char {exc.pos}"
            except RecursionError:
                return objects, "Invalid JSON: nested too deeply"
            objects.append(obj)
        if not objects:
            return objects, "Invalid JSON: empty frame"
        return objects, None

    def _process(self, connection: int, obj: Any) -> None:
        if not isinstance(obj, dict):
            self.status(connection, "error", f"Expected a JSON object, got {_kind(obj)}")
            return
        msg_id = obj.get("id")
        if msg_id is not None and (isinstance(msg_id, bool) or not isinstance(msg_id, (str, int))):
            self.status(
                connection,
                "error",
                f"Expected field id to be a string or an int, got {_kind(msg_id)}",
            )
            return
        op = obj.get("op")
        try:
            if not isinstance(op, str):
                if op is None:
                    raise FrameError("Expected an op field but none was found.")
                raise FrameError(f"Expected field op to be a string, got {_kind(op)}")
            handler = self._OPS.get(op)
            if handler is None:
                raise FrameError(f"Unknown operation: {op}")
            if "fragment_size" in obj and op != "subscribe":
                size = obj["fragment_size"]
                if isinstance(size, int) and not isinstance(size, bool) and size > 0:
                    self._conns[connection].fragment_size = size
            handler(self, connection, obj)
        except _BAD_INPUT as exc:
            self.status(connection, "error", str(exc), msg_id)
        except RecursionError:
            self.status(connection, "error", f"{op}: message nested too deeply", msg_id)

    # -- topics -------------------------------------------------------------------------

    def _op_advertise(self, c: int, obj: Mapping[str, Any]) -> None:
        topic = _name_field(obj, "advertise", "topic")
        full = self.registry.resolve_message(_field(obj, "advertise", "type", str))
        latch = _field(obj, "advertise", "latch", bool, False)
        _field(obj, "advertise", "queue_size", int, 100)
        t = self._topic(topic)
        try:
            self._establish(t, full)
        except FrameError:
            self._gc_topic(t)
            raise
        t.publishers.setdefault(c, set()).add(obj.get("id"))
        if latch:
            t.latching.add(c)

    def _op_unadvertise(self, c: int, obj: Mapping[str, Any]) -> None:
        topic = _name_field(obj, "unadvertise", "topic")
        t = self._topics.get(normalize(topic))
        ids = t.publishers.get(c) if t else None
        if t is None or ids is None:
            raise FrameError(f"unadvertise: topic {topic} is not advertised by this client")
        if "id" in obj:
            if obj["id"] not in ids:
                raise FrameError(
                    f"unadvertise: topic {topic} has no advertisement with id {obj['id']}"
                )
            ids.discard(obj["id"])
        else:
            ids.clear()
        if not ids:
            del t.publishers[c]
            t.latching.discard(c)
            self._gc_topic(t)

    def _op_publish(self, c: int, obj: Mapping[str, Any]) -> None:
        topic = _name_field(obj, "publish", "topic")
        msg = _field(obj, "publish", "msg", dict, {})
        latch = _field(obj, "publish", "latch", bool, False)
        t = self._topics.get(normalize(topic))
        if t is None or t.type is None:
            raise FrameError(
                f"publish: Cannot infer topic type for topic {topic} as it is not yet advertised"
            )
        canonical = from_json(self.registry, t.type, msg, self._now_ns)
        self._deliver(t, canonical, c, latch or c in t.latching)

    def _deliver(self, t: TopicEntry, msg: dict[str, Any], sender: int, latch: bool) -> None:
        assert t.type is not None
        if latch:
            t.latched = msg
        frames: dict[str, str] = {}
        for cid, sub in t.subscribers.items():
            self._send_to_subscriber(t, cid, sub, msg, frames)
        for local in list(t.local):
            local.callback(Message(t.name, t.type, msg, sender))

    def _send_to_subscriber(
        self,
        t: TopicEntry,
        cid: int,
        sub: Subscription,
        msg: dict[str, Any],
        frames: dict[str, str] | None = None,
    ) -> None:
        assert t.type is not None
        now = self._now_ns
        if (
            sub.throttle_ns
            and sub.last_sent_ns is not None
            and now - sub.last_sent_ns < sub.throttle_ns
        ):
            return
        sub.last_sent_ns = now
        limit = sub.queue_length or self.default_queue_length
        if sub.compression == "cbor":
            data = to_cbor(self.registry, t.type, sub.spelled, msg)
            self._emit(cid, data, "publish", t.name, limit)
            return
        if sub.compression == "cbor-raw":
            import cbor2

            raw = {
                "secs": now // 1_000_000_000,
                "nsecs": now % 1_000_000_000,
                "bytes": to_cdr(self.registry, t.type, msg),
            }
            frame_b = bytes(cbor2.dumps({"op": "publish", "topic": sub.spelled, "msg": raw}))
            self._emit(cid, frame_b, "publish", t.name, limit)
            return
        frame = frames.get(sub.spelled) if frames is not None else None
        if frame is None:
            frame = publish_prefix(sub.spelled) + dumps(msg) + "}"
            if frames is not None:
                frames[sub.spelled] = frame
        if sub.compression == "png":
            frame = dumps({"op": "png", "data": _png(frame)})
        self._send(cid, frame, "publish", t.name, None, sub.fragment_size, limit)

    def _op_subscribe(self, c: int, obj: Mapping[str, Any]) -> None:
        topic = _name_field(obj, "subscribe", "topic")
        type_str = _field(obj, "subscribe", "type", str, None)
        throttle = _field(obj, "subscribe", "throttle_rate", int, 0)
        queue_length = _field(obj, "subscribe", "queue_length", int, 0)
        fragment_size = _field(obj, "subscribe", "fragment_size", int, None)
        compression = _field(obj, "subscribe", "compression", str, "none")
        for key, value in (("throttle_rate", throttle), ("queue_length", queue_length)):
            if value < 0:
                raise FrameError(f"subscribe: field {key} must be >= 0, got {value}")
        if fragment_size is not None and fragment_size <= 0:
            raise FrameError(f"subscribe: field fragment_size must be > 0, got {fragment_size}")
        full = self.registry.resolve_message(type_str) if type_str is not None else None
        t = self._topic(topic)
        if full is not None:
            try:
                self._establish(t, full)
            except FrameError:
                self._gc_topic(t)
                raise
        elif t.type is None:
            self.status(
                c,
                "warning",
                f"subscribe: topic {topic} has no type yet; messages flow once it is advertised",
                obj.get("id"),
            )
        if compression not in COMPRESSION_RANK:
            compression = "none"
        sub = t.subscribers.get(c)
        new = sub is None
        if sub is None:
            sub = t.subscribers[c] = Subscription(topic)
        sub.params[obj.get("id")] = SubParams(
            throttle * 1_000_000, queue_length, fragment_size, compression
        )
        sub.recompute()
        if new and t.latched is not None and t.type is not None:
            self._send_to_subscriber(t, c, sub, t.latched)

    def _op_unsubscribe(self, c: int, obj: Mapping[str, Any]) -> None:
        topic = _name_field(obj, "unsubscribe", "topic")
        t = self._topics.get(normalize(topic))
        sub = t.subscribers.get(c) if t else None
        if t is None or sub is None:
            raise FrameError(f"unsubscribe: this client is not subscribed to {topic}")
        if "id" in obj:
            if obj["id"] not in sub.params:
                raise FrameError(f"unsubscribe: no subscription to {topic} with id {obj['id']}")
            del sub.params[obj["id"]]
        else:
            sub.params.clear()
        if sub.params:
            sub.recompute()
        else:
            del t.subscribers[c]
            self._gc_topic(t)

    # -- services -----------------------------------------------------------------------

    def _service_failure(self, c: int, spelled: str, values: Any, msg_id: Any) -> None:
        frame: dict[str, Any] = {
            "op": "service_response",
            "service": spelled,
            "values": values,
            "result": False,
        }
        if msg_id is not None:
            frame["id"] = msg_id
        self._send(c, dumps(frame), "service_response", spelled, msg_id)

    def _op_call_service(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = _name_field(obj, "call_service", "service")
        msg_id = obj.get("id")
        args = obj.get("args", {})
        timeout = bounded_timeout(
            _field(obj, "call_service", "timeout", float, None), self.call_timeout_s, "call_service"
        )
        svc = self._services.get(normalize(spelled))
        if svc is None:
            self._service_failure(c, spelled, f"Service {spelled} does not exist", msg_id)
            return
        request_type = self.registry.service(svc.type).request
        try:
            if args is None:
                args = {}
            if isinstance(args, list):
                names = [f.name for f in self.registry.message(request_type).fields]
                if len(args) > len(names):
                    raise ConversionError(
                        f"{request_type} has {len(names)} fields, "
                        f"but {len(args)} positional args were given"
                    )
                args = dict(zip(names, args, strict=False))
            request = from_json(self.registry, request_type, args, self._now_ns)
        except ConversionError as exc:
            self._service_failure(c, spelled, str(exc), msg_id)
            return
        self._start_call(svc, c, msg_id, spelled, request, timeout)

    def _start_call(
        self,
        svc: ServiceEntry,
        caller: int,
        caller_id: Any,
        spelled: str,
        request: dict[str, Any],
        timeout: float | None,
        callback: Callable[[bool, Any], None] | None = None,
    ) -> None:
        key = self._next_key
        self._next_key += 1
        pending = _PendingCall(caller, caller_id, spelled, svc, None, callback)
        self._calls[key] = pending
        if svc.handler is not None:
            call = ServiceCall(self, key, svc.name, svc.type, request, caller)
            pending.call = call
            try:
                result = svc.handler(call)
            except Exception as exc:  # a failing handler answers, it does not kill the bridge
                self._finish_call(
                    key, False, f"Service {svc.name} handler raised {type(exc).__name__}: {exc}"
                )
                return
            if result is DEFERRED:
                if not call.done and self.on_call_started is not None:
                    self.on_call_started(key, self.call_timeout_s if timeout is None else timeout)
                return
            if not call.done:
                if isinstance(result, Mapping):
                    call.respond(result)
                else:
                    call.fail(
                        f"Service {svc.name} handler returned {type(result).__name__}, "
                        "not a dict or DEFERRED"
                    )
            return
        svc.count += 1
        rid = f"service_request:{svc.spelled}:{svc.count}"
        pending.provider_id = rid
        self._call_by_provider[(svc.provider, rid)] = key
        frame = {"op": "call_service", "id": rid, "service": svc.spelled, "args": request}
        self._send(svc.provider, dumps(frame), "call_service", svc.name, rid)
        if self.on_call_started is not None:
            self.on_call_started(key, self.call_timeout_s if timeout is None else timeout)

    def _drop_call(self, key: int) -> _PendingCall | None:
        pending = self._calls.pop(key, None)
        if pending is not None and self.on_call_ended is not None:
            self.on_call_ended(key)
        if pending is not None and pending.provider_id is not None:
            self._call_by_provider.pop((pending.service.provider, pending.provider_id), None)
        if pending is not None and pending.call is not None:
            pending.call.done = True
        return pending

    def _finish_call(self, key: int, ok: bool, values: Any) -> None:
        pending = self._calls.get(key)
        if pending is None:
            return
        if ok:
            response_type = self.registry.service(pending.service.type).response
            try:
                values = from_json(self.registry, response_type, values, self._now_ns)
            except ConversionError as exc:
                ok, values = False, str(exc)
                if pending.service.handler is None:
                    self.status(
                        pending.service.provider,
                        "error",
                        f"service_response: {exc}",
                        pending.provider_id,
                    )
        self._drop_call(key)
        if pending.callback is not None:
            pending.callback(ok, values)
            return
        if not ok:
            self._service_failure(
                pending.caller,
                pending.spelled,
                values if isinstance(values, (str, dict)) else str(values),
                pending.caller_id,
            )
            return
        frame: dict[str, Any] = {
            "op": "service_response",
            "service": pending.spelled,
            "values": values,
            "result": True,
        }
        if pending.caller_id is not None:
            frame["id"] = pending.caller_id
        self._send(
            pending.caller,
            dumps(frame),
            "service_response",
            pending.service.name,
            pending.caller_id,
        )

    def time_out_call(self, key: int) -> list[Output]:
        """Fail a pending service call or action goal that ran past its timeout (no-op if
        answered); a timed-out goal is also canceled at its action server."""
        pending = self._calls.get(key)
        if pending is not None:
            self._finish_call(key, False, f"Service {pending.spelled} timed out")
        goal = self._goals.get(key)
        if goal is not None:
            self._goal_result(key, f"Action {goal.spelled} timed out", 0, False)
            self._cancel_orphaned_goal(goal)
        return self.drain()

    def _op_service_response(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = _name_field(obj, "service_response", "service")
        rid = _field(obj, "service_response", "id", str)
        result = _field(obj, "service_response", "result", bool, True)
        key = self._call_by_provider.get((c, rid))
        if key is None:
            raise FrameError(f"service_response: unknown service request id {rid} for {spelled}")
        values = obj.get("values", {})
        if result:
            if values is None:
                values = {}
            self._finish_call(key, True, values)
        else:
            self._finish_call(
                key, False, values if isinstance(values, (str, dict)) else dumps(values)
            )

    def _op_advertise_service(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = _name_field(obj, "advertise_service", "service")
        full = self.registry.resolve_service(_field(obj, "advertise_service", "type", str))
        name = normalize(spelled)
        existing = self._services.get(name)
        if existing is not None and existing.provider == 0:
            raise FrameError(f"advertise_service: service {name} is provided by the harness")
        if existing is not None and existing.provider != c:
            self.status(
                c,
                "warning",
                f"advertise_service: service {name} taken over from another client",
                obj.get("id"),
            )
        self._services[name] = ServiceEntry(name, spelled, full, c, None)

    def _op_unadvertise_service(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = _name_field(obj, "unadvertise_service", "service")
        svc = self._services.get(normalize(spelled))
        if svc is None or svc.provider != c:
            raise FrameError(
                f"unadvertise_service: service {spelled} is not advertised by this client"
            )
        del self._services[svc.name]

    # -- actions ------------------------------------------------------------------------

    def _action_failure(self, c: int, spelled: str, text: str, msg_id: Any) -> None:
        frame: dict[str, Any] = {
            "op": "action_result",
            "action": spelled,
            "values": text,
            "status": 0,
            "result": False,
        }
        if msg_id is not None:
            frame["id"] = msg_id
        self._send(c, dumps(frame), "action_result", spelled, msg_id)

    def _op_send_action_goal(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = _name_field(obj, "send_action_goal", "action")
        msg_id = obj.get("id")
        feedback = _field(obj, "send_action_goal", "feedback", bool, False)
        timeout = bounded_timeout(
            _field(obj, "send_action_goal", "timeout", float, None),
            self.goal_timeout_s,
            "send_action_goal",
        )
        act = self._actions.get(normalize(spelled))
        if act is None:
            self._action_failure(c, spelled, f"Action {spelled} does not exist", msg_id)
            return
        try:
            if "action_type" in obj:
                given = self.registry.resolve_action(obj["action_type"])
                if given != act.type:
                    raise ConversionError(f"Action {act.name} has type {act.type}, not {given}")
            goal_type = self.registry.action(act.type).goal
            args = obj.get("args", {})
            goal = from_json(self.registry, goal_type, {} if args is None else args, self._now_ns)
        except _BAD_INPUT as exc:
            self._action_failure(c, spelled, str(exc), msg_id)
            return
        key = self._next_key
        self._next_key += 1
        pending = _PendingGoal(c, msg_id, spelled, act, feedback, None)
        self._goals[key] = pending
        self._goal_by_caller[(c, msg_id, act.name)] = key
        if act.handler is not None:
            handle = ActionGoal(self, key, act.name, act.type, goal, c)
            pending.goal = handle
            try:
                act.handler(handle)
            except Exception as exc:
                self._goal_result(
                    key, f"Action {act.name} handler raised {type(exc).__name__}: {exc}", 0, False
                )
            if key in self._goals and self.on_call_started is not None:
                self.on_call_started(key, timeout)
            return
        act.count += 1
        gid = f"action_goal:{act.spelled}:{act.count}"
        pending.provider_id = gid
        self._goal_by_provider[(act.provider, gid)] = key
        frame = {
            "op": "send_action_goal",
            "id": gid,
            "action": act.spelled,
            "action_type": act.type,
            "args": goal,
            "feedback": True,
        }
        self._send(act.provider, dumps(frame), "send_action_goal", act.name, gid)
        if self.on_call_started is not None:
            self.on_call_started(key, timeout)

    def _drop_goal(self, key: int) -> _PendingGoal | None:
        pending = self._goals.pop(key, None)
        if pending is not None:
            if self.on_call_ended is not None:
                self.on_call_ended(key)
            self._goal_by_caller.pop((pending.caller, pending.caller_id, pending.action.name), None)
            if pending.provider_id is not None:
                self._goal_by_provider.pop((pending.action.provider, pending.provider_id), None)
            if pending.goal is not None:
                pending.goal.done = True
        return pending

    def _goal_feedback(self, key: int, values: Mapping[str, Any]) -> None:
        pending = self._goals.get(key)
        if pending is None or not pending.feedback:
            return
        fb = from_json(
            self.registry, self.registry.action(pending.action.type).feedback, values, self._now_ns
        )
        frame: dict[str, Any] = {"op": "action_feedback", "action": pending.spelled, "values": fb}
        if pending.caller_id is not None:
            frame["id"] = pending.caller_id
        self._send(
            pending.caller, dumps(frame), "action_feedback", pending.action.name, pending.caller_id
        )

    def _goal_result(self, key: int, values: Any, status: int, ok: bool) -> None:
        pending = self._goals.get(key)
        if pending is None:
            return
        if ok:
            values = from_json(
                self.registry,
                self.registry.action(pending.action.type).result,
                values,
                self._now_ns,
            )
        self._drop_goal(key)
        if not ok:
            self._action_failure(pending.caller, pending.spelled, str(values), pending.caller_id)
            return
        frame: dict[str, Any] = {
            "op": "action_result",
            "action": pending.spelled,
            "values": values,
            "status": status,
            "result": True,
        }
        if pending.caller_id is not None:
            frame["id"] = pending.caller_id
        self._send(
            pending.caller, dumps(frame), "action_result", pending.action.name, pending.caller_id
        )

    def _op_cancel_action_goal(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = _name_field(obj, "cancel_action_goal", "action")
        key = self._goal_by_caller.get((c, obj.get("id"), normalize(spelled)))
        if key is None:
            raise FrameError(
                f"cancel_action_goal: no active goal with id {obj.get('id')} on {spelled}"
            )
        pending = self._goals[key]
        if pending.goal is not None:
            pending.goal.cancel_requested = True
            if pending.goal.on_cancel is not None:
                pending.goal.on_cancel(pending.goal)
            else:
                pending.goal.finish({}, GOAL_CANCELED)
            return
        frame = {
            "op": "cancel_action_goal",
            "id": pending.provider_id,
            "action": pending.action.spelled,
        }
        self._send(pending.action.provider, dumps(frame), "cancel_action_goal", pending.action.name)

    def _provider_goal(self, c: int, obj: Mapping[str, Any], op: str) -> int:
        spelled = _name_field(obj, op, "action")
        gid = _field(obj, op, "id", str)
        key = self._goal_by_provider.get((c, gid))
        if key is None:
            raise FrameError(f"{op}: unknown goal id {gid} for {spelled}")
        return key

    def _op_action_feedback(self, c: int, obj: Mapping[str, Any]) -> None:
        key = self._provider_goal(c, obj, "action_feedback")
        self._goal_feedback(key, _field(obj, "action_feedback", "values", dict))

    def _op_action_result(self, c: int, obj: Mapping[str, Any]) -> None:
        key = self._provider_goal(c, obj, "action_result")
        status = _field(obj, "action_result", "status", int, GOAL_SUCCEEDED)
        result = _field(obj, "action_result", "result", bool, True)
        values = obj.get("values", {})
        if result:
            if not isinstance(values, dict):
                raise FrameError(
                    f"action_result: Expected field values to be an object, got {_kind(values)}"
                )
            try:
                self._goal_result(key, values, status, True)
            except ConversionError as exc:
                self._goal_result(key, str(exc), 0, False)
                raise
        else:
            self._goal_result(
                key, values if isinstance(values, str) else dumps(values), status, False
            )

    def _op_advertise_action(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = _name_field(obj, "advertise_action", "action")
        full = self.registry.resolve_action(_field(obj, "advertise_action", "type", str))
        name = normalize(spelled)
        existing = self._actions.get(name)
        if existing is not None and existing.provider == 0:
            raise FrameError(f"advertise_action: action {name} is provided by the harness")
        self._actions[name] = ActionEntry(name, spelled, full, c, None)

    def _op_unadvertise_action(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = _name_field(obj, "unadvertise_action", "action")
        act = self._actions.get(normalize(spelled))
        if act is None or act.provider != c:
            raise FrameError(
                f"unadvertise_action: action {spelled} is not advertised by this client"
            )
        del self._actions[act.name]

    # -- fragments, status, set_level ---------------------------------------------------

    def _op_fragment(self, c: int, obj: Mapping[str, Any]) -> None:
        conn = self._conns[c]
        fid = obj.get("id")
        if fid is None:
            raise FrameError("fragment: Expected a id field but none was found.")
        data = _field(obj, "fragment", "data", str)
        num = _field(obj, "fragment", "num", int)
        total = _field(obj, "fragment", "total", int)
        if total < 1 or not 0 <= num < total:
            self._forget_fragments(conn, fid)
            raise FrameError(
                f"fragment: num {num} is outside 0..total-1 (total {total}) for id {fid}"
            )
        entry = conn.fragments.get(fid)
        if entry is None:
            if len(conn.fragments) >= self.max_fragmented_messages:
                raise FrameError(
                    f"fragment: more than {self.max_fragmented_messages} "
                    "incomplete fragmented messages"
                )
            entry = conn.fragments[fid] = (total, {})
        if entry[0] != total:
            self._forget_fragments(conn, fid)
            raise FrameError(
                f"fragment: total {total} differs from {entry[0]} for id {fid}; message dropped"
            )
        if conn.fragment_bytes + len(data) > self.max_fragment_bytes:
            self._forget_fragments(conn, fid)
            raise FrameError(
                f"fragment: fragmented messages exceed {self.max_fragment_bytes} bytes; "
                f"id {fid} dropped"
            )
        old = entry[1].get(num)
        conn.fragment_bytes += len(data) - (len(old) if old is not None else 0)
        entry[1][num] = data
        if len(entry[1]) < total:
            return
        self._forget_fragments(conn, fid)
        text = "".join(entry[1][i] for i in range(total))
        objects, error = self._split(text)
        for inner in objects:
            self._process(c, inner)
        if error is not None:
            raise FrameError(f"fragment: reassembled message {fid} is not valid: {error}")

    @staticmethod
    def _forget_fragments(conn: _Connection, fid: Any) -> None:
        entry = conn.fragments.pop(fid, None)
        if entry is not None:
            conn.fragment_bytes -= sum(len(d) for d in entry[1].values())

    def _op_status(self, c: int, obj: Mapping[str, Any]) -> None:
        _field(obj, "status", "level", str, "info")
        _field(obj, "status", "msg", str, "")

    def _op_set_level(self, c: int, obj: Mapping[str, Any]) -> None:
        level = _field(obj, "set_level", "level", str)
        if level not in LEVELS:
            raise FrameError(
                f"set_level: level must be one of info, warning, error, none; got {level!r}"
            )
        self._conns[c].level = LEVELS[level]

    _OPS: ClassVar[dict[str, Callable[[Bridge, int, Mapping[str, Any]], None]]] = {
        "advertise": _op_advertise,
        "unadvertise": _op_unadvertise,
        "publish": _op_publish,
        "subscribe": _op_subscribe,
        "unsubscribe": _op_unsubscribe,
        "call_service": _op_call_service,
        "service_response": _op_service_response,
        "advertise_service": _op_advertise_service,
        "unadvertise_service": _op_unadvertise_service,
        "send_action_goal": _op_send_action_goal,
        "cancel_action_goal": _op_cancel_action_goal,
        "action_feedback": _op_action_feedback,
        "action_result": _op_action_result,
        "advertise_action": _op_advertise_action,
        "unadvertise_action": _op_unadvertise_action,
        "fragment": _op_fragment,
        "status": _op_status,
        "set_level": _op_set_level,
    }

    # -- simulation side ----------------------------------------------------------------

    def advertise(
        self, topic: str, type: str, *, latch: bool = False, node: str = HARNESS_NODE
    ) -> None:
        """Declare an in-process publisher of ``topic`` belonging to ``node`` (establishes
        its type: from then on a client that advertises or subscribes to ``topic`` with
        another type gets a status error). ``latch`` keeps the last message for late
        subscribers."""
        t = self._topic(topic)
        self._establish(t, self.registry.resolve_message(type))
        t.publishers.setdefault(0, set()).add(node)
        if latch:
            t.latching.add(0)

    def unadvertise(self, topic: str, *, node: str = HARNESS_NODE) -> None:
        """Remove ``node``'s in-process publisher of ``topic``."""
        t = self._topics.get(normalize(topic))
        nodes = t.publishers.get(0) if t is not None else None
        if t is None or nodes is None:
            return
        nodes.discard(node)
        if not nodes:
            del t.publishers[0]
            t.latching.discard(0)
            self._gc_topic(t)

    def publish(
        self,
        topic: str,
        type: str,
        msg: Mapping[str, Any],
        now_ns: int,
        *,
        latch: bool = False,
        node: str | None = None,
    ) -> None:
        """Publish from the simulation: validated against ``type``, delivered to every
        subscriber; outputs go to the outbox. ``latch`` keeps it for late subscribers.
        ``node`` joins the topic's publishers; without one, a topic nobody in-process has
        advertised gets :data:`HARNESS_NODE`."""
        self._now_ns = now_ns
        t = self._topic(topic)
        self._establish(t, self.registry.resolve_message(type))
        nodes = t.publishers.setdefault(0, set())
        if node is not None:
            nodes.add(node)
        elif not nodes:
            nodes.add(HARNESS_NODE)
        if latch:
            t.latching.add(0)
        assert t.type is not None
        canonical = from_json(self.registry, t.type, msg, now_ns)
        self._deliver(t, canonical, 0, latch or 0 in t.latching)

    def subscribe(
        self,
        topic: str,
        callback: Callable[[Message], None],
        type: str | None = None,
        *,
        node: str = HARNESS_NODE,
    ) -> Callable[[], None]:
        """Call ``callback`` with every message published on ``topic`` by anyone, as a
        subscriber belonging to ``node``; returns a function that removes the subscription."""
        t = self._topic(topic)
        if type is not None:
            self._establish(t, self.registry.resolve_message(type))
        sub = LocalSubscriber(callback, node)
        t.local.append(sub)

        def remove() -> None:
            if sub in t.local:
                t.local.remove(sub)
                self._gc_topic(t)

        return remove

    def advertise_service(
        self,
        service: str,
        type: str,
        handler: Callable[[ServiceCall], Any],
        *,
        node: str = HARNESS_NODE,
    ) -> None:
        """Provide ``service`` in-process as ``node``: ``handler(call)`` returns the response
        values or :data:`DEFERRED` (then answers later with ``call.respond``/``call.fail``)."""
        name = normalize(service)
        self._services[name] = ServiceEntry(
            name, name, self.registry.resolve_service(type), 0, handler, node=node
        )

    def unadvertise_service(self, service: str) -> None:
        """Remove an in-process service."""
        svc = self._services.get(normalize(service))
        if svc is not None and svc.provider == 0:
            del self._services[svc.name]

    def call_service(
        self,
        service: str,
        args: Mapping[str, Any],
        callback: Callable[[bool, Any], None],
        now_ns: int,
        timeout: float | None = None,
    ) -> None:
        """Call any service in-process; ``callback(ok, values_or_error_text)`` runs when it
        answers (maybe immediately)."""
        self._now_ns = now_ns
        svc = self._services.get(normalize(service))
        if svc is None:
            callback(False, f"Service {service} does not exist")
            return
        request = from_json(self.registry, self.registry.service(svc.type).request, args, now_ns)
        self._start_call(svc, 0, None, service, request, timeout, callback)

    def advertise_action(
        self,
        action: str,
        type: str,
        handler: Callable[[ActionGoal], None],
        *,
        node: str = HARNESS_NODE,
    ) -> None:
        """Provide ``action`` in-process as ``node``: ``handler(goal)`` starts the goal and
        later calls ``goal.feedback``/``goal.finish``."""
        name = normalize(action)
        self._actions[name] = ActionEntry(
            name, name, self.registry.resolve_action(type), 0, handler, node=node
        )

    def unadvertise_action(self, action: str) -> None:
        """Remove an in-process action server."""
        act = self._actions.get(normalize(action))
        if act is not None and act.provider == 0:
            del self._actions[act.name]

    def set_now(self, now_ns: int) -> None:
        """Set the sim time used by in-process answers (deferred responses, feedback)."""
        self._now_ns = now_ns

    @property
    def now_ns(self) -> int:
        """The sim time of the last input."""
        return self._now_ns
