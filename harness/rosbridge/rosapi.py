"""rosapi: the graph-introspection services under ``/rosapi`` (types ``rosapi_msgs/srv/*``),
answered in-process from the bridge's own graph, type registry and parameters.

Clients are not ROS nodes: ``/rosbridge_websocket`` publishes what clients advertise,
subscribes to what they subscribe and provides their services and actions. ``/rosapi``
provides these services; ``/harness`` and every node an in-process registration names
(``/robot_state_publisher``, ``/joint_state_broadcaster``, controllers...) the rest.
``node_details`` lists an action server's node's hidden action endpoints as ROS 2 does
(services ``<action>/_action/send_goal``, ``cancel_goal``, ``get_result``; topics
``<action>/_action/feedback``, ``status``); the other answers list actions only in
``action_servers``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator, Mapping
from typing import Any, Protocol

from harness.rosbridge.errors import TypeNameError, UnknownTypeError
from harness.rosbridge.graph import ROSAPI_NODE
from harness.rosbridge.types import FLOAT_TYPES, TypeRegistry

__all__ = ["Host", "Request", "install", "typedefs"]


class Request(Protocol):
    """One call of a rosapi service (the bridge's ``ServiceCall``)."""

    @property
    def args(self) -> Mapping[str, Any]: ...


class Host(Protocol):
    """What rosapi reads and registers on (the bridge): its graph queries, type registry,
    parameters and time, and in-process service registration."""

    registry: TypeRegistry
    params: dict[str, str]
    distro: str

    @property
    def now_ns(self) -> int: ...

    def topics(self) -> Iterator[tuple[str, str]]: ...

    def topic_type(self, topic: str) -> str | None: ...

    def services(self) -> Iterator[tuple[str, str, int]]: ...

    def actions(self) -> Iterator[tuple[str, str, int]]: ...

    def publisher_nodes(self, topic: str) -> list[str]: ...

    def subscriber_nodes(self, topic: str) -> list[str]: ...

    def service_nodes(self) -> Iterator[tuple[str, str, str]]: ...

    def action_nodes(self) -> Iterator[tuple[str, str, str]]: ...

    def node_names(self) -> list[str]: ...

    def advertise_service(
        self,
        service: str,
        type: str,
        handler: Callable[[Request], Mapping[str, Any]],
        *,
        node: str = ...,
    ) -> None: ...


_ACTION_SERVICES = ("cancel_goal", "get_result", "send_goal")
_ACTION_TOPICS = ("feedback", "status")


def _example(type_: str, is_message: bool, count: int | None) -> str:
    if count is not None:
        return "[]"
    if is_message:
        return "{}"
    if type_ in FLOAT_TYPES:
        return "0.0"
    if type_ == "bool":
        return "False"
    if type_ in ("string", "wstring"):
        return ""
    return "0"


def typedefs(registry: TypeRegistry, name: str) -> list[dict[str, Any]]:
    """rosapi ``TypeDef``s of a message and every message it contains."""
    out = []
    for dep in registry.dependencies(name):
        d = registry.message(dep)
        out.append(
            {
                "type": dep,
                "fieldnames": [f.name for f in d.fields],
                "fieldtypes": [f.type for f in d.fields],
                "fieldarraylen": [
                    -1 if f.length is None else (f.length if f.fixed else 0) for f in d.fields
                ],
                "examples": [_example(f.type, f.is_message, f.length) for f in d.fields],
                "constnames": [c[0] for c in d.constants],
                "constvalues": [str(c[2]) for c in d.constants],
            }
        )
    return out


def install(bridge: Host) -> None:
    """Advertise every rosapi service on ``bridge`` (in-process)."""
    reg = bridge.registry

    def topics(call: Request) -> Mapping[str, Any]:
        pairs = list(bridge.topics())
        return {"topics": [p[0] for p in pairs], "types": [p[1] for p in pairs]}

    def topics_for_type(call: Request) -> Mapping[str, Any]:
        want = _resolve(reg.resolve_message, call.args["type"])
        return {"topics": [n for n, t in bridge.topics() if t == want]}

    def topics_and_raw_types(call: Request) -> Mapping[str, Any]:
        pairs = list(bridge.topics())
        return {
            "topics": [p[0] for p in pairs],
            "types": [p[1] for p in pairs],
            "typedefs_full_text": [reg.definition_text(p[1]) for p in pairs],
        }

    def topic_type(call: Request) -> Mapping[str, Any]:
        return {"type": bridge.topic_type(call.args["topic"]) or ""}

    def services(call: Request) -> Mapping[str, Any]:
        return {"services": [s[0] for s in bridge.services()]}

    def services_for_type(call: Request) -> Mapping[str, Any]:
        want = _resolve(reg.resolve_service, call.args["type"])
        return {"services": [s[0] for s in bridge.services() if s[1] == want]}

    def service_type(call: Request) -> Mapping[str, Any]:
        name = _abs(call.args["service"])
        return {"type": next((s[1] for s in bridge.services() if s[0] == name), "")}

    def service_providers(call: Request) -> Mapping[str, Any]:
        name = _abs(call.args["service"])
        return {"providers": [s[2] for s in bridge.service_nodes() if s[0] == name]}

    def service_node(call: Request) -> Mapping[str, Any]:
        name = _abs(call.args["service"])
        return {"node": next((s[2] for s in bridge.service_nodes() if s[0] == name), "")}

    def nodes(call: Request) -> Mapping[str, Any]:
        return {"nodes": bridge.node_names()}

    def node_details(call: Request) -> Mapping[str, Any]:
        node = call.args["node"]
        actions = [a[0] for a in bridge.action_nodes() if a[2] == node]
        topics = [n for n, _ in bridge.topics()]
        return {
            "subscribing": [n for n in topics if node in bridge.subscriber_nodes(n)],
            "publishing": sorted(
                [n for n in topics if node in bridge.publisher_nodes(n)]
                + [f"{a}/_action/{t}" for a in actions for t in _ACTION_TOPICS]
            ),
            "services": sorted(
                [s[0] for s in bridge.service_nodes() if s[2] == node]
                + [f"{a}/_action/{s}" for a in actions for s in _ACTION_SERVICES]
            ),
        }

    def action_servers(call: Request) -> Mapping[str, Any]:
        return {"action_servers": [a[0] for a in bridge.actions()]}

    def publishers(call: Request) -> Mapping[str, Any]:
        return {"publishers": bridge.publisher_nodes(call.args["topic"])}

    def subscribers(call: Request) -> Mapping[str, Any]:
        return {"subscribers": bridge.subscriber_nodes(call.args["topic"])}

    def message_details(call: Request) -> Mapping[str, Any]:
        return {"typedefs": typedefs(reg, _resolve(reg.resolve_message, call.args["type"]))}

    def request_details(call: Request) -> Mapping[str, Any]:
        srv = reg.service(_resolve(reg.resolve_service, call.args["type"]))
        return {"typedefs": typedefs(reg, srv.request)}

    def response_details(call: Request) -> Mapping[str, Any]:
        srv = reg.service(_resolve(reg.resolve_service, call.args["type"]))
        return {"typedefs": typedefs(reg, srv.response)}

    def get_param(call: Request) -> Mapping[str, Any]:
        return {"value": bridge.params.get(call.args["name"], call.args["default_value"])}

    def set_param(call: Request) -> Mapping[str, Any]:
        value = call.args["value"]
        try:
            json.loads(value)
        except ValueError:
            raise ValueError(f"parameter value is not JSON text: {value[:40]!r}") from None
        bridge.params[call.args["name"]] = value
        return {}

    def has_param(call: Request) -> Mapping[str, Any]:
        return {"exists": call.args["name"] in bridge.params}

    def delete_param(call: Request) -> Mapping[str, Any]:
        bridge.params.pop(call.args["name"], None)
        return {}

    def get_param_names(call: Request) -> Mapping[str, Any]:
        return {"names": sorted(bridge.params)}

    def get_time(call: Request) -> Mapping[str, Any]:
        now = bridge.now_ns
        return {"time": {"sec": now // 1_000_000_000, "nanosec": now % 1_000_000_000}}

    def get_ros_version(call: Request) -> Mapping[str, Any]:
        return {"version": 2, "distro": bridge.distro}

    table: dict[str, tuple[str, Callable[[Request], Mapping[str, Any]]]] = {
        "topics": ("Topics", topics),
        "topics_for_type": ("TopicsForType", topics_for_type),
        "topics_and_raw_types": ("TopicsAndRawTypes", topics_and_raw_types),
        "topic_type": ("TopicType", topic_type),
        "services": ("Services", services),
        "services_for_type": ("ServicesForType", services_for_type),
        "service_type": ("ServiceType", service_type),
        "service_providers": ("ServiceProviders", service_providers),
        "service_node": ("ServiceNode", service_node),
        "nodes": ("Nodes", nodes),
        "node_details": ("NodeDetails", node_details),
        "action_servers": ("ActionServers", action_servers),
        "publishers": ("Publishers", publishers),
        "subscribers": ("Subscribers", subscribers),
        "message_details": ("MessageDetails", message_details),
        "service_request_details": ("ServiceRequestDetails", request_details),
        "service_response_details": ("ServiceResponseDetails", response_details),
        "get_param": ("GetParam", get_param),
        "set_param": ("SetParam", set_param),
        "has_param": ("HasParam", has_param),
        "delete_param": ("DeleteParam", delete_param),
        "get_param_names": ("GetParamNames", get_param_names),
        "get_time": ("GetTime", get_time),
        "get_ros_version": ("GetROSVersion", get_ros_version),
    }
    for name, (srv, fn) in table.items():
        bridge.advertise_service(f"/rosapi/{name}", f"rosapi_msgs/srv/{srv}", fn, node=ROSAPI_NODE)


def _abs(name: str) -> str:
    return name if name.startswith("/") else "/" + name


def _resolve(resolve: Callable[[str], str], text: str) -> str:
    try:
        return resolve(text)
    except (TypeNameError, UnknownTypeError) as exc:
        raise ValueError(str(exc)) from None
