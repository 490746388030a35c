"""Mimic joints under every interface: a follower keeps its law ``q = m * q_leader + offset``
whether its leader is position-, velocity- or effort-controlled, for a URDF ``<mimic>`` and
for ros2_control's ``mimic`` joint parameter (the Humble syntax gazebo_ros2_control and
gz_ros2_control read), which the harness ignored (issue 34)."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from harness import Session
from harness.errors import ModelError
from harness.models import load_robot
from harness.testing import connect

DATA = Path(__file__).resolve().parents[2] / "data" / "controllers" / "mimic"
FILES = {"urdf_mimic": ("mimic_pair.urdf", 0.1), "ros2_control_param": ("mimic_param.urdf", 0.0)}
COMMANDS = {
    "position": {"position": 0.5},
    "velocity": {"velocity": 0.3},
    "effort": {"effort": 0.05},
}


@pytest.mark.parametrize("mode", sorted(COMMANDS))
@pytest.mark.parametrize("declared", sorted(FILES))
def test_the_follower_keeps_its_law_under_every_interface(declared: str, mode: str) -> None:
    name, offset = FILES[declared]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(DATA / name, control={"leader": mode})
    with Session(robot, controllers=False) as session, connect(session.url) as client:
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        session.command("leader", **COMMANDS[mode])
        client.step(500)  # 1 s
        client.sync()
    msg = states.messages[-1]
    q = dict(zip(msg["name"], msg["position"], strict=True))
    assert abs(q["leader"]) > 0.25  # it moved
    assert q["follower"] == pytest.approx(-2.0 * q["leader"] + offset, abs=0.002)


def test_a_mimic_parameter_naming_no_joint_is_one_line(tmp_path: Path) -> None:
    text = (DATA / "mimic_param.urdf").read_text("utf-8")
    bad = tmp_path / "bad.urdf"
    bad.write_text(
        text.replace('<param name="mimic">leader</param>', '<param name="mimic">lead</param>')
    )
    with pytest.raises(ModelError) as info:
        load_robot(bad)
    message = str(info.value)
    assert "\n" not in message
    assert "bad.urdf" in message
    assert "joint 'follower': mimic 'lead' is not another joint of the robot" in message
