"""ros2_control_demos' RRBot examples driven as their userdocs drive them: the forward command
controller's ``commands`` topic moves both joints to the commanded positions (or velocities),
measured on ``/joint_states`` (issue 34)."""

from __future__ import annotations

import pytest

from harness.testing import connect
from tests.controllers.demos.demos import command, controllers, latest, session

JOINTS = ["joint1", "joint2"]
FORWARD = "forward_command_controller/ForwardCommandController"

SPAWNED = ["joint_state_broadcaster", "forward_position_controller"]
# example -> (controllers YAML, the launch file's update_rate, its $(var) arguments); example 8's
# transmissions (reductions 2 and 4) are ignored as gz_ros2_control ignores them: the joint
# reaches the joint-space command
POSITION_EXAMPLES = {
    1: ("rrbot_controllers.yaml", 10, {"joint_prefix": "joint"}),
    6: ("rrbot_modular_actuators.yaml", None, None),
    8: ("rrbot_controllers.yaml", None, None),
    9: ("rrbot_controllers.yaml", None, None),
    17: ("rrbot_controllers.yaml", None, None),
}
GOAL = [0.785, -0.785]  # pos1 of the examples' rrbot_forward_position_publisher.yaml, mirrored


@pytest.mark.parametrize("example", sorted(POSITION_EXAMPLES))
def test_forward_position_command_reaches_its_target(example: int) -> None:
    name, rate, args = POSITION_EXAMPLES[example]
    config = controllers(example, name, SPAWNED, rate, args)
    with session(example, config) as s, connect(s.url) as client:
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        listed = client.call_service("/controller_manager/list_controllers")
        client.step(10)
        client.publish(
            "/forward_position_controller/commands", "std_msgs/msg/Float64MultiArray", command(GOAL)
        )
        client.step(1500)  # 3 s: the joints' 1 rad/s limit
        client.sync()
        reached = latest(states, JOINTS)
    active = {c["name"]: c["type"] for c in listed["controller"] if c["state"] == "active"}
    assert active["forward_position_controller"] == FORWARD
    assert reached == pytest.approx(GOAL, abs=0.01)


def test_example_3_forward_velocity_controller_turns_the_joints_at_the_command() -> None:
    # the launch file's default robot_controller; the YAML's acceleration controller is not spawned
    spawned = ["joint_state_broadcaster", "forward_velocity_controller"]
    config = controllers(3, "rrbot_multi_interface_forward_controllers.yaml", spawned)
    # the joints declare position, velocity and acceleration command interfaces; the harness
    # picks a joint's mode at load (the first declared, position): the spawned controller's
    # interface is given, as ros2_control's command mode switch would set it on activation
    velocity = {j: "velocity" for j in JOINTS}
    with session(3, config, control=velocity) as s, connect(s.url) as client:
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        client.step(10)
        client.sync()
        start = latest(states, JOINTS)
        client.publish(
            "/forward_velocity_controller/commands",
            "std_msgs/msg/Float64MultiArray",
            command([0.5, -0.5]),
        )
        client.step(1000)  # 2 s
        client.sync()
        end = latest(states, JOINTS)
        velocity = latest(states, JOINTS, "velocity")
    assert velocity == pytest.approx([0.5, -0.5], abs=0.01)
    travelled = [e - s for e, s in zip(end, start, strict=True)]
    assert travelled == pytest.approx([1.0, -1.0], rel=0.05)


def test_example_14_forward_velocity_without_position_feedback() -> None:
    spawned = ["joint_state_broadcaster", "forward_velocity_controller"]
    name = "rrbot_modular_actuators_without_feedback_sensors_for_position_feedback.yaml"
    config = controllers(14, name, spawned)
    with session(14, config) as s, connect(s.url) as client:
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        client.step(100)  # a /joint_states message at the manager's first cycles (10 Hz)
        client.sync()
        start = latest(states, JOINTS)
        client.publish(
            "/forward_velocity_controller/commands",
            "std_msgs/msg/Float64MultiArray",
            command([0.3, 0.3]),
        )
        client.step(1000)
        client.sync()
        end = latest(states, JOINTS)
    travelled = [e - s for e, s in zip(end, start, strict=True)]
    assert travelled == pytest.approx([0.6, 0.6], rel=0.05)
