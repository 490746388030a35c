"""Kinematic <-> dynamic re-simulation: the teleport jump and the limit violation are found."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType

import pytest

from harness.cli import main
from harness.replay import Thresholds, resimulate

# Step 30: joint7 commanded 0.4 rad past its upper limit (2.8973); step 100: the arm is
# teleported into the box on the table (hand 25 mm deep in it).
PAST_LIMIT = {"joint7": 3.3}
INTO_BOX = {"joint2": 0.4, "joint4": -1.6, "joint6": 1.0}


@pytest.fixture(scope="module")
def jump_recording(helper: ModuleType, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("jump") / "jump.mcap"
    return helper.record(  # type: ignore[no-any-return]
        path, {30: PAST_LIMIT, 100: INTO_BOX}, 160, control="kinematic", kinematic_limits="allow"
    )


def test_kinematic_recording_shows_the_jump_and_the_limit_violation(jump_recording: Path) -> None:
    report = resimulate(jump_recording, "servo")
    assert not report.passed
    found = {(f.quantity, f.name): f for f in report.findings}
    # Only the recording passes joint7's limit (a servo brakes at it) at the step of the
    # command, and only it is 25 mm deep in the box at once: differences, named once each.
    violation = found[("limit_violation", "joint7")]
    assert (violation.run, violation.step) == ("recorded", 31)
    assert violation.recorded_value == pytest.approx(3.3 - 2.8973, abs=0.01)
    assert violation.resimulated_value < 0.005
    assert violation.unit == "rad"
    assert [k for k in found if k[0] == "limit_violation"] == [("limit_violation", "joint7")]
    assert (found[("penetration", "")].run, found[("penetration", "")].step) == ("recorded", 101)
    assert found[("velocity_ratio", "joint2")].step == 101
    assert found[("energy_jump", "")].step == 31
    # The servos cannot teleport: the re-simulated joints leave the recorded positions.
    assert (found[("deviation", "joint7")].run, found[("deviation", "joint7")].step) == (
        "resimulated",
        31,
    )
    assert found[("deviation", "joint2")].step == 101
    assert len(found) == len(report.findings)  # one finding per quantity and joint
    by_joint = {j.joint: j for j in report.resimulated.joints}
    assert by_joint["joint7"].max_limit_violation < 0.005
    assert by_joint["finger_joint1"].unit == "m"  # a slide joint
    assert report.recorded.peak_penetration > 0.02
    assert report.resimulated.penetration_step != 101
    assert "box|hand" in report.contacts_disappearing
    text = report.format()
    assert "legend: each cell is recorded | re-simulated" in text
    assert text.splitlines()[-1].startswith("VERDICT: DIFFERENT: ")
    table = [line for line in text.splitlines() if line.startswith("  ") and " | " in line]
    assert len(table) == len(report.recorded.joints) + 2
    assert len({line.index(" | ") for line in table}) == 1  # aligned columns


def test_a_position_recording_resimulated_dynamically_is_the_same_run(
    base_recording: Path,
) -> None:
    report = resimulate(base_recording, "servo")
    assert report.passed, report.format()
    assert any("recorded in position mode" in n for n in report.notes)
    assert report.format().splitlines()[-1].startswith("VERDICT: SAME BEHAVIOUR")


def test_thresholds_are_configurable(jump_recording: Path) -> None:
    loose = Thresholds(
        max_tracking_error=10.0,
        max_limit_violation=1.0,
        max_velocity_ratio=1e6,
        max_penetration=1.0,
        max_energy_jump=1e9,
    )
    assert resimulate(jump_recording, "servo", thresholds=loose).passed


def test_dynamic_recording_to_kinematic_via_cli(
    base_recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report_path = tmp_path / "resim.json"
    code = main(
        ["replay", str(base_recording), "--actuation", "kinematic", "--report", str(report_path)]
    )
    out = capsys.readouterr().out
    assert "recorded (position) vs re-simulated (kinematic)" in out
    data = json.loads(report_path.read_text())
    assert data["actuation"] == "kinematic"
    assert code == (0 if data["passed"] else 1)
    # Kinematic joints report exactly the commanded targets.
    assert all(j["max_tracking_error"] == 0.0 for j in data["resimulated"]["joints"])
    assert main(["replay", str(base_recording), "--actuation", "kinematic", "--max-velocity-ratio",
                 "1e9", "--max-energy-jump", "1e9", "--max-tracking-error", "10",
                 "--max-penetration", "1", "--max-limit-violation", "1"]) == 0  # fmt: skip
