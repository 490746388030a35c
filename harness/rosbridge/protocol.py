"""The rosbridge v2 protocol as a sans-I/O state machine.

One :class:`Bridge` holds the shared graph (topics, services, actions, params) and the state
of every connection. ``receive(connection, text_or_bytes, now_ns)`` processes one incoming
frame and returns the :class:`OutgoingFrame` frames to send; there are no sockets and no clocks: the
caller passes the current simulation time. The simulation side uses the same graph
in-process (:meth:`Bridge.advertise`, :meth:`Bridge.publish`, :meth:`Bridge.subscribe`,
:meth:`Bridge.advertise_service`, :meth:`Bridge.advertise_action`), each registration under a
ROS node name (``node=``, default ``/harness``) that rosapi shows (see
:mod:`harness.rosbridge.graph`). This module parses incoming frames and dispatches their ops;
its rooms: topics (:mod:`harness.rosbridge.topics`), services
(:mod:`harness.rosbridge.services`), actions (:mod:`harness.rosbridge.actions`), fragmented
messages (:mod:`harness.rosbridge.fragments`), outgoing frames
(:mod:`harness.rosbridge.outgoing`), frame fields and connection state
(:mod:`harness.rosbridge.frames`); rosapi (:mod:`harness.rosbridge.rosapi`) reads the graph
through a protocol of its own and imports none of them.

Outputs produced outside ``receive`` (a deferred service answer, an in-process publish)
collect in an outbox: its owner takes them with :meth:`Bridge.drain` after its own calls
(as a sans-I/O protocol's ``data_to_send``), the deadlines of calls and goals with
:meth:`Bridge.deadlines` and every frame in and out, numbered, with :meth:`Bridge.frames`
(``keep_frames``). The same inputs in the same order produce the same frames, byte for byte.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

from harness.rosbridge.actions import ActionOps, _PendingGoal
from harness.rosbridge.deadlines import MAX_TIMEOUT_S
from harness.rosbridge.errors import FrameError
from harness.rosbridge.fragments import FragmentOps
from harness.rosbridge.frames import BAD_INPUT, LEVELS, Connection, Deadline, field_of, kind_of
from harness.rosbridge.limits import (
    MAX_FRAGMENT_BYTES,
    MAX_PENDING_CALLS,
    MAX_PENDING_CALLS_PER_CLIENT,
    MAX_PENDING_GOALS,
    MAX_PENDING_GOALS_PER_CLIENT,
    MIN_FRAGMENT_SIZE,
    SendBudget,
)
from harness.rosbridge.outgoing import DIRECTION_IN, OutgoingFrame, TapRecord
from harness.rosbridge.rosapi import install as install_rosapi
from harness.rosbridge.services import ServiceOps, _PendingCall
from harness.rosbridge.topics import TopicOps
from harness.rosbridge.types import TypeRegistry

__all__ = ["Bridge"]

_DECODER = json.JSONDecoder()


class Bridge(ServiceOps, ActionOps, TopicOps):
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
        self._outbox: list[OutgoingFrame] = []
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

    def disconnect(self, connection: int) -> list[OutgoingFrame]:
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

    # -- incoming -----------------------------------------------------------------------

    def receive(self, connection: int, data: str | bytes, now_ns: int) -> list[OutgoingFrame]:
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

    def time_out_call(self, key: int) -> list[OutgoingFrame]:
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
        "advertise": TopicOps._op_advertise,
        "unadvertise": TopicOps._op_unadvertise,
        "publish": TopicOps._op_publish,
        "subscribe": TopicOps._op_subscribe,
        "unsubscribe": TopicOps._op_unsubscribe,
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

    @property
    def now_ns(self) -> int:
        """The sim time of the last input."""
        return self._now_ns
