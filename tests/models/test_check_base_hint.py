"""``harness check-model`` on a wheeled robot with a fixed base (issue 34, finding 9): the
report hints ``--base floating``, whether a drive plugin or a ``<ros2_control>`` velocity
interface drives the wheels; an arm and a floating base get no hint."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from harness.cli import main
from harness.models.mobile import MOBILE_URDF

DD100 = Path(__file__).resolve().parents[1] / "data/descriptions/dd100_robot/robot.urdf.xacro"
DIFF_DRIVE = """
  <gazebo>
    <plugin name="diff_drive" filename="libgazebo_ros_diff_drive.so">
      <left_joint>left_wheel_joint</left_joint>
      <right_joint>right_wheel_joint</right_joint>
      <wheel_separation>0.16</wheel_separation>
      <wheel_diameter>0.066</wheel_diameter>
    </plugin>
  </gazebo>
</robot>"""


def _plugin_bot(tmp_path: Path) -> Path:
    """The bundled mobile robot with a Gazebo Classic diff-drive plugin instead of its
    ``<ros2_control>`` block."""
    text = re.sub(r"<ros2_control.*?</ros2_control>", "", MOBILE_URDF.read_text(), flags=re.S)
    path = tmp_path / "plugin_bot.urdf"
    path.write_text(text.replace("</robot>", DIFF_DRIVE))
    return path


def _report(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    main(["check-model", *argv, "--json"])
    return json.loads(capsys.readouterr().out)


def test_a_drive_plugin_robot_held_in_the_air_is_told_to_float(tmp_path, capsys):
    report = _report(capsys, str(_plugin_bot(tmp_path)))
    assert report["base"] == "fixed"
    (hint,) = report["hints"]
    assert "left_wheel_joint, right_wheel_joint" in hint
    assert "a drive plugin drives them" in hint
    assert "--base floating" in hint


@pytest.mark.parametrize(
    ("argv", "wheels"),
    [
        ((str(MOBILE_URDF),), "left_wheel_joint, right_wheel_joint"),
        ((str(DD100), "--robot-arg", "is_sim:=true"), "front_left_wheel_joint"),
    ],
    ids=["mobile_bot", "dd100"],
)
def test_a_ros2_control_velocity_base_is_told_to_float(capsys, argv, wheels):
    (hint,) = _report(capsys, *argv)["hints"]
    assert wheels in hint
    assert "<ros2_control> commands them by velocity" in hint


def test_the_text_report_says_the_hint(capsys):
    main(["check-model", str(MOBILE_URDF)])
    lines = capsys.readouterr().out.splitlines()
    assert any(line.startswith("hint: ") and "--base floating" in line for line in lines)


@pytest.mark.parametrize("argv", [("demo",), (str(MOBILE_URDF), "--base", "floating")])
def test_no_hint_for_an_arm_or_a_floating_base(capsys, argv):
    assert _report(capsys, *argv)["hints"] == []
