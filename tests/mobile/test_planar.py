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


@pytest.mark.slow
def test_planar_base_moves_0_4_m_and_replays_bit_exactly(tmp_path: Path) -> None:
    controllers = tmp_path / "planar.yaml"
    controllers.write_text(PLANAR_YAML)
    path = tmp_path / "planar.mcap"
    robot = load_mobile_bot()
    session = Session(robot, controllers=controllers, sensors=[GROUND_TRUTH_SENSOR], record_to=path)
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


PLANAR_PLUGIN = """
  <gazebo>
    <plugin name="object_controller" filename="libgazebo_ros_planar_move.so">
      <ros><remapping>cmd_vel:=base_cmd</remapping><remapping>odom:=base_odom</remapping></ros>
      <odometry_frame>odom</odometry_frame>
      <robot_base_frame>base_footprint</robot_base_frame>
      <publish_rate>20</publish_rate>
    </plugin>
  </gazebo>
"""


def test_the_planar_move_plugin_tag_drives_the_floating_base(tmp_path: Path) -> None:
    import re
    import warnings

    from harness.models import load_robot
    from harness.models.mobile import MOBILE_URDF, MOBILE_WORLD

    text = re.sub(
        r"<ros2_control.*</ros2_control>", PLANAR_PLUGIN, MOBILE_URDF.read_text(), flags=re.DOTALL
    )
    urdf = tmp_path / "planar_bot.urdf"
    urdf.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(urdf, scene=MOBILE_WORLD, base="floating")
    with (
        Session(robot, sensors=[GROUND_TRUTH_SENSOR]) as session,
        connect(session.url) as client,
    ):
        truth = client.subscribe("/ground_truth/odom", "nav_msgs/msg/Odometry")
        odom = client.subscribe("/base_odom", "nav_msgs/msg/Odometry")
        client.step(10)
        start = _xy(truth.messages[-1])
        client.publish("/base_cmd", TWIST, _twist(0.0, 0.0, math.pi / 4))
        client.step(1000)  # the plugin holds the last command: 2 s at pi/4 rad/s
        client.publish("/base_cmd", TWIST, _twist(0.0, 0.0, 0.0))
        client.step(50)
        end = _xy(truth.messages[-1])
        q = truth.messages[-1]["pose"]["pose"]["orientation"]
        assert odom.messages
    yaw = math.atan2(2 * (q["w"] * q["z"] + q["x"] * q["y"]), 1 - 2 * (q["y"] ** 2 + q["z"] ** 2))
    assert yaw == pytest.approx(math.pi / 2, abs=math.radians(1))
    assert math.hypot(end[0] - start[0], end[1] - start[1]) < 1e-3
