"""An MJCF body without a joint is welded to its parent: its description has a fixed joint,
so /tf_static and /robot_description hang it from its parent link, not from the world (as
robot_state_publisher would for the same robot in URDF)."""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree

from harness.models import load_robot
from harness.session.core.tf import RobotFrames, TfTree
from harness.session.core.urdf_text import urdf_of

_MJCF = """
<mujoco>
  <worldbody>
    <body name="base" pos="0 0 0.1"><geom type="box" size="0.1 0.1 0.05"/>
      <body name="link1" pos="0 0 0.1">
        <joint name="j1" axis="0 0 1"/><geom size="0.04"/>
        <body name="hand" pos="0 0 0.2"><geom type="box" size="0.02 0.05 0.02"/>
          <body name="cam" pos="0.03 0 0"><geom size="0.01"/></body>
          <body name="finger" pos="0 0.03 0.03">
            <joint name="hand_to_cam" type="slide" axis="0 1 0" range="0 0.03"/>
            <geom size="0.01"/>
          </body>
        </body>
      </body>
    </body>
    <body name="table" pos="1 0 0"><geom type="box" size="0.3 0.3 0.02"/></body>
  </worldbody>
  <actuator><position joint="j1" kp="10"/><position joint="hand_to_cam" kp="10"/></actuator>
</mujoco>
"""


def test_bodies_without_joints_are_fixed_to_their_parents(tmp_path: Path) -> None:
    path = tmp_path / "arm.xml"
    path.write_text(_MJCF)
    robot = load_robot(path)
    fixed = {(j.name, j.parent, j.child) for j in robot.description.joints if j.type == "fixed"}
    # "base" sits under the world (in MJCF a root body) and stays a root link, as does the
    # table; "cam"'s fixed joint takes another name than the slide already called hand_to_cam
    assert fixed == {("link1_to_hand", "link1", "hand"), ("hand_to_cam_fixed", "hand", "cam")}

    tree = TfTree(robot.model, [RobotFrames(robot.description)])
    static = {(e.parent, e.child) for e in tree.static}
    moving = {(e.parent, e.child) for e in tree.moving}
    assert {("link1", "hand"), ("hand", "cam")} <= static
    assert moving == {("base", "link1"), ("hand", "finger")}

    urdf = urdf_of(robot.description)
    assert urdf is not None
    parents = {
        joint.find("child").get("link"): joint.find("parent").get("link")  # type: ignore[union-attr]
        for joint in ElementTree.fromstring(urdf).iter("joint")
    }
    assert parents["hand"] == "link1"
    assert parents["cam"] == "hand"
    assert parents["base"] == "world"
