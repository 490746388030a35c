"""A ``<ros2_control>`` ``<sensor>`` entry (IMU or force-torque state interfaces, a
``frame_id`` link) is simulated as gz_ros2_control simulates it, so the ros2_controllers
broadcasters read it (issue 34: the harness read only Gazebo/SDF sensor tags)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import pytest

from harness import Session
from harness.models import load_robot
from harness.replay.pipeline import replay_pipeline
from harness.testing import connect

PAIR = Path(__file__).resolve().parents[1] / "data" / "controllers" / "mimic" / "mimic_pair.urdf"
IMU_BLOCK = """
  <ros2_control name="imu_hardware" type="sensor">
    <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
    <sensor name="base_imu">
      <state_interface name="orientation.x"/><state_interface name="orientation.y"/>
      <state_interface name="orientation.z"/><state_interface name="orientation.w"/>
      <state_interface name="angular_velocity.x"/><state_interface name="angular_velocity.y"/>
      <state_interface name="angular_velocity.z"/>
      <state_interface name="linear_acceleration.x"/>
      <state_interface name="linear_acceleration.y"/>
      <state_interface name="linear_acceleration.z"/>
      <param name="frame_id">arm_a</param>
    </sensor>
  </ros2_control>
</robot>"""
YAML = """
controller_manager:
  ros__parameters:
    update_rate: 50
    imu_sensor_broadcaster:
      type: imu_sensor_broadcaster/IMUSensorBroadcaster
imu_sensor_broadcaster:
  ros__parameters:
    sensor_name: base_imu
    frame_id: arm_a
"""


def test_an_imu_sensor_entry_feeds_the_imu_sensor_broadcaster(tmp_path: Path) -> None:
    urdf = tmp_path / "imu_robot.urdf"
    urdf.write_text(PAIR.read_text("utf-8").replace("</robot>", IMU_BLOCK))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(urdf)
    path = tmp_path / "imu.mcap"
    with (
        Session(robot, controllers=YAML, record_to=path) as session,
        connect(session.url) as client,
    ):
        imu = client.subscribe("/imu_sensor_broadcaster/imu", "sensor_msgs/msg/Imu")
        listed = client.call_service("/controller_manager/list_controllers")
        session.command("leader", position=0.8)  # arm_a turns about z
        client.step(500)
        client.sync()
    (entry,) = listed["controller"]
    assert entry["state"] == "active"
    msg = imu.messages[-1]
    assert msg["header"]["frame_id"] == "arm_a"
    q = msg["orientation"]
    assert 2 * math.atan2(q["z"], q["w"]) == pytest.approx(0.8, abs=0.01)  # the link's yaw
    assert msg["linear_acceleration"]["z"] == pytest.approx(9.81, rel=0.01)  # at rest: gravity
    assert len(imu.messages) >= 15  # 50 Hz over 1 s (subscribed after the start)
    # the sensor is rebuilt from the recorded description: the run replays bit for bit
    report = replay_pipeline(path)
    assert report.reproduced, report.format()
