"""The ROS 2 gateway program: runs in the ROS 2 interpreter (rclpy), never imported by the
harness. Usage: ``python node.py URL`` with the session's offer (:mod:`harness.rosbridge.offer`)
as JSON on stdin.

It is a rosbridge v2 client of the session's embedded server, so every message that crosses
DDS is a bridge frame the session records and replays: for every topic the session publishes
it subscribes over rosbridge and publishes on DDS (latched topics transient local); for every
topic the session subscribes to it advertises over rosbridge and subscribes on DDS; every
service becomes a ROS 2 service whose calls go over rosbridge; every action becomes a ROS 2
action server whose goals and cancels go over rosbridge (``send_action_goal``,
``cancel_action_goal``) and whose feedback and results come back from it (a goal the session
ends canceled without a cancel from DDS, a preempted one, ends aborted on DDS: rclpy allows
canceled only after a cancel request). The DDS entities belong to nodes named as the
session's graph names them. Warnings (a publisher on DDS with another type or with QoS that
cannot match, a type the ROS side lacks) go to the session as ``status`` frames, which it
logs as events. Prints ``ready {JSON}`` on stdout once everything exists.

Only the standard library, rclpy (with the message packages) and websockets.
"""

from __future__ import annotations

import base64
import functools
import importlib
import itertools
import json
import sys
import threading
from typing import Any

import rclpy
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from rosidl_parser.definition import (
    AbstractGenericString,
    AbstractNestedType,
    BasicType,
    NamespacedType,
)
from websockets.sync.client import connect

_BYTES = ("uint8", "char", "octet")
_FLOATS = ("float", "double", "long double")
_CHECK_PERIOD_S = 0.5
_CALL_TIMEOUT_S = 120.0
# rosbridge goal status (action_msgs/GoalStatus): succeeded, canceled
_SUCCEEDED, _CANCELED = 4, 5


def _import_type(full: str) -> Any:
    pkg, kind, name = full.split("/")
    return getattr(importlib.import_module(f"{pkg}.{kind}"), name)


def _namespaced(slot: NamespacedType) -> Any:
    return getattr(importlib.import_module(".".join(slot.namespaces)), slot.name)


# -- rosbridge JSON <-> rclpy messages ------------------------------------------------------


def to_ros(cls: Any, data: Any) -> Any:
    msg = cls()
    if not isinstance(data, dict):
        return msg
    for field, slot in zip(cls.get_fields_and_field_types(), cls.SLOT_TYPES, strict=True):
        if field in data:
            setattr(msg, field, _value_to_ros(slot, data[field]))
    return msg


def _value_to_ros(slot: Any, value: Any) -> Any:
    if isinstance(slot, NamespacedType):
        return to_ros(_namespaced(slot), value)
    if isinstance(slot, AbstractNestedType):
        inner = slot.value_type
        if isinstance(inner, BasicType) and inner.typename in _BYTES and isinstance(value, str):
            raw = base64.b64decode(value)
            return [bytes([b]) for b in raw] if inner.typename == "octet" else list(raw)
        return [_value_to_ros(inner, v) for v in value]
    if isinstance(slot, BasicType):
        name = slot.typename
        if name in _FLOATS:
            return float(value)
        if name == "boolean":
            return bool(value)
        if name == "octet":
            return bytes([int(value)])
        return int(value)
    return str(value)


def to_json(msg: Any) -> dict[str, Any]:
    cls = type(msg)
    return {
        field: _value_to_json(slot, getattr(msg, field))
        for field, slot in zip(cls.get_fields_and_field_types(), cls.SLOT_TYPES, strict=True)
    }


def _value_to_json(slot: Any, value: Any) -> Any:
    if isinstance(slot, NamespacedType):
        return to_json(value)
    if isinstance(slot, AbstractNestedType):
        inner = slot.value_type
        if isinstance(inner, BasicType) and inner.typename in _BYTES:
            raw = b"".join(value) if inner.typename == "octet" else bytes(bytearray(value))
            return base64.b64encode(raw).decode("ascii")
        return [_value_to_json(inner, v) for v in value]
    if isinstance(slot, BasicType):
        name = slot.typename
        if name in _FLOATS:
            return float(value)
        if name == "boolean":
            return bool(value)
        if name == "octet":
            return value[0]
        return int(value)
    if isinstance(slot, AbstractGenericString):
        return str(value)
    return value


# -- the gateway ----------------------------------------------------------------------------


def _qos_text(qos: Any) -> str:
    return f"{qos.reliability.name.lower()}, {qos.durability.name.lower()}"


class Gateway:
    def __init__(self, ws: Any, offer: dict[str, Any]) -> None:
        self.offer = offer
        self.ws = ws
        self.send_lock = threading.Lock()
        self.nodes: dict[str, Node] = {}
        self.publishers: dict[str, tuple[Any, Any]] = {}
        self.expected: dict[str, tuple[str, Any, str]] = {}  # topic -> type, qos, role
        self.refused: list[str] = []
        self.calls: dict[str, tuple[threading.Event, list[Any]]] = {}
        self.ids = itertools.count(1)
        self.warned: set[tuple[str, str, str]] = set()
        self.keep: list[Any] = []
        self.executor: SingleThreadedExecutor | None = None
        self.goals: dict[str, tuple[Any, Any, Future]] = {}  # id -> (goal handle, class, result)

    def node(self, names: list[str]) -> Node:
        full = names[0] if names else "/harness"
        node = self.nodes.get(full)
        if node is None:
            namespace, _, name = full.rpartition("/")
            node = rclpy.create_node(name or "harness", namespace=namespace or "/")
            self.nodes[full] = node
        return node

    def send(self, frame: dict[str, Any]) -> None:
        text = json.dumps(frame)
        with self.send_lock:
            try:
                self.ws.send(text)
            except Exception as exc:  # the session is gone: nothing to tell it
                print(f"gateway: send failed: {exc}", file=sys.stderr, flush=True)

    def status(self, level: str, text: str) -> None:
        self.send({"op": "status", "level": level, "msg": f"ros2: {text}"})

    def set_up(self) -> None:
        for t in self.offer["published"]:
            self.mirror_published(t)
        for t in self.offer["subscribed"]:
            self.mirror_subscribed(t)
        for s in self.offer["services"]:
            self.mirror_service(s)
        for a in self.offer["actions"]:
            self.mirror_action(a)
        for what in self.refused:  # the session logs them as warning events (recorded)
            self.status("warning", f"not on DDS: {what}")

    def mirror_published(self, t: dict[str, Any]) -> None:
        name, type_ = t["name"], t["type"]
        try:
            cls = _import_type(type_)
        except (ImportError, AttributeError, ValueError):
            self.refused.append(f"{name} ({type_}): no type support on the ROS 2 side")
            return
        if t["latched"]:
            qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)  # fmt: skip
        else:  # reliable volatile matches best-effort subscribers (use_sim_time's /clock)
            qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        pub = self.node(t["nodes"]).create_publisher(cls, name, qos)
        self.publishers[name] = (pub, cls)
        self.expected[name] = (type_, qos, "publisher")
        self.send({"op": "subscribe", "id": f"ros2:{name}", "topic": name, "type": type_})

    def mirror_subscribed(self, t: dict[str, Any]) -> None:
        name, type_ = t["name"], t["type"]
        try:
            cls = _import_type(type_)
        except (ImportError, AttributeError, ValueError):
            self.refused.append(f"{name} ({type_}): no type support on the ROS 2 side")
            return
        self.send({"op": "advertise", "id": f"ros2:{name}", "topic": name, "type": type_})
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)

        def forward(msg: Any, name: str = name) -> None:
            self.send({"op": "publish", "topic": name, "msg": to_json(msg)})

        sub = self.node(t["nodes"]).create_subscription(cls, name, forward, qos)
        self.keep.append(sub)
        self.expected[name] = (type_, qos, "subscriber")

    def mirror_service(self, s: dict[str, Any]) -> None:
        name, type_ = s["name"], s["type"]
        try:
            cls = _import_type(type_)
        except (ImportError, AttributeError, ValueError):
            self.refused.append(f"{name} ({type_}): no type support on the ROS 2 side")
            return

        def serve(request: Any, response: Any, name: str = name, cls: Any = cls) -> Any:
            call_id = f"ros2:{name}:{next(self.ids)}"
            done = threading.Event()
            box: list[Any] = []
            self.calls[call_id] = (done, box)
            self.send({"op": "call_service", "id": call_id, "service": name,
                       "args": to_json(request)})  # fmt: skip
            if not done.wait(_CALL_TIMEOUT_S):
                self.calls.pop(call_id, None)
                print(f"gateway: {name}: no answer", file=sys.stderr, flush=True)
                return response
            frame = box[0]
            if not frame.get("result", False):
                print(f"gateway: {name} failed: {frame.get('values')}", file=sys.stderr,
                      flush=True)  # fmt: skip
                return response
            return to_ros(cls.Response, frame.get("values", {}))

        self.keep.append(self.node(s["nodes"]).create_service(cls, name, serve))

    def mirror_action(self, a: dict[str, Any]) -> None:
        name, type_ = a["name"], a["type"]
        try:
            cls = _import_type(type_)
        except (ImportError, AttributeError, ValueError):
            self.refused.append(f"{name} ({type_}): no type support on the ROS 2 side")
            return

        def cancel(goal_handle: Any, name: str = name) -> CancelResponse:
            for goal_id, (handle, _, _) in list(self.goals.items()):
                if handle is goal_handle:
                    self.send({"op": "cancel_action_goal", "id": goal_id, "action": name})
                    return CancelResponse.ACCEPT
            return CancelResponse.REJECT

        server = ActionServer(
            self.node(a["nodes"]),
            cls,
            name,
            # a partial of a coroutine function: rclpy awaits it (a lambda's coroutine it would not)
            functools.partial(self.execute, name=name, type_=type_, cls=cls),
            goal_callback=lambda _goal: GoalResponse.ACCEPT,
            cancel_callback=cancel,
        )
        self.keep.append(server)

    async def execute(self, goal_handle: Any, name: str, type_: str, cls: Any) -> Any:
        """Forward an accepted goal over rosbridge and wait (without blocking the executor:
        /harness/step calls go on meanwhile) for its result."""
        goal_id = f"ros2:{name}:{next(self.ids)}"
        done = Future(executor=self.executor)
        self.goals[goal_id] = (goal_handle, cls, done)
        # sent before the executor serves anything else: a step the client asks for after the
        # goal was accepted comes after the goal on the bridge
        self.send({"op": "send_action_goal", "id": goal_id, "action": name, "action_type": type_,
                   "args": to_json(goal_handle.request), "feedback": True})  # fmt: skip
        frame: dict[str, Any] = await done
        status = frame.get("status", 0)
        if not frame.get("result", False):
            print(f"gateway: {name} failed: {frame.get('values')}", file=sys.stderr, flush=True)
            goal_handle.abort()
            return cls.Result()
        if status == _SUCCEEDED:
            goal_handle.succeed()
        elif status == _CANCELED and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        else:
            goal_handle.abort()
        return to_ros(cls.Result, frame.get("values", {}))

    def action_frame(self, frame: dict[str, Any]) -> None:
        """Feedback or a result from the session (called in the receiver thread)."""
        goal_id = str(frame.get("id"))
        entry = self.goals.get(goal_id)
        if entry is None:
            return
        goal_handle, cls, done = entry
        if frame.get("op") == "action_feedback":
            goal_handle.publish_feedback(to_ros(cls.Feedback, frame.get("values", {})))
            return
        del self.goals[goal_id]
        if self.executor is not None:  # resolved in the executor's thread, which it wakes
            self.executor.create_task(done.set_result, frame)

    def receive_forever(self) -> None:
        try:
            self._receive()
        except Exception as exc:  # the session closed the connection
            print(f"gateway: connection closed: {exc}", file=sys.stderr, flush=True)
        finally:
            rclpy.try_shutdown()  # ends the executor's spin

    def _receive(self) -> None:
        for message in self.ws:
            frame = json.loads(message)
            op = frame.get("op")
            if op == "publish":
                entry = self.publishers.get(frame.get("topic", ""))
                if entry is not None:
                    pub, cls = entry
                    pub.publish(to_ros(cls, frame.get("msg", {})))
            elif op == "service_response":
                waiting = self.calls.pop(str(frame.get("id")), None)
                if waiting is not None:
                    waiting[1].append(frame)
                    waiting[0].set()
            elif op in ("action_feedback", "action_result"):
                self.action_frame(frame)
            elif op == "status":
                print(f"gateway: session status {frame.get('level')}: {frame.get('msg')}",
                      file=sys.stderr, flush=True)  # fmt: skip

    def check_graph(self) -> None:
        """Warn (once each) about DDS endpoints on the session's topics with another type or
        QoS that cannot match."""
        probe = next(iter(self.nodes.values()))
        own = {n.get_fully_qualified_name() for n in self.nodes.values()}
        for topic, (type_, qos, role) in self.expected.items():
            ros_type = type_.replace("/msg/", "/msg/")
            if role == "subscriber":
                infos = probe.get_publishers_info_by_topic(topic)
            else:
                infos = probe.get_subscriptions_info_by_topic(topic)
            for info in infos:
                if info.node_name.startswith("_NODE_NAME_UNKNOWN"):
                    continue  # discovery has not named its node yet: a later check does
                node = f"{info.node_namespace.rstrip('/')}/{info.node_name}"
                if node in own:
                    continue
                problem = ""
                if info.topic_type != ros_type:
                    problem = f"type {info.topic_type}, the simulation's is {type_}"
                elif role == "subscriber" and (
                    info.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
                ):
                    problem = (f"QoS {_qos_text(info.qos_profile)} cannot match the "
                               f"simulation's subscription ({_qos_text(qos)})")  # fmt: skip
                elif role == "publisher" and (
                    info.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
                    and qos.durability != DurabilityPolicy.TRANSIENT_LOCAL
                ):
                    problem = (f"QoS {_qos_text(info.qos_profile)} cannot match the "
                               f"simulation's publisher ({_qos_text(qos)})")  # fmt: skip
                key = (topic, node, problem)
                if problem and key not in self.warned:
                    self.warned.add(key)
                    kind = "publisher" if role == "subscriber" else "subscriber"
                    self.status("warning", f"{topic}: {kind} {node} has {problem}")


def main() -> int:
    url = sys.argv[1]
    offer = json.loads(sys.stdin.readline())
    rclpy.init()
    with connect(url, max_size=2**26, compression=None) as ws:
        return run(Gateway(ws, offer))


def run(gateway: Gateway) -> int:
    gateway.set_up()
    # one thread: a command published before a /harness/step call is forwarded before it
    # (rclpy serves ready subscriptions before ready services)
    executor = SingleThreadedExecutor()
    gateway.executor = executor
    for node in gateway.nodes.values():
        executor.add_node(node)
    if gateway.nodes:
        timer = next(iter(gateway.nodes.values())).create_timer(
            _CHECK_PERIOD_S, gateway.check_graph
        )
        gateway.keep.append(timer)
    receiver = threading.Thread(target=gateway.receive_forever, daemon=True)
    receiver.start()
    print("ready " + json.dumps({"refused": gateway.refused}), flush=True)
    try:
        executor.spin()  # until SIGTERM/SIGINT (rclpy's handlers shut the context down)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        for node in gateway.nodes.values():
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
