"""The simulated robot looks like a real ROS 2 robot through the bridge: roslibpy and roslibjs
find its topics, nodes, services and actions through rosapi; /tf_static arrives latched to a
late subscriber; /tf follows the URDF tree and composes to the simulation's own poses; a
client that retypes one of the simulation's topics gets a status error and the server keeps
serving everyone else."""

from __future__ import annotations

import asyncio
import json
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from harness.models import LoadedRobot, Pose
from harness.recording import Recording
from harness.session import Session
from tests.session.session_helpers import Client

PY_SCRIPT = Path(__file__).with_name("roslibpy_graph.py")
NODE_DIR = Path(__file__).resolve().parents[1] / "node"
JS_SCRIPT = NODE_DIR / "graph_roslibjs.mjs"
NODE = shutil.which("node")
JTC = "/joint_trajectory_controller"
FOLLOW = f"{JTC}/follow_joint_trajectory"
GRIPPER = "/gripper_controller/gripper_cmd"


EXPECTED_TOPICS = {
    "/clock": "rosgraph_msgs/msg/Clock",
    "/joint_states": "sensor_msgs/msg/JointState",
    "/robot_description": "std_msgs/msg/String",
    "/rosout": "rcl_interfaces/msg/Log",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/forward_effort_controller/commands": "std_msgs/msg/Float64MultiArray",
    "/forward_position_controller/commands": "std_msgs/msg/Float64MultiArray",
    "/forward_velocity_controller/commands": "std_msgs/msg/Float64MultiArray",
    "/joint_command": "sensor_msgs/msg/JointState",
    "/joint_trajectory": "trajectory_msgs/msg/JointTrajectory",
    f"{JTC}/controller_state": "control_msgs/msg/JointTrajectoryControllerState",
    f"{JTC}/joint_trajectory": "trajectory_msgs/msg/JointTrajectory",
}
EXPECTED_PUBLISHERS = {
    "/clock": ["/harness"],
    "/joint_states": ["/joint_state_broadcaster"],
    "/robot_description": ["/robot_state_publisher"],
    "/rosout": ["/harness"],
    "/tf": ["/robot_state_publisher"],
    "/tf_static": ["/robot_state_publisher"],
    f"{JTC}/controller_state": [JTC],
}


def _check_graph(out: dict[str, Any]) -> None:
    pairs = dict(zip(out["topics"], out["types"], strict=True))
    assert pairs == EXPECTED_TOPICS
    assert out["tf_static_type"] == "tf2_msgs/msg/TFMessage"
    assert out["nodes"] == [
        "/controller_manager",
        "/forward_effort_controller",
        "/forward_position_controller",
        "/forward_velocity_controller",
        "/gripper_controller",
        "/harness",
        "/joint_state_broadcaster",
        JTC,
        "/robot_state_publisher",
        "/rosapi",
        "/rosbridge_websocket",
    ]
    details = out["details"]
    assert details["/robot_state_publisher"] == {
        "subscribing": [],
        "publishing": ["/robot_description", "/tf", "/tf_static"],
        "services": [],
    }
    assert details["/joint_state_broadcaster"] == {
        "subscribing": [],
        "publishing": ["/joint_states"],
        "services": [],
    }
    harness = details["/harness"]
    assert harness["publishing"] == ["/clock", "/rosout"]
    assert harness["subscribing"] == ["/joint_command", "/joint_trajectory"]
    for kind in ("effort", "position", "velocity"):
        assert details[f"/forward_{kind}_controller"] == {
            "subscribing": [f"/forward_{kind}_controller/commands"],
            "publishing": [],
            "services": [],
        }
    assert harness["services"] == [
        "/harness/get_state",
        "/harness/pause",
        "/harness/reset",
        "/harness/step",
    ]
    actions = ("cancel_goal", "get_result", "send_goal")
    assert details[JTC] == {
        "subscribing": [f"{JTC}/joint_trajectory"],
        "publishing": [
            f"{JTC}/controller_state",
            f"{FOLLOW}/_action/feedback",
            f"{FOLLOW}/_action/status",
        ],
        "services": [f"{FOLLOW}/_action/{a}" for a in actions],
    }
    assert details["/gripper_controller"]["services"] == [f"{GRIPPER}/_action/{a}" for a in actions]
    manager = details["/controller_manager"]["services"]
    assert "/controller_manager/list_controllers" in manager
    assert "/controller_manager/switch_controller" in manager
    assert all(s.startswith("/rosapi/") for s in details["/rosapi"]["services"])
    assert "/rosapi/node_details" in details["/rosapi"]["services"]
    assert set(out["services"]) == {
        *harness["services"],
        *manager,
        *details["/rosapi"]["services"],
    }
    assert out["action_servers"] == [GRIPPER, FOLLOW]
    static = {t["child_frame_id"]: t["header"]["frame_id"] for t in out["tf_static"]["transforms"]}
    assert static == {"link0": "world", "hand": "link7"}


@pytest.mark.slow
def test_roslibpy_sees_the_robot_graph(demo_position: LoadedRobot) -> None:
    with Session(demo_position) as session:
        port = session.url.rsplit(":", 1)[1]
        proc = subprocess.run(
            [sys.executable, str(PY_SCRIPT), port], capture_output=True, text=True, timeout=60
        )
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert proc.stdout.splitlines()[-1] == "OK", proc.stdout
        assert session.step_index == 10  # the late subscription came after the steps
    out = json.loads(proc.stdout.splitlines()[0])
    _check_graph(out)
    # every type on the graph has its definition; every published topic its publisher
    assert out["message_details"] == {t: t for t in EXPECTED_TOPICS.values()}
    assert {t: p for t, p in out["publishers"].items() if p} == EXPECTED_PUBLISHERS


@pytest.mark.node
@pytest.mark.skipif(NODE is None, reason="node is not installed")
@pytest.mark.skipif(
    not (NODE_DIR / "node_modules" / "roslib").is_dir(),
    reason="tests/node/node_modules lacks roslib (run `make node-deps`)",
)
def test_roslibjs_sees_the_robot_graph(demo_position: LoadedRobot) -> None:
    async def drive(url: str) -> tuple[int | None, str]:
        assert NODE is not None
        proc = await asyncio.create_subprocess_exec(
            NODE,
            str(JS_SCRIPT),
            url,
            cwd=NODE_DIR,
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.STDOUT,
        )
        out, _ = await asyncio.wait_for(proc.communicate(), 60)
        return proc.returncode, out.decode()

    with Session(demo_position) as session:
        code, out = asyncio.run(drive(session.url))
        assert code == 0, out
        assert out.splitlines()[-1] == "OK", out
        assert session.step_index == 10
    _check_graph(json.loads(out.splitlines()[0]))


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_retyping_a_simulation_topic_leaves_the_server_serving(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client], clock: str
) -> None:
    with Session(demo_position, clock=clock) as session:  # type: ignore[arg-type]
        bystander = client_factory(session.url)
        bystander.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        intruder = client_factory(session.url)
        frames = [
            ("advertise", "/joint_states", "std_msgs/msg/String"),
            ("subscribe", "/clock", "builtin_interfaces/msg/Time"),
            ("advertise", "/tf", "geometry_msgs/msg/TransformStamped"),
            ("subscribe", "/tf_static", "std_msgs/msg/String"),
        ]
        for i, (op, topic, type_) in enumerate(frames):
            intruder.send({"op": op, "topic": topic, "type": type_, "id": f"bad{i}"})
        for i, (_, topic, type_) in enumerate(frames):
            status = intruder.recv_until(lambda f: f.get("op") == "status")
            assert (status["level"], status["id"]) == ("error", f"bad{i}")
            assert topic in status["msg"]
            assert type_ in status["msg"]
        # the simulation keeps publishing with its own types, to the other client
        start = session.sim_time_ns
        if clock == "lockstep":
            bystander.step(20)  # /joint_states at 100 Hz of sim time

        def later(f: dict[str, Any]) -> bool:
            if f.get("op") != "publish" or f["topic"] != "/joint_states":
                return False
            s = f["msg"]["header"]["stamp"]
            return bool(s["sec"] * 10**9 + s["nanosec"] > start)

        state = next(filter(later, bystander.received), None) or bystander.recv_until(later)
        assert state["msg"]["name"][0] == "joint1"
        assert session.failure is None
        # and the intruder is still a client like any other
        intruder.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        if clock == "lockstep":
            intruder.step(20)
        assert any(f.get("op") == "publish" for f in intruder.received) or intruder.recv_until(
            lambda f: f.get("op") == "publish"
        )
        assert session.failure is None


def _pose(t: dict[str, Any]) -> Pose:
    tr, rot = t["transform"]["translation"], t["transform"]["rotation"]
    return Pose((tr["x"], tr["y"], tr["z"]), (rot["w"], rot["x"], rot["y"], rot["z"]))


def test_tf_follows_the_urdf_tree_and_composes_to_the_simulation(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client], tmp_path: Path
) -> None:
    path = tmp_path / "tf.mcap"
    with Session(demo_position, record_to=path) as session:
        for joint, position in {"joint1": 0.6, "joint2": -0.4, "joint6": 1.2}.items():
            session.command(joint, position=position)
        client = client_factory(session.url)
        client.subscribe("/tf", "tf2_msgs/msg/TFMessage")
        client.subscribe("/tf_static", "tf2_msgs/msg/TFMessage")
        client.step(40)
        poses = session.call(lambda: session.core.sim.link_poses())
        now = session.sim_time_ns
        # lockstep: everything published during the steps came before the step's answer
        assert client.messages("/tf")[-1]["transforms"][0]["header"]["stamp"] == {
            "sec": now // 10**9,
            "nanosec": now % 10**9,
        }
        moving = client.messages("/tf")[-1]["transforms"]
        (static_msg,) = client.messages("/tf_static")
        static = static_msg["transforms"]
    description = demo_position.description
    urdf = {j.child: j.parent for j in description.joints}
    parents = {t["child_frame_id"]: t["header"]["frame_id"] for t in [*static, *moving]}
    assert parents == {**urdf, "link0": "world"}
    assert {t["child_frame_id"] for t in moving} == {
        j.child for j in description.joints if j.type != "fixed"
    }
    # composing the tree from world gives the simulation's world pose of every link
    world: dict[str, Pose] = {"world": Pose()}
    edges = {t["child_frame_id"]: t for t in [*static, *moving]}
    while len(world) <= len(edges):
        for child, t in edges.items():
            if child not in world and t["header"]["frame_id"] in world:
                world[child] = world[t["header"]["frame_id"]] * _pose(t)
    for link in urdf.keys() | {"link0"}:
        xyz, quat = poses[link]
        assert np.allclose(world[link].xyz, xyz, atol=1e-12), link
        assert abs(abs(float(np.dot(world[link].quat, quat))) - 1.0) < 1e-12, link
    assert poses["link1"][1] != pytest.approx(poses["link0"][1])  # the arm did move
    # the recording holds /tf_static once and /tf with the moving transforms only
    with Recording(path) as recording:
        topics = recording.topics
        assert topics["/tf_static"].msgtype == "tf2_msgs/msg/TFMessage"
        assert topics["/tf_static"].messages == 1
        (recorded,) = recording.messages("/tf_static", decode=True)
        assert {t.child_frame_id for t in recorded.msg.transforms} == {"link0", "hand"}
        first_tf = next(recording.messages("/tf", decode=True))
        assert len(first_tf.msg.transforms) == len(moving)


@pytest.mark.slow
def test_harness_serve_survives_a_client_retyping_joint_states() -> None:
    """The report's reproduction: before the fix, `harness serve` exited with "Tried to
    register topic /joint_states with type sensor_msgs/msg/JointState but it is already
    established with type std_msgs/msg/String"."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "harness", "serve", "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        first = proc.stdout.readline()
        assert first.startswith("harness serve: ws://127.0.0.1:"), first
        url = first.split()[2]
        intruder, bystander = Client(url), Client(url)
        intruder.send({"op": "advertise", "topic": "/joint_states", "type": "std_msgs/String"})
        status = intruder.recv_until(lambda f: f.get("op") == "status")
        assert "/joint_states" in status["msg"]
        assert "std_msgs/msg/String" in status["msg"]
        bystander.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        for _ in range(3):  # several publishes of the realtime clock after the refusal
            frame = bystander.recv_until(lambda f: f.get("topic") == "/joint_states")
            assert frame["msg"]["name"][0] == "joint1"
        intruder.close()
        bystander.close()
        assert proc.poll() is None
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert "stopped at step" in out
