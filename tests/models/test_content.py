"""What makes a robot load the way it does lives in its files, not in their paths: the URDF's
``<harness>`` element (keyframes, armature) makes any copy of the demo load identically."""

from __future__ import annotations

import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yourdfpy

from harness.models import DEMO_URDF, load_robot
from harness.models.errors import ModelStructureError, ModelWarning

HOME = {
    "joint1": 0.0,
    "joint2": -np.pi / 4,
    "joint3": 0.0,
    "joint4": -3 * np.pi / 4,
    "joint5": 0.0,
    "joint6": np.pi / 2,
    "joint7": np.pi / 4,
    "finger_joint1": 0.04,
    "finger_joint2": 0.04,
}


@pytest.fixture(scope="module")
def demo() -> tuple[str, bytes]:
    loaded = load_robot("demo")
    return loaded.sha256, loaded.mjb


def test_a_copy_of_the_demo_urdf_loads_the_same_model(
    tmp_path: Path, demo: tuple[str, bytes]
) -> None:
    copy = tmp_path / "demo_arm.urdf"
    shutil.copyfile(DEMO_URDF, copy)
    loaded = load_robot(copy, scene="table")
    assert (loaded.sha256, loaded.mjb) == demo
    assert loaded.sources["model/demo_arm.urdf"] == DEMO_URDF.read_bytes()
    renamed = tmp_path / "other_name.urdf"
    shutil.copyfile(DEMO_URDF, renamed)
    assert load_robot(renamed, scene="table").mjb == demo[1]


def test_the_demo_urdf_reached_through_another_path_loads_the_same_model(
    tmp_path: Path, demo: tuple[str, bytes]
) -> None:
    link = tmp_path / "linked"
    link.symlink_to(DEMO_URDF.parent, target_is_directory=True)
    for path in (link / DEMO_URDF.name, DEMO_URDF.parent / ".." / "data" / DEMO_URDF.name):
        assert path != DEMO_URDF
        loaded = load_robot(path, scene="table")
        assert (loaded.sha256, loaded.mjb) == demo


def test_the_home_keyframe_comes_from_the_file(tmp_path: Path) -> None:
    copy = tmp_path / "demo_arm.urdf"
    shutil.copyfile(DEMO_URDF, copy)
    loaded = load_robot(copy, scene="empty", control={"joint3": "velocity"})
    m = loaded.model
    home = m.key("home")
    for joint, value in HOME.items():
        assert home.qpos[m.jnt_qposadr[m.joint(joint).id]] == pytest.approx(value, abs=1e-15)
    expected_ctrl = [0.0 if j == "joint3" else HOME[j] for j in loaded.actuated]
    assert home.ctrl == pytest.approx(expected_ctrl, abs=1e-15)
    # without the <harness> element the robot starts at zero, except joint4, whose zero is
    # outside its limits: it starts at its nearest limit (a home keyframe made for it); the
    # drives get the armature their servo needs instead of the file's
    stripped = tmp_path / "stripped.urdf"
    text = copy.read_text()
    stripped.write_text(text[: text.index("  <harness>")] + "</robot>\n")
    with pytest.warns(ModelWarning, match="joint4 0 -> -0.0698"):
        bare = load_robot(stripped, scene="empty").model
    assert bare.nkey == 1
    start = {bare.joint(j).name: bare.key("home").qpos[bare.jnt_qposadr[j]] for j in range(7)}
    assert start["joint4"] == pytest.approx(-0.0698)
    assert all(v == 0.0 for name, v in start.items() if name != "joint4")
    assert bare.dof_armature.tolist() != m.dof_armature.tolist()


def test_other_urdf_readers_ignore_the_extension() -> None:
    urdf = yourdfpy.URDF.load(str(DEMO_URDF), build_scene_graph=False, load_meshes=False)
    assert len(urdf.robot.joints) == 10


CHAIN = """<?xml version="1.0"?>
<robot name="chain">
  <link name="a"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01"
    iyz="0" izz="0.01"/></inertial></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01"
    iyz="0" izz="0.01"/></inertial></link>
  <link name="c"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01"
    iyz="0" izz="0.01"/></inertial></link>
  <link name="d"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01"
    iyz="0" izz="0.01"/></inertial></link>
  <joint name="lift" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.5" effort="100" velocity="0.2"/></joint>
  <joint name="turn" type="continuous"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/>
    <limit effort="10" velocity="2"/></joint>
  <joint name="follow" type="continuous"><parent link="c"/><child link="d"/><axis xyz="0 0 1"/>
    <mimic joint="turn" multiplier="-2" offset="0.1"/></joint>
  <joint name="pin" type="fixed"><parent link="a"/><child link="e"/></joint>
  <link name="e"/>
{extension}
</robot>
"""


def test_any_urdf_can_carry_keyframes_and_armature(tmp_path: Path) -> None:
    path = tmp_path / "chain.urdf"
    path.write_text(
        CHAIN.format(
            extension="""<harness>
  <!-- a comment is fine -->
  <keyframe name="up"><joint name="lift" value="0.4"/><joint name="turn" value="1.5"/></keyframe>
  <keyframe name="down"><joint name="turn" value="-1"/><joint name="follow" value="3"/></keyframe>
  <joint name="lift" armature="2.5"/>
  <joint name="follow" armature="0.01"/>
</harness>"""
        )
    )
    loaded = load_robot(path, control={"turn": "effort"})
    m = loaded.model

    def qpos(key: str, joint: str) -> float:
        return float(m.key(key).qpos[m.jnt_qposadr[m.joint(joint).id]])

    assert m.nkey == 2
    assert (qpos("up", "lift"), qpos("up", "turn")) == (0.4, 1.5)
    assert qpos("up", "follow") == pytest.approx(-2 * 1.5 + 0.1)  # follows its mimic leader
    assert (qpos("down", "lift"), qpos("down", "follow")) == (0.0, 3.0)  # as listed
    assert list(m.key("up").ctrl) == [0.4, 0.0]  # lift's servo target; turn is an effort motor
    armature = {j: m.dof_armature[m.jnt_dofadr[m.joint(j).id]] for j in ("lift", "turn", "follow")}
    assert armature == {"lift": 2.5, "turn": 0.0, "follow": 0.01}


@pytest.mark.parametrize(
    ("extension", "message"),
    [
        (
            '<harness><keyframe name="k"><joint name="pin" value="1"/></keyframe></harness>',
            r"chain\.urdf: line \d+: <joint name=\"pin\">: 'pin' is not a revolute, continuous "
            r"or prismatic joint of the robot \(those are: \['lift', 'turn', 'follow'\]\)",
        ),
        (
            '<harness><keyframe name="k"><joint name="ghost" value="1"/></keyframe></harness>',
            r"line \d+: <joint name=\"ghost\">: 'ghost' is not a revolute",
        ),
        (
            '<harness><keyframe name="k"><joint name="lift"/></keyframe></harness>',
            r"line \d+: <joint name=\"lift\">: missing attribute 'value'",
        ),
        (
            '<harness><keyframe name="k"><joint name="lift" value="up"/></keyframe></harness>',
            r"value='up' is not 1 number",
        ),
        (
            '<harness><keyframe><joint name="lift" value="0"/></keyframe></harness>',
            r"line \d+: <keyframe>: keyframe without a name",
        ),
        (
            '<harness><keyframe name="k"/><keyframe name="k"/></harness>',
            r"duplicate keyframe 'k'",
        ),
        (
            '<harness><keyframe name="k"><pose/></keyframe></harness>',
            r"line \d+: <pose>: unexpected <pose> in <keyframe>",
        ),
        (
            '<harness><joint name="lift" armature="-1"/></harness>',
            r"line \d+: <joint name=\"lift\">: armature -1\.0 is negative",
        ),
        (
            '<harness><joint name="lift"/></harness>',
            r"missing attribute 'armature'",
        ),
        (
            '<harness><key name="k"/></harness>',
            r"line \d+: <key name=\"k\">: unexpected <key> in <harness> \(expected <keyframe> "
            r"or <joint>\)",
        ),
        ("<harness/><harness/>", r"line \d+: <harness>: more than one <harness>"),
    ],
)
def test_a_bad_extension_is_one_error_naming_the_element(
    tmp_path: Path, extension: str, message: str
) -> None:
    path = tmp_path / "chain.urdf"
    path.write_text(CHAIN.format(extension=extension))
    with pytest.raises(ModelStructureError, match=message):
        load_robot(path)


def test_keyframe_ctrl_matches_qpos_so_the_robot_holds_it(tmp_path: Path) -> None:
    path = tmp_path / "chain.urdf"
    path.write_text(
        CHAIN.format(
            extension='<harness><keyframe name="home"><joint name="lift" value="0.3"/>'
            "</keyframe></harness>"
        )
    )
    loaded = load_robot(path, scene="empty")
    m = loaded.model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    for _ in range(500):
        mujoco.mj_step(m, d)
    assert d.qpos[m.jnt_qposadr[m.joint("lift").id]] == pytest.approx(0.3, abs=0.005)
