"""A file that declares its actuated joints (``<ros2_control>``, ``<transmission>``) leaves the
others passive: no actuator, they swing freely under gravity, as in Gazebo."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.models import load_robot
from harness.sim import Simulation

_LINK = """
  <link name="{name}">
    <inertial><origin xyz="0.2 0 0"/><mass value="1.0"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <visual><origin xyz="0.2 0 0"/><geometry><box size="0.4 0.04 0.04"/></geometry></visual>
  </link>"""

_JOINT = """
  <joint name="{name}" type="revolute">
    <parent link="{parent}"/><child link="{child}"/><origin xyz="{x} 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="50" velocity="5"/>
  </joint>"""


def _urdf(declaration: str) -> str:
    return (
        '<robot name="two_link">\n  <link name="base"/>'
        + _LINK.format(name="upper")
        + _LINK.format(name="lower")
        + _JOINT.format(name="shoulder", parent="base", child="upper", x=0)
        + _JOINT.format(name="elbow", parent="upper", child="lower", x=0.4)
        + declaration
        + "\n</robot>\n"
    )


_ROS2_CONTROL = """
  <ros2_control name="arm" type="system">
    <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
    <joint name="shoulder"><command_interface name="position"/>
      <state_interface name="position"/></joint>
  </ros2_control>"""

_TRANSMISSION = """
  <transmission name="shoulder_trans">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="shoulder">
      <hardwareInterface>hardware_interface/PositionJointInterface</hardwareInterface>
    </joint>
    <actuator name="shoulder_motor"><mechanicalReduction>1</mechanicalReduction></actuator>
  </transmission>"""


def _elbow_swing(path: Path, **kwargs: object) -> tuple[tuple[str, ...], float, float]:
    robot = load_robot(path, **kwargs)  # type: ignore[arg-type]
    sim = Simulation(robot)
    for _ in range(round(0.5e9 / sim.dt_ns)):
        sim.step()
    model, data = sim.model, sim.data
    shoulder = float(data.qpos[model.jnt_qposadr[model.joint("shoulder").id]])
    elbow = float(data.qpos[model.jnt_qposadr[model.joint("elbow").id]])
    actuated = tuple(model.actuator(i).name for i in range(model.nu))
    return actuated, shoulder, elbow


@pytest.mark.parametrize(
    "declaration", [_ROS2_CONTROL, _TRANSMISSION], ids=["ros2_control", "transmission"]
)
def test_undeclared_joint_swings_freely(tmp_path: Path, declaration: str) -> None:
    path = tmp_path / "two_link.urdf"
    path.write_text(_urdf(declaration))
    actuated, shoulder, elbow = _elbow_swing(path)
    assert actuated == ("shoulder",)
    assert abs(shoulder) < 0.05  # held at its start by its servo
    assert abs(elbow) > 0.5  # the lower link falls from horizontal


def test_without_declarations_every_joint_is_servoed(tmp_path: Path) -> None:
    path = tmp_path / "two_link.urdf"
    path.write_text(_urdf(""))
    actuated, _, elbow = _elbow_swing(path)
    assert set(actuated) == {"shoulder", "elbow"}
    assert abs(elbow) < 0.05


def test_a_joint_the_caller_names_stays_actuated(tmp_path: Path) -> None:
    path = tmp_path / "two_link.urdf"
    path.write_text(_urdf(_ROS2_CONTROL))
    actuated, _, elbow = _elbow_swing(path, control={"elbow": "position"})
    assert set(actuated) == {"shoulder", "elbow"}
    assert abs(elbow) < 0.05
