"""ros2_control_demos' mobile examples driven as their userdocs drive them: DiffBot (example 2,
``diff_drive_controller`` on ``/cmd_vel``) and the car-like robot (example 11,
``bicycle_steering_controller`` on ``~/reference``), each with its launch file's 10 Hz
controller manager and remappings, odometry and ground truth measured (issue 34)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from harness.testing import BridgeTestClient, connect
from tests.controllers.demos.demos import controllers, latest, session

TRUTH = [{"name": "truth", "type": "ground_truth", "parent": "base_link"}]
STEP = 0.002  # the harness's default time step (s)


def _twist(linear: float, angular: float = 0.0) -> dict[str, Any]:
    twist = {
        "linear": {"x": linear, "y": 0.0, "z": 0.0},
        "angular": {"x": 0.0, "y": 0.0, "z": angular},
    }
    return {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "base_link"}, "twist": twist}


def _xy(msg: dict[str, Any]) -> tuple[float, float]:
    p = msg["pose"]["pose"]["position"]
    return float(p["x"]), float(p["y"])


def _publish_for(
    client: BridgeTestClient, topic: str, msg: dict[str, Any], seconds: float, hz: float
) -> None:
    """``msg`` at ``hz`` of simulation time for ``seconds`` (``ros2 topic pub --rate``)."""
    per = round(1 / hz / STEP)
    for _ in range(round(seconds * hz)):
        client.publish(topic, "geometry_msgs/msg/TwistStamped", msg)
        client.step(per)
    client.sync()


# ----------------------------------------------------------------------------- DiffBot (2)

DIFFBOT_WHEELS = ["left_wheel_joint", "right_wheel_joint"]
WHEEL_RADIUS = 0.015  # the YAML's wheel_radius (m)
WHEEL_LIMIT = 1.0  # the URDF's <limit velocity> of both wheels (rad/s): 0.015 m/s at most


def _diffbot(speed: float, seconds: float) -> tuple[float, float, list[float]]:
    """(odometry travel, true travel, wheel velocities) of DiffBot driven at ``speed`` on
    ``/cmd_vel`` at 10 Hz (the userdoc's rate) for ``seconds``."""
    remap = {"diffbot_base_controller": {"ros__parameters": {"cmd_vel_topic": "/cmd_vel"}}}
    config = controllers(2, "diffbot_controllers.yaml", update_rate=10, extra=remap)
    with session(2, config, base="floating", sensors=TRUTH) as s, connect(s.url) as client:
        truth = client.subscribe("/ground_truth/odom", "nav_msgs/msg/Odometry")
        odom = client.subscribe("/diffbot_base_controller/odom", "nav_msgs/msg/Odometry")
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        client.step(100)  # settle on the floor
        client.sync()
        start, odom_start = _xy(truth.messages[-1])[0], _xy(odom.messages[-1])[0]
        _publish_for(client, "/cmd_vel", _twist(speed), seconds, 10)
        end, odom_end = _xy(truth.messages[-1])[0], _xy(odom.messages[-1])[0]
        wheels = latest(states, DIFFBOT_WHEELS, "velocity")
    return odom_end - odom_start, end - start, wheels


def test_diffbot_at_0_01_m_s_for_5_s_travels_0_05_m_by_odometry_and_truth() -> None:
    odom, truth, wheels = _diffbot(0.01, 5.0)
    assert wheels == pytest.approx([0.01 / WHEEL_RADIUS] * 2, rel=0.01)
    assert odom == pytest.approx(0.05, rel=0.05)
    assert truth == pytest.approx(0.05, rel=0.05)


def test_diffbot_at_0_1_m_s_is_held_to_its_urdf_wheel_limit() -> None:
    # the 0.1 m/s needs 6.7 rad/s wheels; DiffBot's URDF allows 1 rad/s (0.015 m/s):
    # the wheels turn at the limit while the open-loop odometry integrates the command
    odom, truth, wheels = _diffbot(0.1, 5.0)
    assert wheels == pytest.approx([WHEEL_LIMIT] * 2, abs=0.01)
    assert odom == pytest.approx(0.5, rel=0.05)
    assert 0 < truth <= WHEEL_LIMIT * WHEEL_RADIUS * 5.0


# ------------------------------------------------------------------------ CarlikeBot (11)

WHEELBASE = 0.325  # the YAML's wheelbase (m)
TRACTION_RADIUS = 0.05  # the YAML's traction_wheel_radius (m)


def _circle(points: np.ndarray) -> float:
    """The radius of the least-squares circle through ``points`` (n x 2)."""
    a = np.c_[2 * points[:, 0], 2 * points[:, 1], np.ones(len(points))]
    b = (points**2).sum(axis=1)
    cx, cy, k = np.linalg.lstsq(a, b, rcond=None)[0]
    return float(math.sqrt(k + cx * cx + cy * cy))


def test_carlikebot_turns_on_the_bicycle_model_radius_of_its_wheelbase() -> None:
    spawned = ["joint_state_broadcaster", "bicycle_steering_controller"]
    config = controllers(11, "carlikebot_controllers.yaml", spawned)
    steer = 0.3  # rad, inside the URDF's +-0.4 limit of the steering joint
    v = 0.5
    w = v * math.tan(steer) / WHEELBASE  # the twist whose bicycle steering angle is `steer`
    with session(11, config, base="floating", sensors=TRUTH) as s, connect(s.url) as client:
        odom = client.subscribe("/bicycle_steering_controller/odometry", "nav_msgs/msg/Odometry")
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        client.step(250)
        _publish_for(client, "/bicycle_steering_controller/reference", _twist(v, w), 1.0, 30)
        first = len(odom.messages)
        _publish_for(client, "/bicycle_steering_controller/reference", _twist(v, w), 5.0, 30)
        track = np.array([_xy(m) for m in odom.messages[first:]])
        steering, wheel = (
            latest(states, ["virtual_front_wheel_joint", "virtual_rear_wheel_joint"])[0],
            latest(states, ["virtual_rear_wheel_joint"], "velocity")[0],
        )
    # the controller's commands: the bicycle model's angle and v / r
    assert steering == pytest.approx(steer, abs=0.01)
    assert wheel == pytest.approx(v / TRACTION_RADIUS, rel=0.02)
    # its odometry (from the measured wheel velocity and steering angle) circles on
    # R = wheelbase / tan(steering)
    assert _circle(track) == pytest.approx(WHEELBASE / math.tan(steer), rel=0.05)
