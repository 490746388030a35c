"""A wheeled robot from a public collection (Clearpath's Dingo-D, dd100) driven by its own
controllers YAML (clearpath_control's diff_drive_controller parameters) over the bridge."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import pytest

from harness import Session
from harness.models import load_robot
from harness.testing import connect

DESCRIPTIONS = Path(__file__).resolve().parents[1] / "data" / "descriptions"
DD100 = DESCRIPTIONS / "dd100_robot" / "robot.urdf.xacro"
CONTROL = DESCRIPTIONS / "clearpath_control" / "config" / "dd100" / "control.yaml"
WHEELS = ("front_left_wheel_joint", "front_right_wheel_joint")


def test_dd100_drives_straight_within_1_degree_over_2_m() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the xacro's hardware is replaced; the base set down
        robot = load_robot(DD100, base="floating", gains=dict.fromkeys(WHEELS, 1.0))
    session = Session(
        robot,
        controllers=CONTROL,
        sensors=[{"name": "truth", "type": "ground_truth", "parent": "base_link"}],
    )
    with session, connect(session.url) as client:
        odom = client.subscribe("/platform_velocity_controller/odom", "nav_msgs/msg/Odometry")
        truth = client.subscribe("/ground_truth/odom", "nav_msgs/msg/Odometry")
        client.step(50)
        start = truth.messages[-1]["pose"]["pose"]["position"]
        twist = {"linear": {"x": 0.5, "y": 0.0, "z": 0.0}, "angular": {"x": 0, "y": 0, "z": 0}}
        for _ in range(45):  # 4.5 s at 0.5 m/s (1 m/s^2 acceleration limit): over 2 m
            client.publish(
                "/platform_velocity_controller/cmd_vel", "geometry_msgs/msg/Twist", twist
            )
            client.step(50)
        end = truth.messages[-1]["pose"]["pose"]["position"]
        wheel_odom = odom.messages[-1]["pose"]["pose"]["position"]
    dx, dy = end["x"] - start["x"], end["y"] - start["y"]
    assert math.hypot(dx, dy) > 2.0
    assert abs(math.degrees(math.atan2(dy, dx))) < 1.0
    assert wheel_odom["x"] == pytest.approx(dx, abs=0.05)
