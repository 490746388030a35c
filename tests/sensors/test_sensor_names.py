"""A sensor's name is any text, as Gazebo takes it (issue 34, finding 8): a public description
package names a camera ``{prefix}camera_…_color`` (literal braces). The robot loads and runs;
where the name stands in for a ROS name (the default topic and frame) its sanitised form
(:func:`harness.sensors.spec.sensor_token`) is used; topics and frames the file gives are kept."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.recording import Recording
from harness.sensors import SensorConfigError, SensorSpec, sensors_from_urdf
from harness.session import Session
from tests.sensors.sensor_helpers import DATA

CAMERA = "{prefix}camera_wrist_color"
IMU = "{prefix}imu sensor"


def _braced_bot(tmp_path: Path) -> Path:
    """sensor_bot.urdf with the upstream typo: its camera and IMU named with literal braces
    (and a space); the IMU loses its <topic>, so its topic comes from the name."""
    text = (DATA / "sensor_bot.urdf").read_text()
    text = text.replace('name="wrist_camera"', f'name="{CAMERA}"')
    text = text.replace('name="imu_sensor"', f'name="{IMU}"').replace("<topic>imu</topic>", "")
    path = tmp_path / "braced_bot.urdf"
    path.write_text(text)
    return path


def test_the_sanitised_form_keeps_ros_names_and_replaces_the_rest():
    from harness.sensors.spec import sensor_token

    assert sensor_token("wrist_camera") == "wrist_camera"
    assert sensor_token("front-cam/left") == "front-cam/left"
    assert sensor_token(CAMERA) == "_prefix_camera_wrist_color"
    assert sensor_token(IMU) == "_prefix_imu_sensor"


def test_a_braced_gazebo_sensor_name_is_read_with_ros_topics(tmp_path):
    specs = {s.name: s for s in sensors_from_urdf(_braced_bot(tmp_path).read_bytes())}
    camera = specs[CAMERA]
    assert camera.topics["image"] == "_prefix_camera_wrist_color/image_raw"
    assert camera.frame_id == "wrist_camera_link_optical"  # the file's <frame_name>, kept
    assert specs[IMU].token == "_prefix_imu_sensor"


def test_the_braced_robot_is_served(tmp_path):
    path = tmp_path / "run.mcap"
    with Session(_braced_bot(tmp_path), record_to=path) as session:
        session.step(100)
    seen: dict[str, set[str]] = {}
    with Recording(path) as rec:
        for m in rec.messages(decode=True):
            header = getattr(m.msg, "header", None)
            if header is not None:
                seen.setdefault(m.topic, set()).add(header.frame_id)
    assert seen["/_prefix_camera_wrist_color/image_raw"] == {"wrist_camera_link_optical"}
    assert seen["/_prefix_imu_sensor/imu"] == {"_prefix_imu_sensor"}


def test_a_braced_sensor_name_runs_in_a_session(tmp_path):
    path = tmp_path / "run.mcap"
    imu = {"name": "{ns}wrist imu", "type": "imu", "parent": "link1", "update_rate": 100}
    with Session("demo", sensors=[imu], record_to=path) as session:
        session.step(20)
    frames = set()
    with Recording(path) as rec:
        for m in rec.messages(topics=["/_ns_wrist_imu/imu"], decode=True):
            frames.add(m.msg.header.frame_id)
    assert frames == {"_ns_wrist_imu"}


@pytest.mark.parametrize(("name", "message"), [("", "non-empty"), ("a\nb", "control character")])
def test_an_empty_or_multiline_name_is_one_line(name, message):
    with pytest.raises(SensorConfigError, match=message):
        SensorSpec(name=name, type="imu", parent="link1")
