"""ros2_control_demos' examples 4 and 5 (an RRBot with a force-torque sensor integrated in its
hardware, or as a separate sensor component) driven as their userdocs drive them: the forward
command moves the joints and ``/fts_broadcaster/wrench`` republishes the sensor's state
interfaces (issue 34: ``force_torque_sensor_broadcaster`` was a type the harness lacked, and a
``<ros2_control>`` ``<sensor>`` had no state interfaces)."""

from __future__ import annotations

import pytest

from harness.testing import connect
from tests.controllers.demos.demos import command, controllers, is_nan, latest, session

JOINTS = ["joint1", "joint2"]
SPAWNED = ["joint_state_broadcaster", "forward_position_controller", "fts_broadcaster"]
TYPE = "force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster"
AXES = [(part, axis) for part in ("force", "torque") for axis in "xyz"]


def _drive(example: int, yaml: str) -> tuple[dict, list[dict], list[dict], list[float]]:
    config = controllers(example, yaml, SPAWNED)
    with session(example, config) as s, connect(s.url) as client:
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        wrench = client.subscribe("/fts_broadcaster/wrench", "geometry_msgs/msg/WrenchStamped")
        measured = client.subscribe("/tcp_fts_sensor/wrench", "geometry_msgs/msg/WrenchStamped")
        listed = client.call_service("/controller_manager/list_controllers")
        client.step(10)
        client.publish(
            "/forward_position_controller/commands",
            "std_msgs/msg/Float64MultiArray",
            command([0.5, 0.5]),
        )
        client.step(1000)
        client.sync()
        reached = latest(states, JOINTS)
    by_name = {c["name"]: c for c in listed["controller"]}
    return by_name, wrench.messages, measured.messages, reached


def _stamp(msg: dict) -> int:
    return int(msg["header"]["stamp"]["sec"]) * 10**9 + int(msg["header"]["stamp"]["nanosec"])


def test_example_4_broadcasts_the_two_interfaces_it_names() -> None:
    listed, wrenches, measured, reached = _drive(4, "rrbot_with_sensor_controllers.yaml")
    fts = listed["fts_broadcaster"]
    assert (fts["type"], fts["state"]) == (TYPE, "active")
    assert fts["required_state_interfaces"] == ["tcp_fts_sensor/force.x", "tcp_fts_sensor/torque.z"]
    assert reached == pytest.approx([0.5, 0.5], abs=0.01)
    assert len(wrenches) >= 100  # 100 Hz controller manager over 2 s
    by_stamp = {_stamp(m): m for m in measured}
    pairs = [(w, by_stamp[_stamp(w)]) for w in wrenches if _stamp(w) in by_stamp]
    assert len(pairs) >= 100
    for got, sensor in pairs:
        assert got["header"]["frame_id"] == "tool_link"
        assert got["wrench"]["force"]["x"] == sensor["wrench"]["force"]["x"]
        assert got["wrench"]["torque"]["z"] == sensor["wrench"]["torque"]["z"]
        # the axes the YAML does not name are NaN, as the semantic component leaves them
        for part, axis in AXES:
            if (part, axis) not in (("force", "x"), ("torque", "z")):
                assert is_nan(got["wrench"][part][axis])


def test_example_5_broadcasts_all_six_interfaces_of_the_external_sensor() -> None:
    listed, wrenches, measured, reached = _drive(5, "rrbot_with_external_sensor_controllers.yaml")
    fts = listed["fts_broadcaster"]
    assert (fts["type"], fts["state"]) == (TYPE, "active")
    assert len(fts["required_state_interfaces"]) == 6
    assert reached == pytest.approx([0.5, 0.5], abs=0.01)
    by_stamp = {_stamp(m): m for m in measured}
    pairs = [(w, by_stamp[_stamp(w)]) for w in wrenches if _stamp(w) in by_stamp]
    assert len(pairs) >= 100
    for got, sensor in pairs:
        assert got["header"]["frame_id"] == "tool_link"
        assert got["wrench"] == sensor["wrench"]
