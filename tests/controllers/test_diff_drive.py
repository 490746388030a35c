"""diff_drive_controller semantics, sans-I/O: wheel speeds, odometry from encoders, timeout,
limits, publications. The 'robot' is ideal wheels that turn exactly as commanded."""

from __future__ import annotations

import math
from typing import Any

import pytest

from harness.controllers.base import JointReadings
from harness.controllers.config import ControllerSpec
from harness.controllers.diff_drive import TYPE_DIFF_DRIVE, DiffDriveController
from harness.controllers.errors import ControllersConfigError

PERIOD = 10_000_000  # 100 Hz
WHEELS = {"fl": "velocity", "rl": "velocity", "fr": "velocity", "rr": "velocity"}


def _controller(**params: Any) -> DiffDriveController:
    base = {
        "left_wheel_names": ["fl", "rl"],
        "right_wheel_names": ["fr", "rr"],
        "wheel_separation": 0.3,
        "wheel_radius": 0.05,
        "use_stamped_vel": False,
        "publish_rate": 10.0,
    }
    base.update(params)
    return DiffDriveController(ControllerSpec("diff_drive", TYPE_DIFF_DRIVE, base), "test", WHEELS)


class IdealWheels:
    def __init__(self) -> None:
        self.position = dict.fromkeys(WHEELS, 0.0)
        self.velocity = dict.fromkeys(WHEELS, 0.0)
        self.time = 0

    def readings(self) -> JointReadings:
        return JointReadings(self.time, dict(self.position), dict(self.velocity), {})

    def run(self, ctrl: DiffDriveController, seconds: float) -> list[Any]:
        published = []
        for _ in range(round(seconds * 1e9 / PERIOD)):
            out = ctrl.update(self.readings(), PERIOD)
            for command in out.commands:
                assert command.velocity is not None
                self.velocity[command.joint] = command.velocity
            published += out.publications
            self.time += PERIOD
            for joint, speed in self.velocity.items():
                self.position[joint] += speed * PERIOD / 1e9
        return published


def _twist(linear: float, angular: float) -> dict[str, Any]:
    return {"linear": {"x": linear, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": angular}}


def test_straight_drive_gives_wheel_speeds_and_odometry() -> None:
    ctrl, wheels = _controller(cmd_vel_timeout=10.0), IdealWheels()
    ctrl.activate(wheels.readings())
    ctrl.on_message("~/cmd_vel", _twist(0.2, 0.0), 1, wheels.readings())
    published = wheels.run(ctrl, 2.01)
    assert wheels.velocity["fl"] == pytest.approx(0.2 / 0.05)
    assert wheels.velocity["rr"] == pytest.approx(0.2 / 0.05)
    odom = [p for p in published if p.topic == "~/odom"][-1].msg
    # encoder travel lags the command by one update: 2.0 s of motion at the last publication
    assert odom["pose"]["pose"]["position"]["x"] == pytest.approx(0.4, abs=0.003)
    assert odom["child_frame_id"] == "base_link"
    assert any(p.topic == "/tf" for p in published)


def test_turn_in_place_integrates_the_heading() -> None:
    ctrl, wheels = _controller(cmd_vel_timeout=10.0), IdealWheels()
    ctrl.activate(wheels.readings())
    ctrl.on_message("~/cmd_vel", _twist(0.0, math.pi / 4), 1, wheels.readings())
    wheels.run(ctrl, 2.0)
    assert wheels.velocity["fl"] == pytest.approx(-math.pi / 4 * 0.15 / 0.05)
    ctrl.update(wheels.readings(), PERIOD)
    assert ctrl.odometry.heading == pytest.approx(math.pi / 2, abs=1e-9)
    assert math.hypot(ctrl.odometry.x, ctrl.odometry.y) < 1e-9


def test_an_arc_follows_the_circle() -> None:
    ctrl, wheels = _controller(cmd_vel_timeout=10.0), IdealWheels()
    ctrl.activate(wheels.readings())
    ctrl.on_message("~/cmd_vel", _twist(0.5, 0.5), 1, wheels.readings())
    wheels.run(ctrl, 3.0)
    ctrl.update(wheels.readings(), PERIOD)
    heading = ctrl.odometry.heading  # radius 1 m circle about (0, 1)
    assert ctrl.odometry.x == pytest.approx(math.sin(heading), abs=1e-9)
    assert ctrl.odometry.y == pytest.approx(1 - math.cos(heading), abs=1e-9)


def test_the_wheels_stop_after_cmd_vel_timeout() -> None:
    ctrl, wheels = _controller(cmd_vel_timeout=0.25), IdealWheels()
    ctrl.activate(wheels.readings())
    ctrl.on_message("~/cmd_vel", _twist(0.2, 0.0), 1, wheels.readings())
    wheels.run(ctrl, 0.2)
    assert wheels.velocity["fl"] > 0
    wheels.run(ctrl, 0.1)
    assert wheels.velocity["fl"] == 0.0


def test_velocity_and_acceleration_limits_clamp_the_command() -> None:
    ctrl = _controller(
        cmd_vel_timeout=10.0,
        linear={"x": {"max_velocity": 0.3, "max_acceleration": 1.0}},
    )
    wheels = IdealWheels()
    ctrl.activate(wheels.readings())
    ctrl.on_message("~/cmd_vel", _twist(2.0, 0.0), 1, wheels.readings())
    wheels.run(ctrl, 0.1)
    assert ctrl.applied[0] == pytest.approx(0.1)  # 1 m/s^2 for 0.1 s
    wheels.run(ctrl, 1.0)
    assert ctrl.applied[0] == pytest.approx(0.3)


def test_a_stamped_command_and_a_bad_one() -> None:
    ctrl, wheels = _controller(use_stamped_vel=True), IdealWheels()
    assert ctrl.subscriptions[0].type == "geometry_msgs/msg/TwistStamped"
    ctrl.activate(wheels.readings())
    out = ctrl.on_message("~/cmd_vel", {"twist": {"linear": {}}}, 3, wheels.readings())
    assert out.logs[0].connection == 3
    assert "refused" in out.logs[0].text
    ctrl.on_message("~/cmd_vel", {"header": {}, "twist": _twist(0.1, 0)}, 3, wheels.readings())
    assert ctrl.wanted == (0.1, 0.0)


def test_missing_geometry_is_a_config_error() -> None:
    with pytest.raises(ControllersConfigError, match="wheel_separation"):
        _controller(wheel_separation=0.0)
    with pytest.raises(ControllersConfigError, match="'nope'"):
        _controller(left_wheel_names=["nope"])


def test_skid_steer_velocity_feedback_integrates_the_wheel_speeds() -> None:
    # position_feedback: false reads the wheels' velocity interfaces (ros2_controllers'
    # updateFromVelocity), not the command: a wheel slower than commanded shows in the odometry
    ctrl, wheels = _controller(cmd_vel_timeout=10.0, position_feedback=False), IdealWheels()
    assert ctrl.state_interfaces == ("fl/velocity", "rl/velocity", "fr/velocity", "rr/velocity")
    ctrl.activate(wheels.readings())
    ctrl.on_message("~/cmd_vel", _twist(0.2, 0.0), 1, wheels.readings())
    published = []
    for _ in range(200):  # 2 s; the rear wheels turn at half the command (slip on that axle)
        out = ctrl.update(wheels.readings(), PERIOD)
        for command in out.commands:
            assert command.velocity is not None
            factor = 0.5 if command.joint in ("rl", "rr") else 1.0
            wheels.velocity[command.joint] = command.velocity * factor
        published += out.publications
        wheels.time += PERIOD
    odom = [p for p in published if p.topic == "~/odom"][-1].msg
    # the mean per side is 0.75 of the command: 0.15 m/s over the 1.9 s before the last publication
    assert odom["pose"]["pose"]["position"]["x"] == pytest.approx(0.15 * 1.9, rel=0.02)


def test_sides_with_different_wheel_counts_are_refused_as_ros2_controllers_does() -> None:
    with pytest.raises(ControllersConfigError) as info:
        _controller(left_wheel_names=["fl", "rl"], right_wheel_names=["fr"])
    assert "the number of left wheels [2] and the number of right wheels [1] are different" in str(
        info.value
    )


def test_wheels_per_side_is_read_and_the_name_lists_decide() -> None:
    ctrl, wheels = _controller(cmd_vel_timeout=10.0, wheels_per_side=1), IdealWheels()
    ctrl.activate(wheels.readings())
    ctrl.on_message("~/cmd_vel", _twist(0.2, 0.0), 1, wheels.readings())
    wheels.run(ctrl, 0.5)
    assert wheels.velocity["rl"] == wheels.velocity["fl"] == pytest.approx(0.2 / 0.05)
    with pytest.raises(ControllersConfigError, match="wheels_per_side must be a number"):
        _controller(wheels_per_side="two")
