"""The graph as rosapi shows it: in-process registrations under their node names, clients
under /rosbridge_websocket; a topic the simulation owns keeps its type against clients;
omitted message fields take the definition's defaults. Sans-I/O: frames in, frames out."""

from __future__ import annotations

import json
import re
from typing import Any

import pytest

from harness.rosbridge import Bridge, Message, TypeRegistry
from harness.rosbridge.convert import default_message, from_json
from harness.rosbridge.errors import ConversionError, TypeNameError

REGISTRY = TypeRegistry()
JOINT_STATE = "sensor_msgs/msg/JointState"
TF = "tf2_msgs/msg/TFMessage"


class Graph:
    """A bridge with a robot-shaped in-process graph and helpers to talk to it."""

    def __init__(self) -> None:
        self.bridge = Bridge(REGISTRY)
        b = self.bridge
        b.advertise("/tf", TF, node="/robot_state_publisher")
        b.advertise("/tf_static", TF, latch=True, node="/robot_state_publisher")
        b.advertise("/joint_states", JOINT_STATE, node="/joint_state_broadcaster")
        b.advertise("/clock", "rosgraph_msgs/msg/Clock")
        self.commands: list[Message] = []
        b.subscribe(
            "/arm_controller/commands",
            self.commands.append,
            "std_msgs/msg/Float64MultiArray",
            node="/arm_controller",
        )
        b.advertise_service(
            "/controller_manager/list_controllers",
            "std_srvs/srv/Trigger",
            lambda call: {"success": True, "message": ""},
            node="/controller_manager",
        )
        b.advertise_service("/harness/step", "harness_msgs/srv/Step", lambda call: {})
        b.advertise_action(
            "/arm_controller/follow",
            "example_interfaces/action/Fibonacci",
            lambda goal: goal.finish({"sequence": []}),
            node="/arm_controller",
        )

    def send(self, conn: int, frame: dict[str, Any]) -> list[tuple[int, Any]]:
        out = self.bridge.receive(conn, json.dumps(frame), 0)
        return [(o.connection, json.loads(o.data)) for o in out]

    def call(self, conn: int, service: str, args: dict[str, Any] | None = None) -> Any:
        out = self.send(conn, {"op": "call_service", "service": service, "args": args or {}})
        assert out[0][1]["result"] is True, out
        return out[0][1]["values"]

    def publish_joint_states(self) -> None:
        self.bridge.publish("/joint_states", JOINT_STATE, {"name": ["j"], "position": [1.0]}, 0)


def test_every_rosapi_answer_names_the_nodes_a_robot_shows() -> None:
    g = Graph()
    c = g.bridge.connect()
    g.send(c, {"op": "advertise", "topic": "/chatter", "type": "std_msgs/String"})
    g.send(c, {"op": "subscribe", "topic": "/joint_states", "type": JOINT_STATE})
    topics = g.call(c, "/rosapi/topics")
    pairs = dict(zip(topics["topics"], topics["types"], strict=True))
    assert pairs == {
        "/arm_controller/commands": "std_msgs/msg/Float64MultiArray",
        "/chatter": "std_msgs/msg/String",
        "/clock": "rosgraph_msgs/msg/Clock",
        "/joint_states": JOINT_STATE,
        "/tf": TF,
        "/tf_static": TF,
    }
    assert g.call(c, "/rosapi/topics_for_type", {"type": "tf2_msgs/TFMessage"}) == {
        "topics": ["/tf", "/tf_static"]
    }
    assert g.call(c, "rosapi/topic_type", {"topic": "/tf_static"}) == {"type": TF}
    assert g.call(c, "/rosapi/nodes")["nodes"] == [
        "/arm_controller",
        "/controller_manager",
        "/harness",
        "/joint_state_broadcaster",
        "/robot_state_publisher",
        "/rosapi",
        "/rosbridge_websocket",
    ]
    assert g.call(c, "/rosapi/publishers", {"topic": "/tf"}) == {
        "publishers": ["/robot_state_publisher"]
    }
    assert g.call(c, "/rosapi/subscribers", {"topic": "/joint_states"}) == {
        "subscribers": ["/rosbridge_websocket"]
    }
    assert g.call(c, "/rosapi/subscribers", {"topic": "/arm_controller/commands"}) == {
        "subscribers": ["/arm_controller"]
    }
    assert g.call(c, "/rosapi/node_details", {"node": "/robot_state_publisher"}) == {
        "subscribing": [],
        "publishing": ["/tf", "/tf_static"],
        "services": [],
    }
    assert g.call(c, "/rosapi/node_details", {"node": "/joint_state_broadcaster"}) == {
        "subscribing": [],
        "publishing": ["/joint_states"],
        "services": [],
    }
    assert g.call(c, "/rosapi/node_details", {"node": "/arm_controller"}) == {
        "subscribing": ["/arm_controller/commands"],
        "publishing": [
            "/arm_controller/follow/_action/feedback",
            "/arm_controller/follow/_action/status",
        ],
        "services": [
            "/arm_controller/follow/_action/cancel_goal",
            "/arm_controller/follow/_action/get_result",
            "/arm_controller/follow/_action/send_goal",
        ],
    }
    assert g.call(c, "/rosapi/node_details", {"node": "/harness"}) == {
        "subscribing": [],
        "publishing": ["/clock"],
        "services": ["/harness/step"],
    }
    assert g.call(c, "/rosapi/node_details", {"node": "/rosbridge_websocket"}) == {
        "subscribing": ["/joint_states"],
        "publishing": ["/chatter"],
        "services": [],
    }
    rosapi = g.call(c, "/rosapi/node_details", {"node": "/rosapi"})
    assert "/rosapi/node_details" in rosapi["services"]
    assert all(s.startswith("/rosapi/") for s in rosapi["services"])
    assert g.call(c, "/rosapi/node_details", {"node": "/nobody"}) == {
        "subscribing": [],
        "publishing": [],
        "services": [],
    }
    assert g.call(
        c, "/rosapi/service_node", {"service": "/controller_manager/list_controllers"}
    ) == {"node": "/controller_manager"}
    assert g.call(c, "/rosapi/service_providers", {"service": "/harness/step"}) == {
        "providers": ["/harness"]
    }
    services = g.call(c, "/rosapi/services")["services"]
    assert {"/controller_manager/list_controllers", "/harness/step"} <= set(services)
    assert g.call(c, "/rosapi/action_servers") == {"action_servers": ["/arm_controller/follow"]}
    # every type on the graph has its message details
    for type_ in pairs.values():
        typedefs = g.call(c, "/rosapi/message_details", {"type": type_})["typedefs"]
        assert typedefs[0]["type"] == type_


def test_a_node_leaves_the_graph_with_its_last_registration() -> None:
    g = Graph()
    c = g.bridge.connect()
    g.bridge.advertise("/tf", TF, node="/other_publisher")
    assert g.call(c, "/rosapi/publishers", {"topic": "/tf"})["publishers"] == [
        "/other_publisher",
        "/robot_state_publisher",
    ]
    g.bridge.unadvertise("/tf", node="/other_publisher")
    assert "/other_publisher" not in g.call(c, "/rosapi/nodes")["nodes"]
    g.bridge.unadvertise("/tf", node="/robot_state_publisher")
    assert "/tf" not in g.call(c, "/rosapi/topics")["topics"]
    # a plain in-process publish names the harness node
    g.bridge.publish("/plain", "std_msgs/msg/String", {"data": "x"}, 0)
    assert g.call(c, "/rosapi/publishers", {"topic": "/plain"}) == {"publishers": ["/harness"]}


@pytest.mark.parametrize(
    ("op", "topic", "type_"),
    [
        ("advertise", "/joint_states", "std_msgs/msg/String"),
        ("subscribe", "/joint_states", "std_msgs/msg/String"),
        ("advertise", "/clock", "builtin_interfaces/msg/Time"),
        ("subscribe", "/tf", "geometry_msgs/msg/TransformStamped"),
    ],
)
def test_a_client_cannot_retype_a_simulation_topic(op: str, topic: str, type_: str) -> None:
    g = Graph()
    intruder, bystander = g.bridge.connect(), g.bridge.connect()
    g.send(bystander, {"op": "subscribe", "topic": "/joint_states", "type": JOINT_STATE})
    out = g.send(intruder, {"op": op, "topic": topic, "type": type_, "id": "x"})
    assert len(out) == 1
    assert out[0][0] == intruder
    status = out[0][1]
    assert (status["op"], status["level"], status["id"]) == ("status", "error", "x")
    assert topic in status["msg"]
    assert type_ in status["msg"]
    # nothing else changed: the type, the publishers, the subscribers
    assert g.bridge.topic_type(topic) != type_
    assert intruder not in g.bridge.publishers_of(topic)
    assert intruder not in g.bridge.subscribers_of(topic)
    # and the simulation keeps publishing to the other client
    g.publish_joint_states()
    (frame,) = g.bridge.drain()
    assert frame.connection == bystander
    assert json.loads(frame.data)["msg"]["position"] == [1.0]


def test_static_transforms_reach_a_late_subscriber() -> None:
    g = Graph()
    g.bridge.publish("/tf_static", TF, {"transforms": [{"child_frame_id": "hand"}]}, 0)
    late = g.bridge.connect()
    out = g.send(late, {"op": "subscribe", "topic": "/tf_static", "type": TF})
    assert [f["msg"]["transforms"][0]["child_frame_id"] for _, f in out] == ["hand"]
    # the moving /tf is not latched
    g.bridge.publish("/tf", TF, {"transforms": []}, 0)
    assert g.send(late, {"op": "subscribe", "topic": "/tf", "type": TF}) == []


def test_a_pose_without_orientation_arrives_with_w_one() -> None:
    g = Graph()
    got: list[Message] = []
    g.bridge.subscribe("/target", got.append, "geometry_msgs/msg/PoseStamped")
    c = g.bridge.connect()
    g.send(c, {"op": "advertise", "topic": "/target", "type": "geometry_msgs/PoseStamped"})
    g.send(c, {"op": "publish", "topic": "/target", "msg": {"pose": {"position": {"x": 0.5}}}})
    (msg,) = got
    assert msg.msg["pose"]["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    assert msg.msg["pose"]["position"] == {"x": 0.5, "y": 0.0, "z": 0.0}
    # a transform without rotation too, and a default-made message
    tf = from_json(REGISTRY, "geometry_msgs/msg/Transform", {}, 0)
    assert tf["rotation"]["w"] == 1.0
    assert default_message(REGISTRY, "geometry_msgs/msg/Pose")["orientation"]["w"] == 1.0


def test_declared_defaults_of_registered_definitions() -> None:
    reg = TypeRegistry(bundled=False, harness_msgs=False)
    reg.register(
        "demo_msgs/msg/Defaults",
        "# every kind of default\n"
        "float64 gain 2.5  # a comment\n"
        "int32 count -3\n"
        "bool enabled true\n"
        'string label "a # b"\n'
        "string plain word\n"
        "int32[] ids [1, 2, 3]\n"
        "uint8[2] raw [7, 8]\n"
        "bool[] flags [true, false]\n"
        "int32 NOT_A_FIELD=4\n"
        "float64 zero\n",
    )
    assert default_message(reg, "demo_msgs/msg/Defaults") == {
        "gain": 2.5,
        "count": -3,
        "enabled": True,
        "label": "a # b",
        "plain": "word",
        "ids": [1, 2, 3],
        "raw": b"\x07\x08",
        "flags": [True, False],
        "zero": 0.0,
    }
    msg = from_json(reg, "demo_msgs/msg/Defaults", {"count": 5}, 0)
    assert (msg["count"], msg["gain"]) == (5, 2.5)
    msg["ids"].append(4)  # a message's list is its own, not the definition's
    assert from_json(reg, "demo_msgs/msg/Defaults", {}, 0)["ids"] == [1, 2, 3]
    # a service's sections get theirs too
    reg.register("demo_msgs/srv/Scale", "float64 factor 1.0\n---\nbool ok true\n")
    assert default_message(reg, "demo_msgs/srv/Scale_Request") == {"factor": 1.0}
    assert default_message(reg, "demo_msgs/srv/Scale_Response") == {"ok": True}


@pytest.mark.parametrize(
    ("text", "error"),
    [
        ("int8 x 300\n", "default '300' of field x is not a valid int8"),
        ("bool b maybe\n", "default 'maybe' of field b is not a valid bool"),
        ("float64[2] v [1.0]\n", "default '[1.0]' of field v is not a valid float64[2]: 1 values"),
    ],
)
def test_a_default_that_does_not_fit_is_refused(text: str, error: str) -> None:
    reg = TypeRegistry(bundled=False, harness_msgs=False)
    with pytest.raises(TypeNameError, match=re.escape(f"demo_msgs/msg/Bad: {error}")):
        reg.register("demo_msgs/msg/Bad", text)


def test_the_empty_message_placeholder_of_ros2_type_support_is_accepted_only_there() -> None:
    # rosbridge-server-rs sends it for an empty request (std_srvs/Trigger, harness GetState)
    placeholder = {"structure_needs_at_least_one_member": 0}
    assert from_json(REGISTRY, "std_srvs/srv/Trigger_Request", placeholder, 0) == {}
    with pytest.raises(ConversionError, match="does not have a field"):
        from_json(REGISTRY, "std_msgs/msg/String", placeholder, 0)
