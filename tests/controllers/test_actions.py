"""The demo arm's ros2_control controllers driven by real clients (roslibpy in a process of its
own, roslibjs through node) in lockstep, recorded, and the recording replayed."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from harness import Session
from harness.controllers import ControllersConfig
from harness.recording import Recording
from harness.replay.pipeline import replay_pipeline
from harness.replay.resim import resimulate
from harness.testing import connect

HERE = Path(__file__).resolve().parent
NODE_DIR = HERE.parent / "node"
JOINTS = [f"joint{i}" for i in range(1, 8)]
TARGET = [0.3, 0.2, 0.1, -1.4, 0.1, 1.8, -0.5]
SUCCEEDED, CANCELED, ABORTED = 4, 5, 6


def _port(session: Session) -> str:
    return session.url.rsplit(":", 1)[1].split("/")[0]


@pytest.fixture(scope="module")
def roslibpy_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], Path]:
    """One recorded session driven by roslibpy_actions.py: its cases by name."""
    path = tmp_path_factory.mktemp("controllers") / "roslibpy.mcap"
    with Session("demo", record_to=path) as session:
        done = subprocess.run(
            [sys.executable, str(HERE / "roslibpy_actions.py"), _port(session)],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.splitlines()
    assert lines[-1] == "OK", done.stdout[-2000:]
    cases = {c["case"]: c for c in (json.loads(line) for line in lines if line.startswith("{"))}
    return cases, path


def _within_goal(positions: dict[str, float], tolerance: float = 0.01) -> None:
    for joint, target in zip(JOINTS, TARGET, strict=True):
        assert abs(positions[joint] - target) < tolerance, (joint, positions[joint], target)


def test_goal_succeeds_with_feedback_and_ends_within_tolerance(roslibpy_run: Any) -> None:
    case = roslibpy_run[0]["success"]
    assert case["result"] == {
        "status": SUCCEEDED,
        "values": {"error_code": 0, "error_string": "Goal successfully reached!"},
    }
    # 0.6 s trajectory, feedback at the default action_monitor_rate of 20 Hz in sim time
    assert case["feedback"] >= 10
    feedback = case["first_feedback"]
    assert feedback["joint_names"] == JOINTS
    for part in ("desired", "actual", "error"):
        assert len(feedback[part]["positions"]) == 7
    error = [d - a for d, a in zip(feedback["desired"]["positions"],
                                    feedback["actual"]["positions"], strict=True)]  # fmt: skip
    assert feedback["error"]["positions"] == pytest.approx(error, abs=1e-12)
    _within_goal(case["positions"])


@pytest.mark.parametrize(
    ("name", "code", "words"),
    [
        ("unknown_joint", -2, "'elbow' is not one of the controller's joints"),
        ("non_increasing", -1, "not strictly increasing"),
        ("past_start", -3, "ends in the past"),
    ],
)
def test_invalid_goals_end_with_the_controllers_error_code(
    roslibpy_run: Any, name: str, code: int, words: str
) -> None:
    case = roslibpy_run[0][name]
    assert case["result"]["status"] == ABORTED
    assert case["result"]["values"]["error_code"] == code
    assert words in case["result"]["values"]["error_string"]
    assert case["feedback"] == 0


def test_path_tolerance_violation_aborts(roslibpy_run: Any) -> None:
    case = roslibpy_run[0]["path_tolerance"]
    assert case["result"]["status"] == ABORTED
    assert case["result"]["values"] == {
        "error_code": -4,
        "error_string": "Aborted due to path tolerance violation",
    }


def test_second_goal_preempts_the_first(roslibpy_run: Any) -> None:
    cases = roslibpy_run[0]
    assert cases["preempted"]["result"] == {
        "status": ABORTED,
        "values": {
            "error_code": -1,
            "error_string": "Current goal preempted by new incoming action.",
        },
    }
    assert cases["preempting"]["result"]["status"] == SUCCEEDED
    _within_goal(cases["preempting"]["positions"])


def test_cancel_and_gripper(roslibpy_run: Any) -> None:
    cases = roslibpy_run[0]
    assert cases["canceled"]["result"]["status"] == CANCELED
    gripper = cases["gripper"]["result"]
    assert gripper["status"] == SUCCEEDED
    assert gripper["values"]["reached_goal"] is True
    assert gripper["values"]["stalled"] is False
    assert abs(gripper["values"]["position"] - 0.02) < 0.01


def test_controller_manager_lists_the_default_set(roslibpy_run: Any) -> None:
    listing = {c["name"]: c for c in roslibpy_run[0]["list_controllers"]["controllers"]}
    assert listing["joint_trajectory_controller"]["state"] == "active"
    # the default set commands through the harness's multiplexer, which claims the joints
    assert listing["joint_trajectory_controller"]["claimed_interfaces"] == [
        f"command_mux/{j}/position" for j in JOINTS
    ]
    assert listing["command_mux"]["state"] == "active"
    assert set(listing["command_mux"]["claimed_interfaces"]) >= {f"{j}/position" for j in JOINTS}
    assert listing["gripper_controller"]["type"] == "position_controllers/GripperActionController"
    assert listing["joint_state_broadcaster"]["state"] == "active"
    assert "forward_position_controller" in listing


def test_full_replay_reproduces_feedback_and_results(roslibpy_run: Any) -> None:
    report = replay_pipeline(roslibpy_run[1])
    assert report.reproduced, report.format()
    assert report.frames_compared > 40  # goals, feedback and results among them


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
def test_roslibjs_action_client(tmp_path: Path) -> None:
    with Session("demo") as session:
        done = subprocess.run(
            ["node", str(NODE_DIR / "controllers_roslibjs.mjs"), session.url],
            capture_output=True,
            text=True,
            timeout=120,
            cwd=NODE_DIR,
        )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    result = json.loads(done.stdout.splitlines()[-1])
    assert result["feedback"] > 0
    assert result["result"]["error_code"] == 0
    assert result["rejected"]["error_code"] == -2
    _within_goal(dict(zip(result["names"], result["positions"], strict=True)))


@pytest.mark.parametrize("mode", ["kinematic", "servo"])
def test_resimulation_replays_trajectories_sent_as_actions(roslibpy_run: Any, mode: str) -> None:
    report = resimulate(roslibpy_run[1], mode)  # type: ignore[arg-type]
    assert report.steps > 1000
    assert report.resimulated.unstable_at is None
    by_joint = {j.joint: j for j in report.resimulated.joints}
    # the targets the actions commanded are re-simulated: tracked within a few centiradians
    for joint in JOINTS:
        assert by_joint[joint].max_tracking_error < 0.1, (joint, by_joint[joint])
    recorded = {j.joint: j for j in report.recorded.joints}
    assert recorded["joint1"].max_velocity_ratio > 0  # the arm did move


def test_trajectory_topic_and_controller_state() -> None:
    with Session("demo") as session, connect(session.url) as client:
        state = client.subscribe(
            "/joint_trajectory_controller/controller_state",
            "control_msgs/msg/JointTrajectoryControllerState",
        )
        client.publish(
            "/joint_trajectory_controller/joint_trajectory",
            "trajectory_msgs/msg/JointTrajectory",
            {
                "joint_names": JOINTS,
                "points": [
                    {"positions": TARGET, "time_from_start": {"sec": 0, "nanosec": 400_000_000}}
                ],
            },
        )
        client.step(400)  # 0.8 s at 2 ms
        js = client.state()["joint_state"]
        positions = dict(zip(js["name"], js["position"], strict=True))
        # 50 Hz of simulation time over 0.8 s
        assert 38 <= len(state.messages) <= 42
        last = state.messages[-1]
        assert last["joint_names"] == JOINTS
        assert last["desired"]["positions"] == pytest.approx(TARGET)
    _within_goal(positions, 0.02)


def test_the_recording_holds_the_resolved_controllers(roslibpy_run: Any) -> None:
    with Recording(roslibpy_run[1]) as recording:
        config = ControllersConfig.from_json(recording.metadata["controllers"])
    by_name = {c.name: c for c in config.controllers}
    assert by_name["joint_trajectory_controller"].params["joints"] == JOINTS
    assert by_name["gripper_controller"].params["joint"] == "finger_joint1"
