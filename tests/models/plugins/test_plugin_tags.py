"""The robot file's own simulation tags are the launch (issue 34): a ros2_control plugin tag's
``<parameters>`` are the controllers, with its remappings; a drive plugin's and a sensor
plugin's ``<ros><namespace>``, ``<remapping>``, ROS 1 spellings and rates; ground truth
odometry whenever a base controller runs. Each test drives a real session in lockstep and
counts messages in simulation time."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from harness.models.mobile import MOBILE_CONTROLLERS, MOBILE_URDF
from harness.session import Session
from harness.testing import connect

ODOM = "nav_msgs/msg/Odometry"
TWIST = "geometry_msgs/msg/Twist"


def _robot(tmp_path: Path, tags: str, *, ros2_control: bool = True) -> Path:
    """The bundled mobile robot with ``tags`` added (its own sensors' plugins kept;
    ``ros2_control=False``: without its ``<ros2_control>`` block)."""
    text = MOBILE_URDF.read_text()
    if not ros2_control:
        text = re.sub(r"<ros2_control .*</ros2_control>", "", text, flags=re.S)
    text = text.replace("</robot>", f"{tags}\n</robot>")
    path = tmp_path / "robot.urdf"
    path.write_text(text)
    return path


def _twist(x: float) -> dict[str, Any]:
    return {"linear": {"x": x, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}


def _steps(client: Any, seconds: float, dt: float = 0.002) -> None:
    for _ in range(round(seconds / dt) // 100):
        client.step(100)
    client.sync()


def _x(msg: dict[str, Any]) -> float:
    return float(msg["pose"]["pose"]["position"]["x"])


# ------------------------------------------------------------------------ ros2_control plugin


@pytest.mark.parametrize(
    "filename",
    ["gz_ros2_control-system", "ign_ros2_control-system", "libgazebo_ros2_control.so"],
)
def test_a_ros2_control_tags_parameters_are_the_controllers(tmp_path: Path, filename: str) -> None:
    """Without ``controllers=``, the tag's YAML is loaded instead of the default set (no
    forward command or trajectory controllers), its remapping of the diff drive's ``cmd_vel``
    (relative: under the tag's namespace) is the topic that drives the robot and its odometry
    is in the tag's namespace
    (before: the default set, the YAML ignored, nothing on the remapped topic)."""
    params = tmp_path / "controllers.yaml"
    params.write_text(
        re.sub(r"\n\s*(cmd_vel_topic|odom_topic):.*", "", MOBILE_CONTROLLERS.read_text())
    )
    robot = _robot(
        tmp_path,
        f"""<gazebo><plugin filename="{filename}" name="ros2_control">
          <parameters>{params}</parameters>
          <ros><namespace>/mb</namespace>
            <remapping>/diff_drive_controller/cmd_vel:=cmd_vel_nav</remapping></ros>
        </plugin></gazebo>""",
    )
    with Session(robot, base="floating") as session, connect(session.url) as client:
        listing = client.call_service("/controller_manager/list_controllers")["controller"]
        assert sorted(c["name"] for c in listing) == [
            "diff_drive_controller",
            "joint_state_broadcaster",
        ]
        truth = client.subscribe("/ground_truth/odom", ODOM)
        wheel = client.subscribe("/mb/diff_drive_controller/odom", ODOM)  # in the namespace
        client.sync()
        _steps(client, 0.2)
        start = _x(truth.messages[-1])
        client.publish("/mb/cmd_vel_nav", TWIST, _twist(0.2))
        client.sync()
        _steps(client, 1.0)
        assert _x(truth.messages[-1]) - start > 0.05  # the YAML's cmd_vel_timeout: 0.5 s
        assert _x(wheel.messages[-1]) == pytest.approx(_x(truth.messages[-1]) - start, abs=0.01)


def test_a_missing_parameters_file_is_one_warning_and_the_default_set(tmp_path: Path) -> None:
    from harness.controllers import ControllersWarning

    robot = _robot(
        tmp_path,
        """<gazebo><plugin filename="gz_ros2_control-system" name="gz">
          <parameters>/nowhere/controllers.yaml</parameters></plugin></gazebo>""",
    )
    with (
        pytest.warns(ControllersWarning, match=r"<parameters> '/nowhere/controllers.yaml' is no"),
        Session(robot, base="floating") as session,
        connect(session.url) as client,
    ):
        assert "/joint_trajectory" in client.call_service("/rosapi/topics")["topics"]


# ------------------------------------------------------------------------------ drive plugins


CLASSIC = """<gazebo><plugin filename="libgazebo_ros_diff_drive.so" name="diff_drive">
  <ros><namespace>/demo</namespace>
    <remapping>cmd_vel:=cmd_demo</remapping><remapping>odom:=odom/unfiltered</remapping></ros>
  <left_joint>left_wheel_joint</left_joint><right_joint>right_wheel_joint</right_joint>
  <wheel_separation>0.16</wheel_separation><wheel_diameter>0.066</wheel_diameter>
  <update_rate>30</update_rate>
</plugin></gazebo>"""
ROS1 = """<gazebo><plugin filename="libgazebo_ros_diff_drive.so" name="diff_drive">
  <robotNamespace>/r1</robotNamespace>
  <commandTopic>cmd</commandTopic><odometryTopic>wheel_odom</odometryTopic>
  <leftJoint>left_wheel_joint</leftJoint><rightJoint>right_wheel_joint</rightJoint>
  <wheelSeparation>0.16</wheelSeparation><wheelDiameter>0.066</wheelDiameter>
  <updateRate>20</updateRate>
</plugin></gazebo>"""


@pytest.mark.parametrize(
    ("tags", "cmd", "odom", "rate"),
    [
        (CLASSIC, "/demo/cmd_demo", "/demo/odom/unfiltered", 30),
        (ROS1, "/r1/cmd", "/r1/wheel_odom", 20),
    ],
    ids=["ros2", "ros1"],
)
def test_a_drive_plugins_namespace_remappings_and_rate(
    tmp_path: Path, tags: str, cmd: str, odom: str, rate: int
) -> None:
    """The plugin's topics as it names them, its odometry at its rate in simulation time (10 s:
    within one message of ``10 * rate``; before: ``/cmd_vel`` and ``/odom``, at 25 Hz for 30)
    and the robot's true pose on ``/ground_truth/odom`` because a base controller runs."""
    robot = _robot(tmp_path, tags, ros2_control=False)  # the plugin alone drives the wheels
    with Session(robot, base="floating") as session, connect(session.url) as client:
        wheels = {session.sim.control[j] for j in ("left_wheel_joint", "right_wheel_joint")}
        assert wheels == {"velocity"}
        wheel = client.subscribe(odom, ODOM)
        truth = client.subscribe("/ground_truth/odom", ODOM)
        client.sync()
        client.publish(cmd, TWIST, _twist(0.1))
        client.sync()
        _steps(client, 10.0)
        assert abs(len(wheel.messages) - 10 * rate) <= 1
        assert _x(truth.messages[-1]) > 0.8
        assert _x(wheel.messages[-1]) == pytest.approx(_x(truth.messages[-1]), abs=0.02)


def _sensor_topics(robot: Path, **options: Any) -> set[str]:
    with Session(robot, base="floating", **options) as session:
        sensors = session.core.sensors
        return {out.topic for s in sensors.sensors for out in s.outputs} if sensors else set()


def test_ground_truth_whenever_a_base_controller_runs(tmp_path: Path) -> None:
    """A drive plugin's controller brings ``/ground_truth/odom`` (before: only a declared
    ``ground_truth`` sensor did); a ``ground_truth`` sensor the caller lists replaces it (its
    topic); a robot without a base controller gets none."""
    robot = _robot(tmp_path, CLASSIC)
    assert "/ground_truth/odom" in _sensor_topics(robot)
    sensor = {"name": "gt", "type": "ground_truth", "parent": "base_link", "topic": "/truth"}
    listed = _sensor_topics(robot, sensors=[sensor])
    assert "/truth" in listed
    assert "/ground_truth/odom" not in listed
    assert "/ground_truth/odom" not in _sensor_topics(MOBILE_URDF, controllers=False)


P3D = """<gazebo><plugin filename="libgazebo_ros_p3d.so" name="p3d">
  <ros><namespace>/demo</namespace><remapping>odom:=truth</remapping></ros>
  <body_name>base_link</body_name><frame_name>map</frame_name><update_rate>20</update_rate>
</plugin></gazebo>"""


def test_a_p3d_plugin_is_the_robots_ground_truth(tmp_path: Path) -> None:
    """Gazebo Classic's p3d plugin in the robot file: its body, remapped topic under its
    namespace, frame and rate (before: ignored); the automatic ground truth then stays off."""
    robot = _robot(tmp_path, CLASSIC + P3D)
    with Session(robot, base="floating") as session, connect(session.url) as client:
        truth = client.subscribe("/demo/truth", ODOM)
        client.sync()
        _steps(client, 1.0)
        topics = {out.topic for s in session.core.sensors.sensors for out in s.outputs}
    assert "/ground_truth/odom" not in topics
    assert abs(len(truth.messages) - 20) <= 1
    assert truth.messages[-1]["header"]["frame_id"] == "map"
    assert truth.messages[-1]["child_frame_id"] == "base_link"


# ---------------------------------------------------------------------------- sensor plugins

IMU = """<gazebo reference="base_link"><sensor type="imu" name="imu">
  <update_rate>{rate}</update_rate>
  <plugin filename="libgazebo_ros_imu_sensor.so" name="imu_plugin">
    <robotNamespace>/r1</robotNamespace><topicName>imu/data</topicName>
    <frameName>imu_frame</frameName>
  </plugin>
</sensor></gazebo>
<gazebo reference="base_link"><sensor type="imu" name="imu2">
  <update_rate>30</update_rate>
  <plugin filename="libgazebo_ros_imu_sensor.so" name="imu2_plugin">
    <ros><namespace>/r2</namespace><remapping>~/out:=imu</remapping></ros>
  </plugin>
</sensor></gazebo>
<gazebo reference="base_link"><sensor type="imu" name="imu3">
  <update_rate>200</update_rate>
  <plugin filename="libgazebo_ros_imu.so" name="imu3_plugin">
    <topicName>imu3</topicName><updateRateHZ>50.0</updateRateHZ>
  </plugin>
</sensor></gazebo>"""


@pytest.mark.parametrize("rate", [200, 30])
def test_sensor_plugins_topics_frames_and_rates(tmp_path: Path, rate: int) -> None:
    """ROS 1's ``<robotNamespace>``/``<topicName>``/``<frameName>`` and ROS 2's namespace and
    ``~/out`` remapping; a ROS 1 plugin's ``<updateRateHZ>``; over 10 s of simulation (2 ms
    steps) each sensor gives ``10 * rate`` messages to one (before: 2500 for 200 Hz, 333 for
    30 Hz: a period rounded to whole steps; and ``imu/data`` outside its namespace)."""
    robot = _robot(tmp_path, IMU.format(rate=rate))
    with Session(robot, base="floating", controllers=False) as session, connect(session.url) as c:
        first = c.subscribe("/r1/imu/data", "sensor_msgs/msg/Imu")
        second = c.subscribe("/r2/imu", "sensor_msgs/msg/Imu")
        third = c.subscribe("/imu3", "sensor_msgs/msg/Imu")
        c.sync()
        _steps(c, 10.0)
    assert abs(len(first.messages) - 10 * rate) <= 1
    assert abs(len(second.messages) - 300) <= 1
    assert abs(len(third.messages) - 500) <= 1  # a ROS 1 plugin's updateRateHZ throttles it
    assert first.messages[0]["header"]["frame_id"] == "imu_frame"


def test_check_model_hints_floating_for_an_sdf_drive_plugin() -> None:
    """The TB3 burger's gz-sim DiffDrive held on a fixed base: check-model's one-line hint
    (before: its wheels were position-driven, so no hint)."""
    import os
    import subprocess
    import sys

    burger = Path(__file__).resolve().parents[2] / "data" / "worlds" / "turtlebot3" / "models"
    root = Path(__file__).resolve().parents[3]
    done = subprocess.run(
        [sys.executable, "-m", "harness", "check-model",
         str(burger / "turtlebot3_burger" / "model.sdf"), "--base", "fixed"],
        capture_output=True, text=True, timeout=300,
        env={**os.environ, "PYTHONPATH": str(root)},
    )  # fmt: skip
    hints = [line for line in (done.stdout + done.stderr).splitlines() if "--base floating" in line]
    assert len(hints) == 1, done.stdout + done.stderr
    assert "wheel_left_joint, wheel_right_joint turn as wheels" in hints[0]


def test_a_camera_plugins_remapped_outputs(tmp_path: Path) -> None:
    """gazebo_ros_camera's ``<remapping>`` of its image and camera_info (by ``~/`` or by the
    camera's name; relative: under the plugin's namespace) and the others under its namespace
    (before: the remappings were ignored)."""
    text = MOBILE_URDF.read_text().replace(
        "<camera_name>front_camera</camera_name>",
        """<camera_name>front_camera</camera_name>
        <ros><namespace>/mb</namespace><remapping>~/image_raw:=front/image</remapping>
          <remapping>front_camera/camera_info:=/front/info</remapping></ros>""",
    )
    path = tmp_path / "robot.urdf"
    path.write_text(text)
    with Session(path, base="floating", controllers=False) as session:
        camera = next(s for s in session.core.sensors.sensors if s.spec.name == "front_camera")
        topics = {out.key: out.topic for out in camera.outputs}
    assert topics["image"] == "/mb/front/image"
    assert topics["camera_info"] == "/front/info"
    assert topics["compressed"] == "/mb/front_camera/image_raw/compressed"
