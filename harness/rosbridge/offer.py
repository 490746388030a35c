"""What a bridge's in-process side offers on its graph: the topics it publishes (type,
latched, nodes), the topics it subscribes to, its services and action servers. A relay (client
mode of an external rosbridge server, the ROS 2 gateway) mirrors exactly this, so whatever the
session registers (robot topics, ``/harness/*`` services, controllers) appears on the other side
without a hand-written list.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

from harness.rosbridge.graph import ROSAPI_NODE, Graph

__all__ = ["Offer", "OfferedEndpoint", "offer_of"]


@dataclass(frozen=True)
class OfferedEndpoint:
    """One topic, service or action: absolute ``name``, full ``type`` (``pkg/msg/Name``,
    ``pkg/srv/Name``, ``pkg/action/Name``), the ``nodes`` it belongs to and, for a published
    topic, whether it is ``latched`` (transient local)."""

    name: str
    type: str
    nodes: tuple[str, ...] = ()
    latched: bool = False


@dataclass(frozen=True)
class Offer:
    """Everything the in-process side of a graph offers, each kind sorted by name."""

    published: tuple[OfferedEndpoint, ...]
    subscribed: tuple[OfferedEndpoint, ...]
    services: tuple[OfferedEndpoint, ...]
    actions: tuple[OfferedEndpoint, ...]

    def to_json(self) -> str:
        """The offer as one JSON object (the ROS 2 gateway reads it)."""

        def rows(items: tuple[OfferedEndpoint, ...]) -> list[dict[str, Any]]:
            return [
                {"name": e.name, "type": e.type, "nodes": list(e.nodes), "latched": e.latched}
                for e in items
            ]

        return json.dumps(
            {
                "published": rows(self.published),
                "subscribed": rows(self.subscribed),
                "services": rows(self.services),
                "actions": rows(self.actions),
            },
            sort_keys=True,
        )


def offer_of(graph: Graph) -> Offer:
    """The in-process registrations of ``graph`` (connection 0) as an :class:`Offer`."""
    published: list[OfferedEndpoint] = []
    subscribed: list[OfferedEndpoint] = []
    for name, type_ in graph.topics():
        # the graph's records, read here rather than grown into one more public query
        entry = graph._topics[name]
        if 0 in entry.publishers:
            published.append(
                OfferedEndpoint(
                    name,
                    type_,
                    tuple(sorted(str(n) for n in entry.publishers[0])),
                    0 in entry.latching,
                )
            )
        if entry.local:
            subscribed.append(
                OfferedEndpoint(name, type_, tuple(sorted({s.node for s in entry.local})))
            )
    services = [
        OfferedEndpoint(name, type_, (node,))
        for (name, type_, node), (_, _, provider) in zip(
            graph.service_nodes(), graph.services(), strict=True
        )
        if provider == 0 and node != ROSAPI_NODE  # the bridge's own rosapi stays home
    ]
    actions = [
        OfferedEndpoint(name, type_, (node,))
        for (name, type_, node), (_, _, provider) in zip(
            graph.action_nodes(), graph.actions(), strict=True
        )
        if provider == 0
    ]
    return Offer(tuple(published), tuple(subscribed), tuple(services), tuple(actions))
