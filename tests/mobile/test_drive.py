"""The bundled mobile robot driven over the bridge by a real WebSocket client: diff_drive
on /cmd_vel, encoder odometry on /odom, the true pose on /ground_truth/odom."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import pytest

from harness import Session
from harness.models.mobile import GROUND_TRUTH_SENSOR, MOBILE_CONTROLLERS, load_mobile_bot
from harness.testing import BridgeTestClient, connect

TWIST = "geometry_msgs/msg/Twist"


def _twist(linear: float, angular: float) -> dict[str, Any]:
    return {
        "linear": {"x": linear, "y": 0.0, "z": 0.0},
        "angular": {"x": 0.0, "y": 0.0, "z": angular},
    }


def _yaw(msg: dict[str, Any]) -> float:
    q = msg["pose"]["pose"]["orientation"]
    return math.atan2(2 * (q["w"] * q["z"] + q["x"] * q["y"]), 1 - 2 * (q["y"] ** 2 + q["z"] ** 2))


def _xy(msg: dict[str, Any]) -> tuple[float, float]:
    p = msg["pose"]["pose"]["position"]
    return p["x"], p["y"]


@pytest.fixture
def drive() -> Iterator[tuple[Session, BridgeTestClient]]:
    robot = load_mobile_bot()
    session = Session(robot, controllers=MOBILE_CONTROLLERS, sensors=[GROUND_TRUTH_SENSOR])
    with session, connect(session.url) as client:
        yield session, client


def _hold(client: BridgeTestClient, twist: dict[str, Any], seconds: float) -> None:
    """Send ``twist`` at 20 Hz of simulation time for ``seconds``."""
    for _ in range(round(seconds * 20)):
        client.publish("/cmd_vel", TWIST, twist)
        client.step(25)  # 50 ms at 2 ms steps


def test_straight_at_0_2_m_s_for_2_s_moves_0_4_m(drive: Any) -> None:
    _, client = drive
    odom = client.subscribe("/odom", "nav_msgs/msg/Odometry")
    truth = client.subscribe("/ground_truth/odom", "nav_msgs/msg/Odometry")
    tf = client.subscribe("/tf", "tf2_msgs/msg/TFMessage")
    client.step(50)
    start = _xy(truth.messages[-1])
    _hold(client, _twist(0.2, 0.0), 2.0)
    _hold(client, _twist(0.0, 0.0), 0.5)
    x, y = _xy(odom.messages[-1])
    assert x == pytest.approx(0.4, abs=0.02)
    assert abs(y) < 0.01
    tx, ty = _xy(truth.messages[-1])
    assert math.hypot(tx - start[0], ty - start[1]) == pytest.approx(0.4, abs=0.02)
    assert truth.messages[-1]["child_frame_id"] == "base_link"
    # the floating base's true pose is on /tf as world -> base_link, equal to ground truth
    base = [
        t
        for m in tf.messages
        for t in m["transforms"]
        if (t["header"]["frame_id"], t["child_frame_id"]) == ("world", "base_link")
    ]
    assert base
    latest = base[-1]["transform"]["translation"]
    assert latest["x"] == pytest.approx(tx, abs=1e-3)


def test_a_quarter_turn_in_place(drive: Any) -> None:
    _, client = drive
    odom = client.subscribe("/odom", "nav_msgs/msg/Odometry")
    truth = client.subscribe("/ground_truth/odom", "nav_msgs/msg/Odometry")
    client.step(50)
    start = _yaw(truth.messages[-1])
    _hold(client, _twist(0.0, math.pi / 4), 2.0)
    _hold(client, _twist(0.0, 0.0), 0.5)
    assert math.degrees(_yaw(odom.messages[-1])) == pytest.approx(90.0, abs=2.0)
    turned = math.degrees(_yaw(truth.messages[-1]) - start)
    assert turned == pytest.approx(90.0, abs=2.0)


def test_cmd_vel_timeout_stops_the_robot(drive: Any) -> None:
    _, client = drive
    truth = client.subscribe("/ground_truth/odom", "nav_msgs/msg/Odometry")
    _hold(client, _twist(0.2, 0.0), 1.0)
    client.step(250)  # 0.5 s: the controller's cmd_vel_timeout, no command since
    client.step(100)  # braking
    stopped = _xy(truth.messages[-1])
    client.step(250)
    later = _xy(truth.messages[-1])
    assert math.hypot(later[0] - stopped[0], later[1] - stopped[1]) < 0.002
    assert stopped[0] > 0.15
