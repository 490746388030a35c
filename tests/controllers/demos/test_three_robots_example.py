"""ros2_control_demos' example 13: three robots (two RRBots, a three-DoF bot) with their name
prefixes in one description and one controller manager, each with its own controllers; driven
as its userdoc drives them (the position controllers, the ``--inactive`` spawn activated with
``switch_controller``), the prefixed force-torque sensors broadcast (issue 34)."""

from __future__ import annotations

import pytest

from harness.testing import BridgeTestClient, connect
from tests.controllers.demos.demos import command, controllers, latest, session

YAML = "three_robots_controllers.yaml"
ACTIVE = [
    "joint_state_broadcaster",
    "rrbot_joint_state_broadcaster",
    "rrbot_position_controller",
    "rrbot_external_fts_broadcaster",
    "rrbot_with_sensor_joint_state_broadcaster",
    "rrbot_with_sensor_fts_broadcaster",
]
INACTIVE = ["rrbot_with_sensor_position_controller", "threedofbot_position_controller"]
# threedofbot_pid_gain_controller commands the custom pid_gain interface: not simulated, not spawned
RRBOT = ["rrbot_joint1", "rrbot_joint2"]
WITH_SENSOR = ["rrbot_with_sensor_joint1", "rrbot_with_sensor_joint2"]
THREEDOF = ["threedofbot_joint1", "threedofbot_joint2", "threedofbot_joint3"]
ARRAY = "std_msgs/msg/Float64MultiArray"


def _switch(client: BridgeTestClient, activate: list[str], deactivate: list[str]) -> bool:
    request = {
        "activate_controllers": activate,
        "deactivate_controllers": deactivate,
        "strictness": 2,
        "activate_asap": True,
        "timeout": {"sec": 0, "nanosec": 0},
    }
    return bool(client.call_service("/controller_manager/switch_controller", request)["ok"])


def test_three_robots_in_one_controller_manager_move_each_on_its_own_controller() -> None:
    config = controllers(13, YAML, ACTIVE + INACTIVE)
    with session(13, config) as s, connect(s.url) as client:
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        external = client.subscribe("/rrbot_external_fts_broadcaster/wrench")
        integrated = client.subscribe("/rrbot_with_sensor_fts_broadcaster/wrench")
        assert _switch(client, [], INACTIVE)  # the launch file spawns them --inactive
        client.step(10)
        client.publish("/rrbot_position_controller/commands", ARRAY, command([0.5, -0.5]))
        client.publish(
            "/rrbot_with_sensor_position_controller/commands", ARRAY, command([0.5, 0.5])
        )
        client.step(1000)
        client.sync()
        rrbot, idle = latest(states, RRBOT), latest(states, WITH_SENSOR)
        # the userdoc's next step: activate the robot with the sensor's controller
        assert _switch(client, ["rrbot_with_sensor_position_controller"], [])
        client.publish(
            "/rrbot_with_sensor_position_controller/commands", ARRAY, command([0.5, 0.5])
        )
        assert _switch(client, ["threedofbot_position_controller"], [])
        client.publish("/threedofbot_position_controller/commands", ARRAY, command([0.3, 0.2, 0.1]))
        client.step(1000)
        client.sync()
        moved, threedof = latest(states, WITH_SENSOR), latest(states, THREEDOF)
        listed = client.call_service("/controller_manager/list_controllers")
    assert rrbot == pytest.approx([0.5, -0.5], abs=0.01)
    assert idle == pytest.approx([0.0, 0.0], abs=0.01)  # its controller was inactive
    assert moved == pytest.approx([0.5, 0.5], abs=0.01)
    assert threedof == pytest.approx([0.3, 0.2, 0.1], abs=0.01)
    assert external.messages[-1]["header"]["frame_id"] == "rrbot_tool_link"
    assert integrated.messages[-1]["header"]["frame_id"] == "rrbot_with_sensor_tool_link"
    states_of = {c["name"]: c["state"] for c in listed["controller"]}
    assert all(states_of[name] == "active" for name in ACTIVE + INACTIVE)
