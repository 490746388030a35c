"""ros2_control_demos' examples the harness cannot run whole: each ends in a one-line refusal
naming what it lacks (issue 34: 7 its own C++ controller, 10 a GPIO controller, 12 and 16
chained controllers, 15 several controller managers). What they share with the driven
examples still runs: example 10's forward position controller, example 15's robot in its
namespace."""

from __future__ import annotations

import pytest

from harness.controllers import ControllersConfigError, load_controllers, make_controller
from harness.testing import connect
from tests.controllers.demos.demos import command, config_path, controllers, latest, session

ARRAY = "std_msgs/msg/Float64MultiArray"


def test_example_7_its_own_controller_is_one_line_naming_its_type() -> None:
    # the r6bot's meshes are not vendored: the refusal comes from the controllers file alone
    config = load_controllers(config_path(7, "r6bot_controller.yaml"))
    (spec,) = [s for s in config.controllers if s.name == "r6bot_controller"]
    joints = [f"joint_{i}" for i in range(1, 7)]
    controller = make_controller(spec, config.source, dict.fromkeys(joints, "position"), joints)
    reason = getattr(controller, "reason", "")
    assert "\n" not in reason
    assert "unknown controller type 'ros2_control_demo_example_7/RobotController'" in reason


def test_example_10_gpio_controller_is_left_unconfigured_and_the_arm_still_moves() -> None:
    spawned = ["joint_state_broadcaster", "forward_position_controller", "gpio_controller"]
    config = controllers(10, "rrbot_controllers.yaml", spawned)
    with session(10, config) as s, connect(s.url) as client:
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        listed = client.call_service("/controller_manager/list_controllers")
        client.step(10)
        client.publish("/forward_position_controller/commands", ARRAY, command([0.5, 0.5]))
        client.step(1000)
        client.sync()
        reached = latest(states, ["joint1", "joint2"])
    state = {c["name"]: c["state"] for c in listed["controller"]}
    assert state["gpio_controller"] == "unconfigured"
    assert state["forward_position_controller"] == "active"
    assert reached == pytest.approx([0.5, 0.5], abs=0.01)
    (spec,) = [c for c in config.controllers if c.name == "gpio_controller"]
    reason = getattr(make_controller(spec, config.source, {}, []), "reason", "")
    assert "\n" not in reason
    assert "unknown controller type 'gpio_controllers/GpioCommandController'" in reason


@pytest.mark.parametrize(
    ("example", "yaml", "chained"),
    [
        (12, "rrbot_chained_controllers.yaml", "position_controller"),
        (16, "diffbot_chained_controllers.yaml", "pid_controller_left_wheel_joint"),
    ],
)
def test_chained_controllers_are_one_line_naming_the_chained_controller(
    example: int, yaml: str, chained: str
) -> None:
    config = controllers(example, yaml)
    base = "floating" if example == 16 else None
    with pytest.raises(ControllersConfigError) as info:
        session(example, config, base=base).close()
    text = str(info.value)
    assert "\n" not in text
    assert f"reference interface of controller {chained!r}" in text
    assert "chained controllers are not supported" in text


def test_example_15_several_controller_managers_are_one_line() -> None:
    path = config_path(15, "multi_controller_manager_rrbot_generic_controllers.yaml")
    with pytest.raises(ControllersConfigError) as info:
        load_controllers(path)
    text = str(info.value)
    assert "\n" not in text
    assert "/rrbot_1/forward_position_controller and /rrbot_2/forward_position_controller" in text
    assert "several controller managers" in text


def test_example_15_one_robot_in_its_namespace_is_driven() -> None:
    # rrbot_namespace.launch.py: example 1's RRBot, its controller manager in /rrbot
    spawned = ["joint_state_broadcaster", "forward_position_controller"]
    config = controllers(15, "rrbot_namespace_controllers.yaml", spawned)
    with session(1, config, namespace="rrbot") as s, connect(s.url) as client:
        states = client.subscribe("/rrbot/joint_states", "sensor_msgs/msg/JointState")
        listed = client.call_service("/rrbot/controller_manager/list_controllers")
        client.step(10)
        client.publish("/rrbot/forward_position_controller/commands", ARRAY, command([0.5, -0.5]))
        client.step(1000)
        client.sync()
        reached = latest(states, ["joint1", "joint2"])
    assert {c["name"] for c in listed["controller"]} == set(spawned)
    assert reached == pytest.approx([0.5, -0.5], abs=0.01)
