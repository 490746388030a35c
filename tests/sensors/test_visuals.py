"""A robot whose sensors render (a camera) is loaded with its visual geoms, which the camera
draws: its recording carries the visual-only meshes, each file once, says ``visuals=true``,
and a replay at --level full rebuilds the same model (issue 35, "Small goldens")."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import mujoco
import pytest

from harness.recording import Recording
from harness.replay.source import rebuild_run
from harness.session import Session

MESH = (
    Path(__file__).resolve().parents[1]
    / "data/descriptions/moveit_resources_panda_description/meshes/collision/finger.stl"
)

CAMERA = """
  <gazebo reference="link1">
    <sensor type="camera" name="wrist_camera">
      <pose>0 0 0.3 0 0 0</pose>
      <update_rate>50</update_rate>
      <camera>
        <horizontal_fov>1.2</horizontal_fov>
        <image><width>32</width><height>24</height></image>
        <clip><near>0.05</near><far>10</far></clip>
      </camera>
    </sensor>
  </gazebo>
"""

URDF = """<?xml version="1.0"?>
<robot name="looking_bot">
  <link name="base_link">
    <inertial>
      <mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
    <visual><geometry><mesh filename="meshes/finger.stl"/></geometry></visual>
    <collision>
      <origin xyz="0 0 0.05"/><geometry><box size="0.2 0.2 0.1"/></geometry>
    </collision>
  </link>
  <link name="link1">
    <inertial>
      <origin xyz="0 0 0.2"/><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
    <visual>
      <origin xyz="0 0 0.2"/><geometry><mesh filename="meshes/finger.stl"/></geometry>
    </visual>
    <collision>
      <origin xyz="0 0 0.2"/><geometry><cylinder radius="0.03" length="0.3"/></geometry>
    </collision>
  </link>
  <joint name="joint1" type="revolute">
    <origin xyz="0 0 0.1"/>
    <parent link="base_link"/>
    <child link="link1"/>
    <axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="2" effort="50"/>
  </joint>
{camera}</robot>
"""

VISUAL = "source/model/meshes/finger.stl"


def _robot(folder: Path, camera: bool) -> Path:
    (folder / "meshes").mkdir(parents=True)
    shutil.copyfile(MESH, folder / "meshes" / "finger.stl")
    urdf = folder / "looking_bot.urdf"
    urdf.write_text(URDF.replace("{camera}", CAMERA if camera else ""))
    return urdf


def _visual_geoms(model: mujoco.MjModel) -> int:
    """The geoms that collide with nothing: the visuals."""
    return sum(
        1
        for g in range(model.ngeom)
        if model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0
    )


def _record(urdf: Path, path: Path, sensors: list[dict[str, object]]) -> int:
    """Record 30 steps; the number of visual geoms of the session's model."""
    with Session(urdf, sensors=sensors, record_to=path) as session:
        session.step(30)
        return _visual_geoms(session.sim.model)


@pytest.mark.slow
@pytest.mark.parametrize("declared", [True, False], ids=["declared", "listed"])
def test_a_robot_whose_camera_renders_is_loaded_and_recorded_with_its_visuals(
    tmp_path: Path, declared: bool
) -> None:
    urdf = _robot(tmp_path / "bot", camera=declared)
    listed = (
        []
        if declared
        else [{"name": "cam", "type": "rgbd", "parent": "link1", "width": 16, "height": 12}]
    )
    path = tmp_path / "looking.mcap"
    visual_geoms = _record(urdf, path, listed)
    assert visual_geoms == 2  # the two <visual> meshes, which the camera draws
    with Recording(path) as rec:
        assert rec.metadata.get("visuals") == "true"
        names = rec.attachment_names
        assert VISUAL in names  # the visual-only mesh, attached once for both references
        blobs = [bytes(rec.attachment(n)) for n in names]
        assert blobs.count(MESH.read_bytes()) == 1
        rebuilt = rebuild_run(rec)  # from the carried sources, as replay rebuilds it
        assert rebuilt.sha256 == rec.metadata["model_sha256"]
        assert _visual_geoms(rebuilt.model) == 2
    done = subprocess.run(
        [sys.executable, "-m", "harness", "replay", "--level", "full", str(path)],
        capture_output=True, text=True, timeout=180,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr


def test_a_robot_without_a_rendering_sensor_leaves_its_visuals_out(tmp_path: Path) -> None:
    urdf = _robot(tmp_path / "bot", camera=False)
    path = tmp_path / "blind.mcap"
    assert _record(urdf, path, [{"name": "imu", "type": "imu", "parent": "link1"}]) == 0
    with Recording(path) as rec:
        assert rec.metadata.get("visuals") is None
        assert VISUAL not in rec.attachment_names
