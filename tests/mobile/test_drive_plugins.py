"""Drive plugins in the robot file: Gazebo Classic's libgazebo_ros_diff_drive.so and gz-sim's
DiffDrive system become a diff drive controller on the plugin's topics, its wheels velocity
driven, with no controllers YAML."""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path
from typing import Any

import pytest

from harness import Session
from harness.models import load_robot
from harness.models.mobile import MOBILE_URDF, MOBILE_WORLD
from harness.testing import connect

CLASSIC = """
  <gazebo>
    <plugin name="wheels" filename="libgazebo_ros_diff_drive.so">
      <left_joint>left_wheel_joint</left_joint>
      <right_joint>right_wheel_joint</right_joint>
      <wheel_separation>0.16</wheel_separation>
      <wheel_diameter>0.066</wheel_diameter>
      <command_topic>cmd_vel</command_topic>
      <odometry_topic>wheel_odom</odometry_topic>
      <robot_base_frame>base_link</robot_base_frame>
      <update_rate>20</update_rate>
    </plugin>
  </gazebo>
"""
GZ = """
  <gazebo>
    <plugin filename="gz-sim-diff-drive-system" name="gz::sim::systems::DiffDrive">
      <left_joint>left_wheel_joint</left_joint>
      <right_joint>right_wheel_joint</right_joint>
      <wheel_separation>0.16</wheel_separation>
      <wheel_radius>0.033</wheel_radius>
      <topic>cmd_vel</topic>
      <odom_topic>wheel_odom</odom_topic>
    </plugin>
  </gazebo>
"""


def _robot_with(plugin: str, folder: Path) -> Path:
    text = MOBILE_URDF.read_text()
    text = re.sub(r"<ros2_control.*</ros2_control>", plugin, text, flags=re.DOTALL)
    path = folder / "plugin_bot.urdf"
    path.write_text(text)
    return path


@pytest.mark.parametrize("plugin", [CLASSIC, GZ], ids=["classic", "gz-sim"])
def test_a_drive_plugin_drives_the_robot(plugin: str, tmp_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(_robot_with(plugin, tmp_path), scene=MOBILE_WORLD, base="floating")
    assert dict(robot.control) == {"left_wheel_joint": "velocity", "right_wheel_joint": "velocity"}
    twist: dict[str, Any] = {
        "linear": {"x": 0.2, "y": 0, "z": 0},
        "angular": {"x": 0, "y": 0, "z": 0},
    }
    with Session(robot) as session, connect(session.url) as client:
        odom = client.subscribe("/wheel_odom", "nav_msgs/msg/Odometry")
        client.publish("/cmd_vel", "geometry_msgs/msg/Twist", twist)
        client.step(1000)  # the plugins keep the last command: 2 s at 0.2 m/s
        client.publish(
            "/cmd_vel", "geometry_msgs/msg/Twist", {**twist, "linear": {"x": 0, "y": 0, "z": 0}}
        )
        client.step(100)
        position = odom.messages[-1]["pose"]["pose"]["position"]
    assert position["x"] == pytest.approx(0.4, abs=0.02)
    assert math.isclose(position["y"], 0.0, abs_tol=0.01)
