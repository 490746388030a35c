"""The native ROS 2 side (``Session(ros2=True)``) with real rclpy nodes in other processes."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

from harness.events import CollectingSink, Level, LogMessage
from harness.recording import Recording
from harness.replay import verify
from harness.ros2 import Ros2Install, choose_domain_id
from harness.ros2.testing import free_port, rosbridge_server, run_node, start_node
from harness.session import Session
from tests.ros2.ros2_paths import ARM_NODE

BAD_NODE = """
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory
rclpy.init()
node = rclpy.create_node("bad_node")
wrong_type = node.create_publisher(String, "/joint_command", 10)
best_effort = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
unmatched = node.create_publisher(JointTrajectory, "/joint_trajectory", best_effort)
other = rclpy.Context()  # a second participant: one may not hold two types of a topic
rclpy.init(context=other)
joints_node = rclpy.create_node("bad_joints", context=other)
command = joints_node.create_publisher(JointState, "/joint_command", 10)
while command.get_subscription_count() == 0:
    rclpy.spin_once(joints_node, timeout_sec=0.05)
print("published", flush=True)
while True:  # again and again: the first messages may go before discovery completes
    command.publish(JointState(name=["no_such_joint"], position=[1.0]))
    rclpy.spin_once(node, timeout_sec=0.1)
"""


def _texts(sink: CollectingSink, level: Level) -> list[str]:
    return [e.message() for e in sink.events if isinstance(e, LogMessage) and e.level == level]


@pytest.mark.slow
def test_lockstep_from_a_node_gives_identical_runs_that_replay(
    ros2: Ros2Install, tmp_path: Path
) -> None:
    paths = [tmp_path / "first.mcap", tmp_path / "second.mcap"]
    for path in paths:
        with Session("demo", ros2=True, record_to=path) as session:
            assert session.ros2_refused == ()
            result = run_node(ros2, session.ros_domain_id or 0, ARM_NODE, ["--lockstep"])
            assert result["joint1"] == pytest.approx(0.3, abs=0.01)
            assert result["clock_ns"] == result["step_answer_ns"] == 1_000_000_000
            assert result["description_bytes"] > 1000
            domain = session.ros_domain_id
        with Recording(path) as rec:
            assert rec.metadata["ros_domain_id"] == str(domain)
            dds = [f for f in rec.bridge_frames() if f.direction == 0 and f.connection == 1]
            assert any(f.op == "call_service" and f.topic == "/harness/step" for f in dds)
            assert any(f.op == "publish" and f.topic == "/joint_trajectory" for f in dds)
        report = verify(path, level="full")
        assert report.reproduced
        assert report.pipeline is not None
        assert report.pipeline.reproduced
    with Recording(paths[0]) as a, Recording(paths[1]) as b:
        first, second = a.physics_state_arrays(), b.physics_state_arrays()
        assert np.array_equal(first.steps, second.steps)
        assert first.state.tobytes() == second.state.tobytes()


@pytest.mark.slow
def test_bad_input_from_a_node_is_reported_and_a_crash_leaves_the_run_going(
    ros2: Ros2Install, tmp_path: Path
) -> None:
    events = CollectingSink()
    path = tmp_path / "bad.mcap"
    with Session("demo", ros2=True, record_to=path, sinks=[events]) as session:
        node = start_node(ros2, session.ros_domain_id or 0, BAD_NODE)
        warnings, errors = "", []
        try:
            assert node.stdout is not None
            assert node.stdout.readline().strip() == "published"
            deadline = time.monotonic() + 30  # the gateway checks the graph every 0.5 s
            while time.monotonic() < deadline:
                warnings = " | ".join(session.call(lambda: _texts(events, Level.WARNING)))
                errors = session.call(lambda: _texts(events, Level.ERROR))
                refused = any("no_such_joint" in t for t in errors)
                if "type std_msgs/msg/String" in warnings and "best_effort" in warnings and refused:
                    break
                session.step(1)
        finally:
            os.kill(node.pid, signal.SIGKILL)  # the node crashes mid-run
            node.communicate()
        assert "/joint_command: publisher /bad_node has type std_msgs/msg/String" in warnings
        assert "/joint_trajectory: publisher /bad_node has QoS best_effort" in warnings
        assert any("command refused" in t and "no_such_joint" in t for t in errors), errors
        before = session.step_index
        session.step(50)
        assert session.step_index == before + 50
    assert verify(path, level="full").reproduced


def test_domain_id_honours_the_environment() -> None:
    assert choose_domain_id({"ROS_DOMAIN_ID": "42"}) == 42
    assert choose_domain_id({}) in range(1, 102)


@pytest.mark.slow
def test_client_mode_survives_a_rosbridge_server_rs_restart(
    ros2: Ros2Install, tmp_path: Path
) -> None:
    domain = choose_domain_id()
    port = free_port()
    path = tmp_path / "restart.mcap"
    with rosbridge_server(ros2, domain, port) as url:
        session = Session("demo", connect_to=url, record_to=path)
        try:
            run_node(ros2, domain, ARM_NODE, ["--lockstep"])
        except BaseException:
            session.close()
            raise
    try:
        with rosbridge_server(ros2, domain, port):  # the same server, restarted
            result = run_node(ros2, domain, ARM_NODE, ["--lockstep", "--target", "-0.2"])
            assert result["joint1"] == pytest.approx(-0.2, abs=0.01)
            assert session.step_index == 1000
            assert session.upstream is not None
            assert session.upstream.reconnects == 1
    finally:
        session.close()
    with Recording(path) as rec:
        gap = [f.text for f in rec.bridge_frames() if f.topic == "harness/transport_status"]
    assert any("lost: reconnecting" in t for t in gap), gap
    assert verify(path, level="full").reproduced
