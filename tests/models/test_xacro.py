"""xacro robots: real ROS description packages (tests/data/descriptions) loaded with their
arguments, the package search ``$(find)`` shares with ``package://``, portable output, the
cache, ``<ros2_control>`` and the errors (one line each, exit 2 on the CLI)."""

from __future__ import annotations

import math
import shutil
import warnings
from pathlib import Path

import pytest

from harness.cli import main
from harness.models import load_description, load_robot
from harness.models.errors import UnknownPackageError, XacroError
from harness.models.urdf.ros2_control import HardwareReplacedWarning
from harness.models.xacro.expand import (
    UnusedRobotArgWarning,
    clear_cache,
    expand_xacro,
    is_xacro,
    normalize_args,
)

DESCRIPTIONS = Path(__file__).resolve().parents[1] / "data" / "descriptions"
UR = DESCRIPTIONS / "ur_description" / "urdf" / "ur_mocked.urdf.xacro"
UR_PLAIN = DESCRIPTIONS / "ur_description" / "urdf" / "ur.urdf.xacro"
FRANKA = DESCRIPTIONS / "franka_description" / "robots"
DD100 = DESCRIPTIONS / "dd100_robot" / "robot.urdf.xacro"
UR_TYPES = ("ur3", "ur3e", "ur5", "ur5e", "ur10", "ur10e", "ur16e", "ur20", "ur30")
UR_HOME = {
    "shoulder_pan_joint": 0.0,
    "shoulder_lift_joint": -1.57,
    "elbow_joint": 0.0,
    "wrist_1_joint": -1.57,
    "wrist_2_joint": 0.0,
    "wrist_3_joint": 0.0,
}


def _expanded(robot) -> str:
    [name] = [n for n in robot.sources if n.startswith("model/")]
    return robot.sources[name].decode()


@pytest.mark.parametrize("ur_type", UR_TYPES)
def test_every_ur_type_loads_with_its_arguments(ur_type):
    with warnings.catch_warnings():
        warnings.simplefilter("error", HardwareReplacedWarning)  # a mock system: no notice
        robot = load_robot(UR, robot_args={"ur_type": ur_type, "name": "ur"})
    description = robot.description
    assert [j.name for j in description.controllable_joints] == list(UR_HOME)
    assert description.xacro is not None
    assert dict(description.xacro.args) == {"ur_type": ur_type, "name": "ur"}
    # the type's own kinematics and limits (config/<ur_type>/*.yaml) made it in
    reach = description.link("tool0").pose.xyz
    assert robot.model.key("home").qpos.tolist() == pytest.approx(list(UR_HOME.values()))
    text = _expanded(robot)
    assert "package://ur_description/meshes/" in text
    assert "file://" not in text
    assert str(DESCRIPTIONS) not in text
    [block] = description.ros2_control.blocks
    assert block.plugin == "mock_components/GenericSystem"
    assert block.simulated
    assert block.joints[1].initial_position == -1.57
    assert set(robot.control.values()) == {"position"}
    assert any(n.startswith("package/ur_description/meshes/") for n in robot.sources)
    assert f"xacro/ur_description/config/{ur_type}/joint_limits.yaml" in robot.sources
    assert math.dist(reach, (0, 0, 0)) > 0.3


def test_ur_types_differ_by_their_arguments():
    small = load_description(UR_PLAIN, robot_args={"ur_type": "ur3e", "name": "ur"})
    large = load_description(UR_PLAIN, robot_args={"ur_type": "ur10e", "name": "ur"})
    assert large.joint("elbow_joint").pose.xyz != small.joint("elbow_joint").pose.xyz
    assert large.link("tool0").pose.xyz[0] != pytest.approx(small.link("tool0").pose.xyz[0])
    assert small.ros2_control is None  # ur.urdf.xacro has no <ros2_control>


def test_absolute_mesh_paths_are_written_back_as_package_references():
    expansion = expand_xacro(UR_PLAIN, {"ur_type": "ur5e", "name": "ur", "force_abs_paths": True})
    text = expansion.urdf.decode()
    assert "package://ur_description/meshes/ur5e/collision/base.stl" in text
    assert "file://" not in text
    assert str(DESCRIPTIONS) not in text


@pytest.mark.parametrize(("robot", "repair"), [("fr3", False), ("fp3", False), ("fer", True)])
def test_franka_arms_with_their_hand(robot, repair):
    path = FRANKA / robot / f"{robot}.urdf.xacro"
    with pytest.warns(HardwareReplacedWarning, match="franka_hardware/FrankaHardwareInterface"):
        loaded = load_robot(path, robot_args={"ros2_control": True}, repair_inertia=repair)
    joints = [j.name for j in loaded.description.controllable_joints]
    assert joints == [f"{robot}_joint{i}" for i in range(1, 8)] + [f"{robot}_finger_joint1"]
    home = loaded.model.key("home").qpos
    # initial_value of each joint's position state interface in <ros2_control>
    assert home[:7].tolist() == pytest.approx(
        [0, -math.pi / 4, 0, -3 * math.pi / 4, 0, math.pi / 2, math.pi / 4]
    )
    without_hand = load_description(path, robot_args={"hand": False})
    assert not [j for j in without_hand.joints if "finger" in j.name]
    assert without_hand.ros2_control is None  # ros2_control defaults to false


def test_franka_fake_hardware_is_simulated_without_a_notice():
    with warnings.catch_warnings():
        warnings.simplefilter("error", HardwareReplacedWarning)
        robot = load_robot(
            FRANKA / "fr3" / "fr3.urdf.xacro",
            robot_args={"ros2_control": "true", "use_fake_hardware": "true"},
        )
    assert robot.description.ros2_control.blocks[0].plugin == "fake_components/GenericSystem"


@pytest.mark.filterwarnings("ignore::harness.models.urdf.ros2_control.HardwareReplacedWarning")
def test_mobile_base_takes_its_control_modes_from_its_command_interfaces():
    with pytest.warns(HardwareReplacedWarning, match="clearpath_platform/PumaHardware"):
        robot = load_robot(DD100)
    wheels = ["front_left_wheel_joint", "front_right_wheel_joint"]
    assert dict(robot.control) == dict.fromkeys(wheels, "velocity")
    # two packages found by $(find): the platform's and clearpath_control (an argument default)
    assert "xacro/clearpath_platform_description/urdf/dd100/dd100.urdf.xacro" in robot.sources
    assert "xacro/robot.urdf.xacro" in robot.sources
    named = load_robot(DD100, control={wheels[0]: "position"})
    assert dict(named.control) == {wheels[0]: "position", wheels[1]: "velocity"}
    assert set(load_robot(DD100, control="effort").control.values()) == {"effort"}
    with warnings.catch_warnings():
        warnings.simplefilter("error", HardwareReplacedWarning)
        sim = load_robot(DD100, robot_args={"is_sim": True})
    assert sim.description.ros2_control.blocks[0].plugin == "ign_ros2_control/IgnitionSystem"
    # the controllers file given as $(find clearpath_control)/... stays a package reference
    text = _expanded(sim)
    assert "<parameters>package://clearpath_control/config/dd100/control.yaml</parameters>" in text
    assert "package/clearpath_control/config/dd100/control.yaml" in sim.sources


def test_package_reference_through_every_search_place(tmp_path, monkeypatch):
    reference = "package://ur_description/urdf/ur_mocked.urdf.xacro"
    args = {"ur_type": "ur5e", "name": "ur"}
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(UnknownPackageError, match="unknown package 'ur_description'"):
        load_description(reference, robot_args=args)
    explicit = load_description(
        reference, robot_args=args, packages={"ur_description": DESCRIPTIONS / "ur_description"}
    )
    assert explicit.xacro.source == reference
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(DESCRIPTIONS))
    assert load_description(reference, robot_args=args).name == "ur"
    # a ROS 2 install: <prefix>/share/<package>; $(find) searches it as package:// does
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    share = tmp_path / "install" / "share"
    share.mkdir(parents=True)
    shutil.copytree(DESCRIPTIONS / "ur_description", share / "ur_description")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "install"))
    expansion = expand_xacro(share / "ur_description" / "urdf" / "ur_mocked.urdf.xacro", args)
    assert expansion.packages["ur_description"] == (share / "ur_description").resolve()
    robot = load_robot(reference, robot_args=args)
    assert robot.model.njnt == 6


def test_cache_expands_once_and_notices_changed_content(tmp_path, monkeypatch):
    copy = tmp_path / "ur_description"
    shutil.copytree(DESCRIPTIONS / "ur_description", copy)
    entry = copy / "urdf" / "ur_mocked.urdf.xacro"
    args = {"ur_type": "ur5e", "name": "ur"}
    first = expand_xacro(entry, args)
    assert expand_xacro(entry, dict(args)) is first
    assert expand_xacro(entry, {**args, "name": "other"}) is not first
    positions = copy / "config" / "initial_positions.yaml"  # read through xacro.load_yaml
    positions.write_text(positions.read_text().replace("elbow_joint: 0.0", "elbow_joint: 0.5"))
    changed = expand_xacro(entry, args)
    assert changed is not first
    assert load_robot(entry, robot_args=args).model.key("home").qpos[2] == pytest.approx(0.5)
    clear_cache()
    assert expand_xacro(entry, args) is not changed


def test_env_eval_include_and_macro(tmp_path, monkeypatch):
    (tmp_path / "parts.xacro").write_text(
        """<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
          <xacro:macro name="arm_link" params="name length">
            <link name="${name}">
              <inertial><mass value="${length * 2}"/>
                <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
              <collision><geometry><box size="0.05 0.05 ${length}"/></geometry></collision>
            </link>
          </xacro:macro>
        </robot>"""
    )
    (tmp_path / "bot.urdf").write_text(
        """<?xml version="1.0"?>
        <robot name="$(env BOT_NAME)" xmlns:xacro="http://www.ros.org/wiki/xacro">
          <xacro:arg name="length" default="0.5"/>
          <xacro:include filename="parts.xacro"/>
          <link name="base"/>
          <xacro:arm_link name="arm" length="$(arg length)"/>
          <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
            <axis xyz="0 0 1"/>
            <limit lower="${-float(xacro.arg('length'))}" upper="$(eval 0.5 + 0.25)"
              effort="5" velocity="1"/>
          </joint>
        </robot>"""
    )
    path = tmp_path / "bot.urdf"  # a .urdf whose root declares and uses xacro is a xacro file
    assert is_xacro(path)
    written = tmp_path / "written.urdf"  # what xacro writes: the declaration, nothing to expand
    written.write_text(
        '<robot name="w" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<!-- <xacro:macro name="m"/> ${x} --><link name="a"/></robot>'
    )
    assert not is_xacro(written)
    monkeypatch.setenv("BOT_NAME", "bot_a")
    first = load_description(path, robot_args={"length": 0.25})
    assert first.name == "bot_a"
    assert first.link("arm").inertial.mass == pytest.approx(0.5)
    assert first.joint("j").limits.lower == pytest.approx(-0.25)
    assert first.joint("j").limits.upper == pytest.approx(0.75)
    monkeypatch.setenv("BOT_NAME", "bot_b")  # the cache knows the files read $(env BOT_NAME)
    assert load_description(path, robot_args={"length": 0.25}).name == "bot_b"


def test_robot_args_are_spelled_as_on_the_xacro_command_line():
    assert normalize_args(["ur_type:=ur5e", "safety_limits:=true"]) == {
        "ur_type": "ur5e",
        "safety_limits": "true",
    }
    assert normalize_args({"hand": False, "count": 2, "gain": 0.5}) == {
        "hand": "false",
        "count": "2",
        "gain": "0.5",
    }
    with pytest.raises(XacroError, match="is not NAME:=VALUE"):
        normalize_args(["ur_type=ur5e"])
    with pytest.raises(XacroError, match="not a xacro file"):
        load_robot("demo", robot_args={"x": "1"})


# ------------------------------------------------------------------------ errors, CLI


def _cli(capsys, *argv: str) -> tuple[int, str]:
    code = main(["inspect-model", *argv])
    captured = capsys.readouterr()
    return code, captured.err


def test_cli_loads_a_xacro_robot_with_robot_args(capsys):
    code = main(
        ["inspect-model", str(UR), "--robot-arg", "ur_type:=ur10e", "--robot-arg", "name:=ur"]
    )
    out = capsys.readouterr().out
    assert code == 0
    assert "model ur (urdf" in out
    assert "shoulder_pan_joint" in out
    assert "with ur_type:=ur10e name:=ur" in out
    assert "ur: mock_components/GenericSystem" in out
    assert "shoulder_lift_joint: position, velocity; -1.57" in out


def test_missing_package_is_one_line_naming_it_and_every_place(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws"))
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "ros"))
    path = tmp_path / "robot.urdf.xacro"
    path.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="$(find nowhere_description)/urdf/arm.xacro"/></robot>'
    )
    code, err = _cli(capsys, str(path))
    assert code == 2
    assert err.count("\n") == 1
    assert "unknown package 'nowhere_description'" in err
    assert str(path) in err
    assert str(tmp_path / "ws") in err
    assert str(tmp_path / "ros" / "share") in err
    assert f"the folders above {tmp_path.resolve()}" in err


def test_undefined_argument_is_one_line_naming_it_and_the_file(capsys):
    code, err = _cli(capsys, str(UR), "--robot-arg", "ur_type:=ur5e")
    assert code == 2
    assert err.count("\n") == 1
    assert f"{UR}: undefined argument 'name'" in err
    assert "given: ur_type" in err


def test_every_undefined_argument_is_named_at_once(tmp_path, capsys):
    path = tmp_path / "cell.urdf.xacro"
    path.write_text(
        '<robot name="cell" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:arg name="given_one" default="x"/>'
        '<link name="$(arg arm_prefix)base"/><link name="tool_$(arg tool)"/>'
        '<link name="$(arg given_one)"/></robot>'
    )
    code, err = _cli(capsys, str(path))
    assert code == 2
    assert err.count("\n") == 1
    assert "undefined arguments 'arm_prefix', 'tool'" in err
    assert "--robot-arg arm_prefix:=VALUE --robot-arg tool:=VALUE" in err
    assert (
        _cli(capsys, str(path), "--robot-arg", "arm_prefix:=a_", "--robot-arg", "tool:=t")[0] == 0
    )


def test_xacro_syntax_error_is_one_line_naming_the_file_and_line(tmp_path, capsys):
    (tmp_path / "part.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro">\n<link name="a">\n</robot>\n'
    )
    path = tmp_path / "robot.urdf.xacro"
    path.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="part.xacro"/></robot>'
    )
    code, err = _cli(capsys, str(path))
    assert code == 2
    assert err.count("\n") == 1
    assert f"{tmp_path / 'part.xacro'}:3: malformed XML" in err


def test_bad_robot_arg_spelling_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as info:
        main(["inspect-model", str(UR), "--robot-arg", "ur_type=ur5e"])
    assert info.value.code == 2
    assert "is not NAME:=VALUE" in capsys.readouterr().err


def test_an_argument_no_file_mentions_is_named_in_a_warning():
    with pytest.warns(UnusedRobotArgWarning, match="'ur_tpye' is mentioned by none"):
        expand_xacro(UR_PLAIN, {"ur_type": "ur5e", "name": "ur", "ur_tpye": "ur3"})
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnusedRobotArgWarning)
        expand_xacro(UR_PLAIN, {"ur_type": "ur3", "name": "ur", "safety_limits": "true"})


def test_franka_multi_arm_takes_list_arguments():
    path = FRANKA / "multi_arm" / "multi_arm.urdf.xacro"
    with pytest.warns(HardwareReplacedWarning, match="MultiFrankaHardwareInterface"):
        robot = load_robot(
            path, robot_args={"arm_prefixes": "['west','east']", "ros2_control": "true"}
        )
    joints = [j.name for j in robot.description.controllable_joints]
    assert joints[0] == "west_fr3_joint1"
    assert joints[8] == "east_fr3_joint1"
    assert len(joints) == 16
    west, east = (robot.description.link(f"{side}_fr3_link0").pose for side in ("west", "east"))
    assert west.xyz[1] == pytest.approx(0.1)  # xyz_values' default
    assert east.xyz[1] == pytest.approx(-0.1)


def test_a_relative_mesh_path_into_a_package_becomes_a_package_reference(tmp_path):
    package = tmp_path / "cell_description"
    shutil.copytree(DESCRIPTIONS / "ur_description" / "meshes" / "ur5e", package / "meshes")
    (package / "package.xml").write_text("<package><name>cell_description</name></package>")
    (package / "urdf").mkdir()
    (package / "urdf" / "cell.urdf.xacro").write_text(
        """<robot name="cell" xmlns:xacro="http://www.ros.org/wiki/xacro">
          <link name="base"><collision><geometry>
            <mesh filename="../meshes/collision/base.stl"/></geometry></collision>
          <inertial><mass value="1"/>
            <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
          </link></robot>"""
    )
    robot = load_robot(package / "urdf" / "cell.urdf.xacro")
    assert 'filename="package://cell_description/meshes/collision/base.stl"' in _expanded(robot)
    assert "package/cell_description/meshes/collision/base.stl" in robot.sources
