"""The planar (holonomic) base controller: /cmd_vel applied directly to the floating base as a
recorded kinematic write, so a run replays bit for bit."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from harness import Session
from harness.models.mobile import GROUND_TRUTH_SENSOR, load_mobile_bot
from harness.replay import verify
from harness.testing import BridgeTestClient, connect

TWIST = "geometry_msgs/msg/Twist"

PLANAR_YAML = """
controller_manager:
  ros__parameters:
    update_rate: 100
    planar_base:
      type: planar_controller/PlanarController
planar_base:
  ros__parameters:
    use_stamped_vel: false
    cmd_vel_topic: /cmd_vel
    odom_topic: /odom
    enable_odom_tf: false
    cmd_vel_timeout: 0.5
"""


def _twist(x: float, y: float, yaw: float) -> dict[str, Any]:
    return {"linear": {"x": x, "y": y, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": yaw}}


def _hold(client: BridgeTestClient, twist: dict[str, Any], seconds: float) -> None:
    for _ in range(round(seconds * 20)):
        client.publish("/cmd_vel", TWIST, twist)
        client.step(25)  # 50 ms at 2 ms steps


def _xy(msg: dict[str, Any]) -> tuple[float, float]:
    p = msg["pose"]["pose"]["position"]
    return p["x"], p["y"]


def test_planar_base_moves_0_4_m_and_replays_bit_exactly(tmp_path: Path) -> None:
    controllers = tmp_path / "planar.yaml"
    controllers.write_text(PLANAR_YAML)
    path = tmp_path / "planar.mcap"
    robot = load_mobile_bot()
    session = Session(
        robot, controllers=controllers, sensors=[GROUND_TRUTH_SENSOR], record_to=path
    )
    with session, connect(session.url) as client:
        truth = client.subscribe("/ground_truth/odom", "nav_msgs/msg/Odometry")
        odom = client.subscribe("/odom", "nav_msgs/msg/Odometry")
        client.step(50)
        start = _xy(truth.messages[-1])
        _hold(client, _twist(0.2, 0.0, 0.0), 2.0)
        _hold(client, _twist(0.0, 0.0, 0.0), 0.3)
        end = _xy(truth.messages[-1])
        # sideways too: holonomic
        _hold(client, _twist(0.0, 0.1, 0.0), 1.0)
        _hold(client, _twist(0.0, 0.0, 0.0), 0.3)
        side = _xy(truth.messages[-1])
        odom_end = _xy(odom.messages[-1])
    assert math.hypot(end[0] - start[0], end[1] - start[1]) == pytest.approx(0.4, abs=0.005)
    assert side[1] - end[1] == pytest.approx(0.1, abs=0.005)
    assert abs(side[0] - end[0]) < 1e-6
    assert odom_end[0] == pytest.approx(0.4, abs=0.005)
    assert odom_end[1] == pytest.approx(0.1, abs=0.005)
    report = verify(path)
    assert report.reproduced, report
    from harness.cli import main

    assert main(["replay", str(path)]) == 0
