"""The shared ROS graph of a bridge: topics (type, publishers, subscribers, latched message),
services and actions, and the queries rosapi answers from. Pure records, no protocol: the
:class:`~harness.rosbridge.protocol.Bridge` builds on :class:`Graph`, and
:mod:`harness.rosbridge.rosapi` reads it.

Every registration names the ROS node it belongs to, as a real robot's graph shows it: what
clients advertise, subscribe and serve belongs to :data:`CLIENT_NODE`; an in-process
registration carries the node given to the bridge's ``advertise``/``publish``/``subscribe``/
``advertise_service``/``advertise_action`` (``node=``, default :data:`HARNESS_NODE`), e.g.
``/robot_state_publisher`` or ``/joint_trajectory_controller``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, Final, NamedTuple

from harness.rosbridge.errors import FrameError

__all__ = [
    "CLIENT_NODE",
    "COMPRESSION_RANK",
    "HARNESS_NODE",
    "ROSAPI_NODE",
    "ActionEntry",
    "Graph",
    "LocalSubscriber",
    "Message",
    "ServiceEntry",
    "SubParams",
    "Subscription",
    "TopicEntry",
    "normalize",
]

COMPRESSION_RANK: Final = {"none": 0, "png": 1, "cbor": 2, "cbor-raw": 3}
"""Subscription compressions by precedence (the highest asked for wins)."""
HARNESS_NODE: Final = "/harness"
"""The node of in-process registrations that name none."""
CLIENT_NODE: Final = "/rosbridge_websocket"
"""The node of everything clients advertise, subscribe and serve (clients are not nodes)."""
ROSAPI_NODE: Final = "/rosapi"
"""The node of the ``/rosapi`` services."""


class Message(NamedTuple):
    """A message published on the graph; ``connection`` 0 means in-process."""

    topic: str
    type: str
    msg: dict[str, Any]
    connection: int


def normalize(name: str) -> str:
    """A topic, service or action name made absolute, without a trailing slash."""
    name = name.rstrip("/") or "/"
    return name if name.startswith("/") else "/" + name


class LocalSubscriber(NamedTuple):
    """An in-process subscription: ``callback`` and the ``node`` it belongs to."""

    callback: Callable[[Message], None]
    node: str


@dataclass
class SubParams:
    """One subscription request's parameters (a client may subscribe several times)."""

    throttle_ns: int
    queue_length: int
    fragment_size: int | None
    compression: str


@dataclass
class Subscription:
    """A client's subscription to a topic: the effective parameters of its requests."""

    spelled: str
    params: dict[Any, SubParams] = field(default_factory=dict)
    throttle_ns: int = 0
    queue_length: int = 0
    fragment_size: int | None = None
    compression: str = "none"
    last_sent_ns: int | None = None

    def recompute(self) -> None:
        ps = list(self.params.values())
        self.throttle_ns = min(p.throttle_ns for p in ps)
        # 0 asks for no particular bound (the bridge default applies)
        lengths = [p.queue_length for p in ps if p.queue_length > 0]
        self.queue_length = min(lengths) if lengths else 0
        sizes = [p.fragment_size for p in ps if p.fragment_size is not None]
        self.fragment_size = min(sizes) if sizes else None
        self.compression = max((p.compression for p in ps), key=COMPRESSION_RANK.__getitem__)


@dataclass
class TopicEntry:
    """A topic: its type once established, publishers by connection (a client's advertisement
    ids; for connection 0 the publishing node names), client subscriptions, in-process
    subscribers and the latched message."""

    name: str
    type: str | None = None
    publishers: dict[int, set[Any]] = field(default_factory=dict)
    latching: set[int] = field(default_factory=set)
    subscribers: dict[int, Subscription] = field(default_factory=dict)
    local: list[LocalSubscriber] = field(default_factory=list)
    latched: dict[str, Any] | None = None


@dataclass
class ServiceEntry:
    """A service: provided by a connection, or in-process (provider 0) by ``handler``."""

    name: str
    spelled: str
    type: str
    provider: int
    handler: Callable[[Any], Any] | None
    count: int = 0
    node: str = CLIENT_NODE


@dataclass
class ActionEntry:
    """An action server: a connection's, or in-process (provider 0) by ``handler``."""

    name: str
    spelled: str
    type: str
    provider: int
    handler: Callable[[Any], None] | None
    count: int = 0
    node: str = CLIENT_NODE


class Graph:
    """The graph's records and the queries over them."""

    def __init__(self) -> None:
        self._topics: dict[str, TopicEntry] = {}
        self._services: dict[str, ServiceEntry] = {}
        self._actions: dict[str, ActionEntry] = {}

    def _topic(self, name: str) -> TopicEntry:
        key = normalize(name)
        t = self._topics.get(key)
        if t is None:
            t = self._topics[key] = TopicEntry(key)
        return t

    def _gc_topic(self, t: TopicEntry) -> None:
        if not t.publishers and not t.subscribers and not t.local:
            self._topics.pop(t.name, None)

    def _establish(self, t: TopicEntry, full: str) -> None:
        if t.type is not None and t.type != full:
            raise FrameError(
                f"Tried to register topic {t.name} with type {full} but it is already "
                f"established with type {t.type}"
            )
        t.type = full

    # -- queries (rosapi) ----------------------------------------------------------------

    def topics(self) -> Iterator[tuple[str, str]]:
        """``(topic, type)`` of every typed topic, sorted by name."""
        for name in sorted(self._topics):
            t = self._topics[name]
            if t.type is not None:
                yield name, t.type

    def topic_type(self, topic: str) -> str | None:
        """The type of ``topic``, None if unknown."""
        t = self._topics.get(normalize(topic))
        return t.type if t else None

    def services(self) -> Iterator[tuple[str, str, int]]:
        """``(service, type, provider connection)`` sorted by name (0 = in-process)."""
        for name in sorted(self._services):
            s = self._services[name]
            yield name, s.type, s.provider

    def actions(self) -> Iterator[tuple[str, str, int]]:
        """``(action, type, provider connection)`` sorted by name (0 = in-process)."""
        for name in sorted(self._actions):
            a = self._actions[name]
            yield name, a.type, a.provider

    def publishers_of(self, topic: str) -> list[int]:
        """Connections publishing ``topic`` (0 = in-process), sorted."""
        t = self._topics.get(normalize(topic))
        return sorted(t.publishers) if t else []

    def subscribers_of(self, topic: str) -> list[int]:
        """Connections subscribed to ``topic`` (0 = in-process subscribers), sorted."""
        t = self._topics.get(normalize(topic))
        if t is None:
            return []
        return sorted(set(t.subscribers) | ({0} if t.local else set()))

    def publisher_nodes(self, topic: str) -> list[str]:
        """The nodes publishing ``topic``, sorted."""
        t = self._topics.get(normalize(topic))
        if t is None:
            return []
        nodes = {CLIENT_NODE for c in t.publishers if c != 0}
        nodes.update(str(n) for n in t.publishers.get(0, ()))
        return sorted(nodes)

    def subscriber_nodes(self, topic: str) -> list[str]:
        """The nodes subscribed to ``topic``, sorted."""
        t = self._topics.get(normalize(topic))
        if t is None:
            return []
        nodes = {sub.node for sub in t.local}
        if t.subscribers:
            nodes.add(CLIENT_NODE)
        return sorted(nodes)

    def service_nodes(self) -> Iterator[tuple[str, str, str]]:
        """``(service, type, node)`` sorted by name."""
        for name in sorted(self._services):
            s = self._services[name]
            yield name, s.type, s.node

    def action_nodes(self) -> Iterator[tuple[str, str, str]]:
        """``(action, type, node)`` sorted by name."""
        for name in sorted(self._actions):
            a = self._actions[name]
            yield name, a.type, a.node

    def node_names(self) -> list[str]:
        """Every node of the graph, sorted: :data:`HARNESS_NODE`, :data:`CLIENT_NODE` and
        :data:`ROSAPI_NODE` always, and every node an in-process registration names."""
        nodes = {HARNESS_NODE, CLIENT_NODE, ROSAPI_NODE}
        for t in self._topics.values():
            nodes.update(str(n) for n in t.publishers.get(0, ()))
            nodes.update(sub.node for sub in t.local)
        nodes.update(s.node for s in self._services.values())
        nodes.update(a.node for a in self._actions.values())
        return sorted(nodes)
