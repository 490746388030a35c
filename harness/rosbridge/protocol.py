"""The rosbridge v2 protocol as a sans-I/O state machine.

One :class:`Bridge` holds the shared graph (topics, services, actions, params) and the state
of every connection. ``receive(connection, text_or_bytes, now_ns)`` processes one incoming
frame and returns the :class:`Output` frames to send; there are no sockets and no clocks: the
caller passes the current simulation time. The simulation side uses the same graph
in-process (:meth:`Bridge.advertise`, :meth:`Bridge.publish`, :meth:`Bridge.subscribe`,
:meth:`Bridge.advertise_service`, :meth:`Bridge.advertise_action`), each registration under a
ROS node name (``node=``, default ``/harness``) that rosapi shows (see
:mod:`harness.rosbridge.graph`). Its rooms: services (:mod:`harness.rosbridge.services`),
actions (:mod:`harness.rosbridge.actions`), fragmented messages
(:mod:`harness.rosbridge.fragments`), frame fields and connection state
(:mod:`harness.rosbridge.frames`); rosapi (:mod:`harness.rosbridge.rosapi`) reads the graph
through a protocol of its own and imports none of them.

Outputs produced outside ``receive`` (a deferred service answer, an in-process publish)
collect in an outbox: its owner takes them with :meth:`Bridge.drain` after its own calls
(as a sans-I/O protocol's ``data_to_send``), the deadlines of calls and goals with
:meth:`Bridge.deadlines` and every frame in and out, numbered, with :meth:`Bridge.frames`
(``keep_frames``). The same inputs in the same order produce the same frames, byte for byte.
"""

from __future__ import annotations

import base64
import json
import math
import struct
import zlib
from collections.abc import Callable, Mapping
from typing import Any, ClassVar, Final, NamedTuple

from harness.rosbridge.actions import ActionGoal, ActionOps, _PendingGoal
from harness.rosbridge.budget import BudgetOps
from harness.rosbridge.convert import dumps, from_json, publish_prefix, to_cbor, to_cdr
from harness.rosbridge.deadlines import MAX_TIMEOUT_S
from harness.rosbridge.errors import FrameError
from harness.rosbridge.fragments import FragmentOps
from harness.rosbridge.frames import (
    BAD_INPUT,
    LEVELS,
    Connection,
    Deadline,
    field_of,
    kind_of,
    name_field,
)
from harness.rosbridge.graph import (
    COMPRESSION_RANK,
    HARNESS_NODE,
    Graph,
    LocalSubscriber,
    Message,
    SubParams,
    Subscription,
    TopicEntry,
    normalize,
)
from harness.rosbridge.limits import (
    MAX_FRAGMENT_BYTES,
    MAX_PENDING_CALLS,
    MAX_PENDING_CALLS_PER_CLIENT,
    MAX_PENDING_GOALS,
    MAX_PENDING_GOALS_PER_CLIENT,
    MIN_FRAGMENT_SIZE,
    SendBudget,
)
from harness.rosbridge.rosapi import install as install_rosapi
from harness.rosbridge.services import DEFERRED, ServiceCall, ServiceOps, _PendingCall
from harness.rosbridge.types import TypeRegistry

__all__ = [
    "DEFERRED",
    "DIRECTION_IN",
    "DIRECTION_OUT",
    "LEVELS",
    "ActionGoal",
    "Bridge",
    "Message",
    "Output",
    "ServiceCall",
    "TapRecord",
]

DIRECTION_IN: Final = 0
DIRECTION_OUT: Final = 1
_DECODER = json.JSONDecoder()


class Output(NamedTuple):
    """One frame to send: ``queue_limit`` > 0 marks a subscription frame the server may drop
    (oldest first, per ``(connection, name)``) when the client reads too slowly."""

    connection: int
    data: str | bytes
    op: str
    name: str
    queue_limit: int = 0


class TapRecord(NamedTuple):
    """A frame that crossed the bridge (:meth:`Bridge.frames`): ``direction`` is
    :data:`DIRECTION_IN` or :data:`DIRECTION_OUT`; ``seq`` counts every frame of the bridge
    from 0; ``now_ns``: the bridge's time when it crossed."""

    seq: int
    connection: int
    direction: int
    data: str | bytes
    op: str
    name: str
    now_ns: int = 0


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


class Bridge(ServiceOps, ActionOps, FragmentOps, BudgetOps, Graph):
    """The shared rosbridge graph and every connection's protocol state (sans-I/O).

    ``keep_frames``: keep every frame in and out for :meth:`frames`; ``call_timeout_s`` is
    the default service-call timeout the owner enforces: :meth:`deadlines` reports each call
    it starts and ends, and the owner calls :meth:`time_out_call` when one runs out (action
    goals too,
    ``goal_timeout_s`` by default; a client's ``timeout`` is bounded by
    :func:`harness.rosbridge.deadlines.bounded_timeout`);
    ``default_queue_length`` bounds a subscription's unsent frames when the client asks for
    ``queue_length`` 0. Bounds on each client (:mod:`harness.rosbridge.limits`): a
    ``fragment_size`` below ``min_fragment_size`` is raised to it (with a ``warning``), pending
    service calls and action goals are capped per client and in total (one more is refused
    with a failed answer naming the limit), and with a ``send_budget`` every frame sent to a
    client for its subscriptions is charged to it: a client over its budget has its
    subscription messages dropped (counted, :meth:`throttled`, and reported in a ``warning``)
    until its budget refills.
    """

    def __init__(
        self,
        registry: TypeRegistry | None = None,
        *,
        keep_frames: bool = False,
        call_timeout_s: float = 30.0,
        default_queue_length: int = 1000,
        max_fragment_bytes: int = MAX_FRAGMENT_BYTES,
        max_fragmented_messages: int = 64,
        min_fragment_size: int = MIN_FRAGMENT_SIZE,
        max_pending_calls_per_client: int = MAX_PENDING_CALLS_PER_CLIENT,
        max_pending_calls: int = MAX_PENDING_CALLS,
        max_pending_goals_per_client: int = MAX_PENDING_GOALS_PER_CLIENT,
        max_pending_goals: int = MAX_PENDING_GOALS,
        send_budget: SendBudget | None = None,
        rosapi: bool = True,
        distro: str = "humble",
    ) -> None:
        super().__init__()
        self.registry = registry if registry is not None else TypeRegistry()
        self._frames: list[TapRecord] | None = [] if keep_frames else None
        self.call_timeout_s = call_timeout_s
        self.default_queue_length = default_queue_length
        self.max_fragment_bytes = max_fragment_bytes
        self.max_fragmented_messages = max_fragmented_messages
        self.min_fragment_size = min_fragment_size
        self.max_pending_calls_per_client = max_pending_calls_per_client
        self.max_pending_calls = max_pending_calls
        self.max_pending_goals_per_client = max_pending_goals_per_client
        self.max_pending_goals = max_pending_goals
        self.send_budget = send_budget
        self.distro = distro
        self.params: dict[str, str] = {}
        self._deadline_log: list[Deadline] | None = None
        self.goal_timeout_s = MAX_TIMEOUT_S
        self._seq = 0
        self._next_conn = 1
        self._next_key = 1
        self._conns: dict[int, Connection] = {}
        self._calls: dict[int, _PendingCall] = {}
        self._calls_of: dict[int, int] = {}
        self._call_by_provider: dict[tuple[int, str], int] = {}
        self._goals: dict[int, _PendingGoal] = {}
        self._goals_of: dict[int, int] = {}
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
        self._conns[cid] = Connection(cid, peer, budget=self.send_budget)
        return cid

    @property
    def connections(self) -> list[int]:
        """Ids of the open connections."""
        return list(self._conns)

    @property
    def open_count(self) -> int:
        """How many connections are open now."""
        return len(self._conns)

    @property
    def opened(self) -> int:
        """How many connections were ever opened (ids are given in order from 1)."""
        return self._next_conn - 1

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

    # -- outputs ------------------------------------------------------------------------

    def drain(self) -> list[Output]:
        """Every output produced so far and not yet taken."""
        out, self._outbox = self._outbox, []
        return out

    def frames(self) -> list[TapRecord]:
        """Every frame in and out since the last call, in order (drained; kept only with
        ``keep_frames``): what a recording of the bridge holds."""
        out, self._frames = self._frames, None if self._frames is None else []
        return [] if out is None else out

    @property
    def seq(self) -> int:
        """The sequence number the next frame gets."""
        return self._seq

    def _tap(self, connection: int, direction: int, data: str | bytes, op: str, name: str) -> None:
        if self._frames is not None:
            self._frames.append(
                TapRecord(self._seq, connection, direction, data, op, name, self._now_ns)
            )
        self._seq += 1

    def _emit(
        self, connection: int, data: str | bytes, op: str, name: str, queue_limit: int = 0
    ) -> None:
        conn = self._conns.get(connection)
        if conn is None:
            return
        if queue_limit and conn.budget is not None:  # a subscription's frame (see Output)
            self._charge(conn, conn.budget, len(data), self._now_ns)
        if self._frames is None:
            self._seq += 1  # what _tap does when no frames are kept
        else:
            self._tap(connection, DIRECTION_OUT, data, op, name)
        self._outbox.append(Output(connection, data, op, name, queue_limit))

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

    def transport_status(self, connection: int, level: str, msg: str) -> None:
        """A ``status`` the transport sends by itself (not an answer to a frame: frames
        dropped for a slow reader, a client-mode link lost), subject to ``set_level``."""
        self.status(connection, level, msg)

    # -- incoming -----------------------------------------------------------------------

    def receive(self, connection: int, data: str | bytes, now_ns: int) -> list[Output]:
        """Process one incoming frame (several concatenated JSON objects are processed in
        order); returns every output produced, bad input answered with a ``status``."""
        if connection not in self._conns:
            raise FrameError(f"receive: connection {connection} is not open")
        self._now_ns = now_ns
        if type(data) is str:
            # The common frame, one JSON object, at once (what the general path below does
            # for it); anything else (whitespace around it, several objects, bad JSON, not
            # an object) takes the general path from the start.
            try:
                obj, end = _DECODER.raw_decode(data)
            except (json.JSONDecodeError, RecursionError):
                end = -1
            if end == len(data) and type(obj) is dict:
                if self._frames is not None:  # _tap's record, inline: (almost) every frame
                    op = obj.get("op")
                    name = obj.get("topic")
                    self._frames.append(
                        TapRecord(
                            self._seq,
                            connection,
                            DIRECTION_IN,
                            data,
                            op if type(op) is str else "",
                            name if type(name) is str else self._frame_name(obj),
                            now_ns,  # what _now_ns returns now (a session bridge's: its clock)
                        )
                    )
                self._seq += 1
                self._process(connection, obj)
                return self.drain()
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
            self.status(connection, "error", f"Expected a JSON object, got {kind_of(obj)}")
            return
        msg_id = obj.get("id")
        if msg_id is not None and (isinstance(msg_id, bool) or not isinstance(msg_id, (str, int))):
            self.status(
                connection,
                "error",
                f"Expected field id to be a string or an int, got {kind_of(msg_id)}",
            )
            return
        op = obj.get("op")
        try:
            if not isinstance(op, str):
                if op is None:
                    raise FrameError("Expected an op field but none was found.")
                raise FrameError(f"Expected field op to be a string, got {kind_of(op)}")
            handler = self._OPS.get(op)
            if handler is None:
                raise FrameError(f"Unknown operation: {op}")
            if "fragment_size" in obj and op != "subscribe":
                size = obj["fragment_size"]
                if isinstance(size, int) and not isinstance(size, bool) and size > 0:
                    size = self._fragment_floor(connection, op, size, msg_id)
                    self._conns[connection].fragment_size = size
            handler(self, connection, obj)
        except BAD_INPUT as exc:
            self.status(connection, "error", str(exc), msg_id)
        except RecursionError:
            self.status(connection, "error", f"{op}: message nested too deeply", msg_id)

    # -- topics -------------------------------------------------------------------------

    def _op_advertise(self, c: int, obj: Mapping[str, Any]) -> None:
        topic = name_field(obj, "advertise", "topic")
        full = self.registry.resolve_message(field_of(obj, "advertise", "type", str))
        latch = field_of(obj, "advertise", "latch", bool, False)
        field_of(obj, "advertise", "queue_size", int, 100)
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
        topic = name_field(obj, "unadvertise", "topic")
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
        topic = name_field(obj, "publish", "topic")
        msg = obj.get("msg", {})
        if type(msg) is not dict:
            msg = field_of(obj, "publish", "msg", dict)
        latch = obj.get("latch", False)
        if latch is not False and latch is not True:
            latch = field_of(obj, "publish", "latch", bool)
        # keys are normalized names: a name found as given needs no normalizing
        t = self._topics.get(topic) or self._topics.get(normalize(topic))
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
        if t.subscribers:
            frames: dict[str, str] = {}
            for cid, sub in t.subscribers.items():
                self._send_to_subscriber(t, cid, sub, msg, frames)
        if t.local:
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
        conn = self._conns.get(cid)
        if conn is None:
            return
        budget = conn.budget
        if budget is not None and self._over_budget(conn, now):
            self._throttle(conn, t.name)  # dropped before any work is done for it
            return
        sub.last_sent_ns = now
        limit = sub.queue_length or self.default_queue_length
        compression = sub.compression
        if compression == "none":
            # The common frame (a JSON publish, unfragmented) as _send and _emit would send
            # it, without their calls: every message relayed to every subscriber is here.
            frame = frames.get(sub.spelled) if frames is not None else None
            if frame is None:
                frame = publish_prefix(sub.spelled) + dumps(msg) + "}"
                if frames is not None:
                    frames[sub.spelled] = frame
            size = sub.fragment_size if sub.fragment_size is not None else conn.fragment_size
            if size is not None and len(frame) > size:
                self._send(cid, frame, "publish", t.name, None, size, limit)
                return
            if budget is not None:
                self._charge(conn, budget, len(frame), now)
            if self._frames is not None:
                self._frames.append(
                    TapRecord(self._seq, cid, DIRECTION_OUT, frame, "publish", t.name, now)
                )
            self._seq += 1
            self._outbox.append(Output(cid, frame, "publish", t.name, limit))
            return
        if compression == "cbor":
            data = to_cbor(self.registry, t.type, sub.spelled, msg)
            self._emit(cid, data, "publish", t.name, limit)
            return
        if compression == "cbor-raw":
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
        if compression == "png":
            frame = dumps({"op": "png", "data": _png(frame)})
        self._send(cid, frame, "publish", t.name, None, sub.fragment_size, limit)

    def _op_subscribe(self, c: int, obj: Mapping[str, Any]) -> None:
        topic = name_field(obj, "subscribe", "topic")
        type_str = field_of(obj, "subscribe", "type", str, None)
        throttle = field_of(obj, "subscribe", "throttle_rate", int, 0)
        queue_length = field_of(obj, "subscribe", "queue_length", int, 0)
        fragment_size = field_of(obj, "subscribe", "fragment_size", int, None)
        compression = field_of(obj, "subscribe", "compression", str, "none")
        for key, value in (("throttle_rate", throttle), ("queue_length", queue_length)):
            if value < 0:
                raise FrameError(f"subscribe: field {key} must be >= 0, got {value}")
        if fragment_size is not None:
            if fragment_size <= 0:
                raise FrameError(f"subscribe: field fragment_size must be > 0, got {fragment_size}")
            fragment_size = self._fragment_floor(c, "subscribe", fragment_size, obj.get("id"))
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
        topic = name_field(obj, "unsubscribe", "topic")
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

    # -- status, set_level --------------------------------------------------------------

    def _op_status(self, c: int, obj: Mapping[str, Any]) -> None:
        field_of(obj, "status", "level", str, "info")
        field_of(obj, "status", "msg", str, "")

    def _op_set_level(self, c: int, obj: Mapping[str, Any]) -> None:
        level = field_of(obj, "set_level", "level", str)
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
        "call_service": ServiceOps._op_call_service,
        "service_response": ServiceOps._op_service_response,
        "advertise_service": ServiceOps._op_advertise_service,
        "unadvertise_service": ServiceOps._op_unadvertise_service,
        "send_action_goal": ActionOps._op_send_action_goal,
        "cancel_action_goal": ActionOps._op_cancel_action_goal,
        "action_feedback": ActionOps._op_action_feedback,
        "action_result": ActionOps._op_action_result,
        "advertise_action": ActionOps._op_advertise_action,
        "unadvertise_action": ActionOps._op_unadvertise_action,
        "fragment": FragmentOps._op_fragment,
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

    @property
    def now_ns(self) -> int:
        """The sim time of the last input."""
        return self._now_ns
