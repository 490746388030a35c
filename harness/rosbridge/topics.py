"""Topics on the bridge: the ``advertise``, ``unadvertise``, ``publish``, ``subscribe`` and
``unsubscribe`` ops, delivery of each message to every subscriber (per its throttle, queue
length, fragment size and compression) and to in-process callbacks, and the simulation's
in-process publishers and subscribers (a room of :class:`~harness.rosbridge.Bridge`, mixed
into it)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from harness.rosbridge.convert import dumps, from_json, publish_prefix, to_cbor, to_cdr
from harness.rosbridge.errors import FrameError
from harness.rosbridge.fragments import FragmentOps
from harness.rosbridge.frames import field_of, name_field
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
from harness.rosbridge.outgoing import (
    DIRECTION_OUT,
    OutgoingFrame,
    OutgoingOps,
    TapRecord,
    png_frame,
)

__all__ = ["TopicOps"]


class TopicOps(FragmentOps, OutgoingOps, Graph):
    """The topic ops and the in-process topic API (:meth:`advertise`, :meth:`unadvertise`,
    :meth:`publish`, :meth:`subscribe`); ``default_queue_length`` bounds a subscription's
    unsent frames when the client asks for ``queue_length`` 0."""

    default_queue_length: int

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
            self._outbox.append(OutgoingFrame(cid, frame, "publish", t.name, limit))
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
            frame = dumps({"op": "png", "data": png_frame(frame)})
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
