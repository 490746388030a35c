"""``<ros2_control>`` blocks: parsed into frozen records, their ``initial_value``s the initial
configuration, their command interfaces the default control modes, a real driver replaced by
the simulation with a notice."""

from __future__ import annotations

import dataclasses
import warnings

import pytest

from harness.models import load_description, load_robot
from harness.models.errors import ModelStructureError
from harness.models.urdf.ros2_control import HardwareReplacedWarning

JOINT = """
  <joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>{mimic}
    <limit lower="-2" upper="2" effort="20" velocity="2"/></joint>
  <link name="{child}"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>"""


def _robot(tmp_path, control: str, harness: str = "") -> str:
    joints = "".join(
        JOINT.format(name=n, kind="revolute", parent=p, child=c, mimic=m)
        for n, p, c, m in (
            ("a", "base", "l1", ""),
            ("b", "l1", "l2", ""),
            ("c", "l2", "l3", ""),
            ("follow", "l3", "l4", '<mimic joint="a" multiplier="-1" offset="0.1"/>'),
        )
    )
    path = tmp_path / "robot.urdf"
    path.write_text(f'<robot name="r"><link name="base"/>{joints}{control}{harness}</robot>')
    return str(path)


CONTROL = """
  <ros2_control name="arm" type="system">
    <hardware><plugin>acme_driver/ArmInterface</plugin><param name="ip">10.0.0.2</param></hardware>
    <joint name="a">
      <command_interface name="position"><param name="min">-1</param></command_interface>
      <state_interface name="position"><param name="initial_value">0.7</param></state_interface>
      <state_interface name="velocity"/>
    </joint>
    <joint name="b">
      <command_interface name="effort"/>
      <command_interface name="velocity"/>
      <state_interface name="position"><param name="initial_value">-0.3</param></state_interface>
    </joint>
    <sensor name="ft"><state_interface name="force.x"/></sensor>
    <gpio name="io"><command_interface name="out"/></gpio>
  </ros2_control>
  <ros2_control name="wheel" type="actuator">
    <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
    <joint name="c"><command_interface name="velocity"/></joint>
  </ros2_control>"""


def test_blocks_are_frozen_records_of_what_the_file_declares(tmp_path):
    control = load_description(_robot(tmp_path, CONTROL)).ros2_control
    arm, wheel = control.blocks
    assert (arm.name, arm.type, arm.plugin) == ("arm", "system", "acme_driver/ArmInterface")
    assert dict(arm.hardware_params) == {"ip": "10.0.0.2"}
    assert (arm.sensors, arm.gpios) == (("ft",), ("io",))
    assert arm.joints[0].command_interfaces[0].params["min"] == "-1"
    assert arm.joints[1].command_names == ("effort", "velocity")
    assert dict(control.initial_positions) == {"a": 0.7, "b": -0.3}
    assert control.replaced_plugins == ("acme_driver/ArmInterface",)
    assert wheel.simulated
    with pytest.raises(dataclasses.FrozenInstanceError):
        arm.plugin = "other"  # type: ignore[misc]


def test_initial_values_modes_and_the_notice(tmp_path):
    with pytest.warns(HardwareReplacedWarning, match=r'name="arm"> hardware plugin .acme_driver'):
        robot = load_robot(_robot(tmp_path, CONTROL))
    home = robot.model.key("home").qpos
    assert home.tolist() == pytest.approx([0.7, -0.3, 0.0, -0.6])  # the follower: -a + 0.1
    assert dict(robot.control) == {"a": "position", "b": "effort", "c": "velocity"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HardwareReplacedWarning)
        chosen = load_robot(_robot(tmp_path, CONTROL), control={"b": "position"})
        kinematic = load_robot(_robot(tmp_path, CONTROL), control="kinematic")
    assert dict(chosen.control) == {"a": "position", "b": "position", "c": "velocity"}
    assert set(kinematic.control.values()) == {"kinematic"}


def test_a_harness_home_keyframe_wins_over_initial_values(tmp_path):
    harness = '<harness><keyframe name="home"><joint name="a" value="0.2"/></keyframe></harness>'
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HardwareReplacedWarning)
        robot = load_robot(_robot(tmp_path, CONTROL, harness))
    assert robot.model.key("home").qpos[:2].tolist() == pytest.approx([0.2, 0.0])


def test_a_bad_initial_value_names_the_joint(tmp_path):
    bad = CONTROL.replace(">0.7<", ">${pi}<")
    with pytest.raises(ModelStructureError, match=r"joint name=\"a\".*initial_value '\$\{pi\}'"):
        load_description(_robot(tmp_path, bad))
