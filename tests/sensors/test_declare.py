"""Sensors declared in URDF <gazebo> blocks and SDF <sensor> elements come out on the expected
topics with the expected frame ids (recorded by a real session); bad declarations fail with one
clear line."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.recording import Recording
from harness.sensors import (
    CameraOptions,
    LidarOptions,
    SensorConfigError,
    SensorSpec,
    sensors_from_urdf,
)
from harness.session import Session
from tests.sensors.sensor_helpers import DATA


def _recorded(robot: Path, tmp_path: Path, steps: int) -> dict[str, tuple[str, set[str]]]:
    """topic -> (type, frame ids seen) of every message of a short recorded session."""
    path = tmp_path / "run.mcap"
    with Session(robot, record_to=path) as session:
        session.step(steps)
    out: dict[str, tuple[str, set[str]]] = {}
    with Recording(path) as rec:
        for m in rec.messages(decode=True):
            header = getattr(m.msg, "header", None)
            frames = out.setdefault(m.topic, (m.msgtype, set()))[1]
            if header is not None:
                frames.add(header.frame_id)
            if m.topic == "/tf_static":
                frames.update(f"{t.header.frame_id}->{t.child_frame_id}" for t in m.msg.transforms)
    return out


@pytest.mark.slow
def test_urdf_gazebo_sensors_on_their_topics_and_frames(tmp_path: Path) -> None:
    seen = _recorded(DATA / "sensor_bot.urdf", tmp_path, 100)
    assert seen["/wrist_camera/image_raw"] == (
        "sensor_msgs/msg/Image",
        {"wrist_camera_link_optical"},
    )
    assert seen["/wrist_camera/camera_info"][1] == {"wrist_camera_link_optical"}
    assert "/wrist_camera/image_raw/compressed" not in seen  # raw recorded, PNG on request
    assert seen["/scan"] == ("sensor_msgs/msg/LaserScan", {"laser_frame"})
    assert seen["/imu"] == ("sensor_msgs/msg/Imu", {"imu_sensor"})
    assert seen["/tool_wrench"] == ("geometry_msgs/msg/WrenchStamped", {"tool_ft"})
    assert seen["/tf_static"][1] >= {
        "link1->wrist_camera",
        "link1->wrist_camera_link_optical",
        "link1->laser_frame",
        "base_link->imu_sensor",
        "tool->tool_ft",
    }


def test_sdf_sensors_on_links_and_joints(tmp_path: Path) -> None:
    seen = _recorded(DATA / "sensor_model.sdf", tmp_path, 250)
    assert seen["/base/imu"] == ("sensor_msgs/msg/Imu", {"base_imu"})
    assert seen["/front/depth"] == ("sensor_msgs/msg/Image", {"front_camera_optical"})
    assert seen["/front/depth/points"][0] == "sensor_msgs/msg/PointCloud2"
    assert seen["/arm_ft/wrench"] == ("geometry_msgs/msg/WrenchStamped", {"arm_ft"})
    assert seen["/tf_static"][1] >= {"base->base_imu", "base->front_camera_optical", "arm->arm_ft"}


def test_urdf_parameters_are_read() -> None:
    specs = {s.name: s for s in sensors_from_urdf((DATA / "sensor_bot.urdf").read_bytes())}
    cam, laser = specs["wrist_camera"], specs["laser"]
    assert cam.type == "camera"
    assert cam.options == CameraOptions(width=32, height=24, hfov=1.2, far=10.0)
    assert cam.pose == (0, 0, 0.3, 0, 0, 0)
    assert cam.update_rate == 5
    options = laser.options_as(LidarOptions)
    assert (laser.type, options.samples, options.min_angle, options.range_max) == (
        "lidar",
        90,
        -1.57,
        8,
    )
    assert specs["tool_ft"].parent == "tool"
    assert specs["tool_ft"].joint == "tool_joint"


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ({"name": "x", "type": "sonar", "parent": "a"}, "type 'sonar' is not one of"),
        ({"name": "x", "type": "camera", "parent": "a", "hfov": -1}, "hfov must be a number > 0"),
        ({"name": "x", "type": "lidar", "parent": "a", "colour": 1}, "unknown sensor key 'colour'"),
        ({"name": "x", "type": "imu"}, "give the link (parent)"),
        ({"name": "x", "type": "camera", "parent": "a", "near": 5, "far": 1}, "near clip 5"),
        ({"name": "x", "type": "imu", "parent": "a", "topics": {"scan": "s"}}, "topics has 'scan'"),
        (
            {"name": "x", "type": "imu", "parent": "a", "pose": ["a", 0, 0, 0, 0, 0]},
            "pose must be 6",
        ),
        ({"name": "x", "type": "imu", "parent": "a", "update_rate": "fast"}, "update_rate must be"),
        ({"name": 3, "type": "imu", "parent": "a"}, "the name must be"),
    ],
)
def test_bad_declarations_say_what_and_where(value: dict, message: str) -> None:
    with pytest.raises(SensorConfigError, match="sensors\\[2\\]") as info:
        SensorSpec.from_mapping(value, "sensors[2]")
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_unknown_link_and_bad_urdf_value(tmp_path: Path) -> None:
    with pytest.raises(SensorConfigError, match="no link 'nowhere'"):
        Session(
            DATA / "sensor_rig.xml", sensors=[{"name": "c", "type": "imu", "parent": "nowhere"}]
        )
    bad = (DATA / "sensor_bot.urdf").read_text().replace("<samples>90", "<samples>many")
    with pytest.raises(SensorConfigError, match="<scan/horizontal/samples> is 'many'"):
        sensors_from_urdf(bad.encode(), "bad.urdf")


def test_world_file_sensors_are_mounted_on_scene_models() -> None:
    import mujoco

    from harness.sensors import RobotMount, SensorSuite

    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body name="camera_post/post_link" pos="2 0 0.5">'
        '<geom type="box" size="0.02 0.02 0.5"/></body></worldbody></mujoco>'
    )
    world = RobotMount("", "", {"scene/sensor_world.sdf": (DATA / "sensor_world.sdf").read_bytes()})
    robot = RobotMount("arm", "arm/", {})
    suite = SensorSuite.for_robots(model, [robot], seed=0, dt_ns=2_000_000, world=[world])
    assert suite is not None
    assert dict(suite.topics()) == {
        "/world/overhead": "sensor_msgs/msg/Image",
        "/world/camera_info": "sensor_msgs/msg/CameraInfo",
        "/world/overhead/compressed": "sensor_msgs/msg/CompressedImage",
        "/world/scan": "sensor_msgs/msg/LaserScan",
    }
    frames = {t["child_frame_id"]: t["header"]["frame_id"] for t in suite.static_tf()["transforms"]}
    assert frames["post_scan"] == "camera_post/post_link"
