"""``harness check-model FILE [--json]``: exit 0 when the robot behaves, 1 with the reasons
when it does not, 2 when it does not load."""

from __future__ import annotations

import json

from harness.cli import main

from .conftest import DATA

ARM = DATA / "overlapping_arm.urdf"


def test_a_robot_that_behaves_exits_0_with_its_report(capsys):
    assert main(["check-model", str(ARM), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["exit_code"] == 0
    assert report["problems"] == []
    assert report["self_collision"]["policy"] == "auto"
    assert ["base", "forearm", "default"] in report["self_collision"]["ignored"]
    joints = {j["name"]: j for j in report["joints"]}
    assert set(joints) == {"shoulder_joint", "elbow_joint"}
    for joint in joints.values():
        assert joint["holds"]
        assert joint["hold_error"] < 1e-3
        assert joint["settling_time"] is not None
        assert joint["settling_time"] <= 0.5 + 0.1 / 2.0
        assert joint["overshoot"] < 0.2
        assert joint["peak_speed"] <= 1.2 * joint["velocity_limit"]
    assert report["mass"]["total_kg"] == 6.5
    assert main(["check-model", str(ARM)]) == 0
    text = capsys.readouterr().out
    assert "behaves" in text
    assert "base / forearm: default" in text


def test_a_robot_too_weak_for_its_load_exits_1_naming_why(tmp_path, capsys):
    weak = tmp_path / "weak_arm.urdf"
    tilted = '<harness><keyframe name="home"><joint name="shoulder_joint" value="0.5"/>'
    tilted += "</keyframe></harness></robot>"
    text = ARM.read_text().replace('effort="50"', 'effort="0.5"')
    weak.write_text(text.replace("</robot>", tilted))
    arm = main(["check-model", str(weak), "--json"])
    report = json.loads(capsys.readouterr().out)
    assert arm == 1
    assert report["exit_code"] == 1
    assert any(
        p.startswith("shoulder_joint does not hold") and "effort limit 0.5 N m below" in p
        for p in report["problems"]
    ), report["problems"]


def test_a_robot_that_does_not_load_exits_2(tmp_path, capsys):
    broken = tmp_path / "broken.urdf"
    broken.write_text('<robot name="r"></robot>')
    assert main(["check-model", str(broken), "--json"]) == 2
    report = json.loads(capsys.readouterr().out)
    assert report["loaded"] is False
    assert "<robot> has no <link>" in report["error"]
    assert main(["check-model", str(broken)]) == 2
    assert "does not load" in capsys.readouterr().out


def test_a_floating_robot_is_stood_instead_of_stepped(capsys):
    assert main(["check-model", str(ARM), "--base", "floating", "--json"]) in (0, 1)
    report = json.loads(capsys.readouterr().out)
    assert report["base"] == "floating"
    assert report["stand"]["seconds"] == 5.0
    assert report["stand"]["finite"] is True
    assert all(j["settling_time"] is None for j in report["joints"])


def test_strict_refuses_what_the_default_repairs(capsys):
    lenient = DATA / "lenient" / "trailing_content.urdf"
    assert main(["check-model", str(lenient), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert any("content after the root element" in n for n in report["notes"])
    assert report["repairs"]
    assert main(["check-model", str(lenient), "--strict", "--json"]) == 2
    assert "Extra content" in json.loads(capsys.readouterr().out)["error"]
