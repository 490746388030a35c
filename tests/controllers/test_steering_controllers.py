"""The steering controllers (bicycle, tricycle, Ackermann: ros2_controllers'
steering_controllers_library), sans-I/O: the commands of a reference, the odometry of ideal
joints that do as commanded, the reference timeout, configuration errors (issue 34)."""

from __future__ import annotations

import math
from typing import Any

import pytest

from harness.controllers import ControllersConfigError, ControllerSpec, RobotInterfaces, known_types
from harness.controllers.base import Controller, JointReadings
from harness.controllers.registry import factory_of

PERIOD = 10_000_000  # 100 Hz
BICYCLE = "bicycle_steering_controller/BicycleSteeringController"
TRICYCLE = "tricycle_steering_controller/TricycleSteeringController"
ACKERMANN = "ackermann_steering_controller/AckermannSteeringController"
JOINTS = {
    "rear": "velocity", "rear_right": "velocity", "rear_left": "velocity",
    "front": "position", "front_right": "position", "front_left": "position",
}  # fmt: skip


def _build(type: str, **params: Any) -> Controller:
    spec = ControllerSpec("steering", type, {"reference_timeout": 10.0, **params})
    return factory_of(type)(spec, RobotInterfaces("test.yaml", JOINTS, tuple(JOINTS)))


def _reference(v: float, w: float) -> dict[str, Any]:
    twist = {"linear": {"x": v, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": w}}
    return {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""}, "twist": twist}


class IdealJoints:
    """Joints that take their command at once (steering) or turn at it (traction)."""

    def __init__(self) -> None:
        self.position = dict.fromkeys(JOINTS, 0.0)
        self.velocity = dict.fromkeys(JOINTS, 0.0)
        self.time = 0

    def readings(self) -> JointReadings:
        return JointReadings(self.time, dict(self.position), dict(self.velocity), {})

    def run(self, ctrl: Controller, seconds: float) -> list[Any]:
        published: list[Any] = []
        for _ in range(round(seconds * 1e9 / PERIOD)):
            out = ctrl.update(self.readings(), PERIOD)
            for c in out.commands:
                if c.velocity is not None:
                    self.velocity[c.joint] = c.velocity
                if c.position is not None:
                    self.position[c.joint] = c.position
            published += out.publications
            self.time += PERIOD
            for joint, mode in JOINTS.items():
                if mode == "velocity":
                    self.position[joint] += self.velocity[joint] * PERIOD / 1e9
        return published


def _circle_radius(published: list[Any]) -> float:
    """The radius of the circle through three odometry poses (first, middle, last)."""
    poses = [p.msg["pose"]["pose"]["position"] for p in published if p.topic == "~/odometry"]
    (x1, y1), (x2, y2), (x3, y3) = [
        (q["x"], q["y"]) for q in (poses[0], poses[len(poses) // 2], poses[-1])
    ]
    a = math.dist((x1, y1), (x2, y2))
    b = math.dist((x2, y2), (x3, y3))
    c = math.dist((x1, y1), (x3, y3))
    area = abs((x2 - x1) * (y3 - y1) - (x3 - x1) * (y2 - y1)) / 2
    return a * b * c / (4 * area)


def test_the_three_types_are_registered() -> None:
    assert {BICYCLE, TRICYCLE, ACKERMANN} <= set(known_types())


def test_bicycle_commands_are_the_example_11_userdoc_s() -> None:
    # example_11's YAML and its userdoc's reference (1 m/s, 0.1 rad/s): the hardware logs
    # "position: 0.03 for joint 'virtual_front_wheel_joint', velocity: 20.00 for ... rear"
    ctrl = _build(
        BICYCLE, traction_joints_names=["rear"], steering_joints_names=["front"],
        wheelbase=0.325, traction_wheel_radius=0.05,
    )  # fmt: skip
    joints = IdealJoints()
    ctrl.activate(joints.readings())
    ctrl.on_message("~/reference", _reference(1.0, 0.1), 1, joints.readings())
    published = joints.run(ctrl, 2.0)
    assert joints.velocity["rear"] == pytest.approx(20.0)
    assert joints.position["front"] == pytest.approx(math.atan(0.1 * 0.325 / 1.0))
    assert ctrl.command_interfaces == ("rear/velocity", "front/position")
    assert ctrl.state_interfaces == ("rear/velocity", "front/position")  # position_feedback false
    assert {p.topic for p in published} == {"~/odometry", "~/tf_odometry"}
    assert _circle_radius(published) == pytest.approx(10.0, rel=0.01)


def test_tricycle_spreads_the_speed_over_its_axle_and_circles_on_the_model_radius() -> None:
    ctrl = _build(
        TRICYCLE, traction_joints_names=["rear_right", "rear_left"],
        steering_joints_names=["front"], wheelbase=0.5, traction_track_width=0.4,
        traction_wheels_radius=0.1,
    )  # fmt: skip
    joints = IdealJoints()
    ctrl.activate(joints.readings())
    steer = 0.4
    v = 0.5
    ctrl.on_message("~/reference", _reference(v, v * math.tan(steer) / 0.5), 1, joints.readings())
    published = joints.run(ctrl, 3.0)
    radius = 0.5 / math.tan(steer)
    assert joints.position["front"] == pytest.approx(steer)
    assert joints.velocity["rear_right"] == pytest.approx(v / 0.1 * (radius + 0.2) / radius)
    assert joints.velocity["rear_left"] == pytest.approx(v / 0.1 * (radius - 0.2) / radius)
    assert _circle_radius(published) == pytest.approx(radius, rel=0.01)


def test_ackermann_steers_each_wheel_about_one_centre_of_rotation() -> None:
    ctrl = _build(
        ACKERMANN,
        traction_joints_names=["rear_right", "rear_left"],
        steering_joints_names=["front_right", "front_left"],
        wheelbase=0.5, traction_track_width=0.4, steering_track_width=0.4,
        traction_wheels_radius=0.1,
    )  # fmt: skip
    joints = IdealJoints()
    ctrl.activate(joints.readings())
    steer = 0.3
    v = 0.5
    ctrl.on_message("~/reference", _reference(v, v * math.tan(steer) / 0.5), 1, joints.readings())
    published = joints.run(ctrl, 3.0)
    right, left = joints.position["front_right"], joints.position["front_left"]
    assert left > steer > right  # a left turn: the inner (left) wheel steers more
    # both wheels' axes meet at the turning centre: their radii differ by the track
    assert 0.5 / math.tan(right) - 0.5 / math.tan(left) == pytest.approx(0.4)
    assert _circle_radius(published) == pytest.approx(0.5 / math.tan(steer), rel=0.01)


def test_the_traction_stops_after_the_reference_timeout() -> None:
    ctrl = _build(
        BICYCLE, traction_joints_names=["rear"], steering_joints_names=["front"],
        wheelbase=0.325, traction_wheel_radius=0.05, reference_timeout=0.5,
    )  # fmt: skip
    joints = IdealJoints()
    ctrl.activate(joints.readings())
    ctrl.on_message("~/reference", _reference(1.0, 0.5), 1, joints.readings())
    joints.run(ctrl, 0.4)
    assert joints.velocity["rear"] == pytest.approx(20.0)
    joints.run(ctrl, 0.2)
    assert joints.velocity["rear"] == 0.0
    assert joints.position["front"] == pytest.approx(math.atan(0.5 * 0.325))  # keeps its angle


ONE_ONE = {"traction_joints_names": ["rear"], "steering_joints_names": ["front"]}
AXLE = {"wheelbase": 0.5, "traction_track_width": 0.4, "traction_wheels_radius": 0.1}


@pytest.mark.parametrize(
    ("type", "params", "message"),
    [
        (BICYCLE, {**ONE_ONE, "traction_wheel_radius": 0.05}, "wheelbase"),
        (TRICYCLE, {**ONE_ONE, **AXLE}, "traction_joints_names must name 2 joint(s), not 1"),
        (
            BICYCLE,
            {**ONE_ONE, "traction_joints_names": ["nope"], "wheelbase": 0.3,
             "traction_wheel_radius": 0.05},
            "joint 'nope' is not a controllable joint",
        ),
    ],
)  # fmt: skip
def test_a_bad_configuration_is_one_line(type: str, params: dict[str, Any], message: str) -> None:
    with pytest.raises(ControllersConfigError) as info:
        _build(type, **params)
    text = str(info.value)
    assert "\n" not in text
    assert message in text
    assert "controller 'steering'" in text
