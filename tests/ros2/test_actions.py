"""Actions on DDS: the gateway mirrors every action the session serves as an rclpy action
server whose goals, cancels, feedback and results cross the bridge as recorded frames."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.cli import main
from harness.recording import Recording
from harness.ros2 import Ros2Install
from harness.ros2.testing import run_node
from harness.session import Session
from tests.ros2.ros2_paths import ROOT

CLIENT = ROOT / "tests" / "ros2" / "follow_trajectory.py"
ARM = "/joint_trajectory_controller/follow_joint_trajectory"
JOINTS = [f"joint{i}" for i in range(1, 8)]
TARGET = [0.3, 0.2, 0.1, -1.4, 0.1, 1.8, -0.5]
SUCCEEDED, CANCELED = 4, 5


@pytest.mark.slow
def test_follow_joint_trajectory_goal_from_an_rclpy_action_client(
    ros2: Ros2Install, tmp_path: Path
) -> None:
    path = tmp_path / "action.mcap"
    with Session("demo", ros2=True, record_to=path) as session:
        assert session.ros2_refused == ()
        result = run_node(ros2, session.ros_domain_id or 0, CLIENT)
        assert result["status"] == SUCCEEDED, result
        assert result["error_code"] == 0
        assert result["feedback"] >= 5
        first = result["first_feedback"]
        assert first["joint_names"] == JOINTS
        error = [d - a for d, a in zip(first["desired"], first["actual"], strict=True)]
        assert first["error"] == pytest.approx(error, abs=1e-12)
        for joint, target in zip(JOINTS, TARGET, strict=True):
            assert result["positions"][joint] == pytest.approx(target, abs=0.01), joint
        assert result["cancel_goals"] == 1
        assert result["canceled_status"] == CANCELED
    with Recording(path) as rec:
        frames = [f for f in rec.bridge_frames() if f.topic == ARM]
    ops = [(f.direction, f.op) for f in frames]
    assert ops[0] == (0, "send_action_goal")
    assert (1, "action_feedback") in ops
    assert (0, "cancel_action_goal") in ops
    assert [op for op in ops if op[1] in ("send_action_goal", "action_result")] == [
        (0, "send_action_goal"), (1, "action_result")] * 2  # fmt: skip
    assert main(["replay", str(path), "--level", "full"]) == 0
