"""The test client's action helper (issue 34, finding 9): ``client.send_goal`` sends a
FollowJointTrajectory goal to the demo arm's real controller in a lockstep session; the
handle's feedback, result and cancel step the session in simulation time, no raw frames."""

from __future__ import annotations

import pytest

from harness import Session
from harness.testing import ActionGoalFailed, GoalResult, TestClientTimeout, connect

FJT = "control_msgs/action/FollowJointTrajectory"
ARM = "/joint_trajectory_controller/follow_joint_trajectory"
JOINTS = [f"joint{i}" for i in range(1, 8)]
TARGET = [0.3, 0.2, 0.1, -1.4, 0.1, 1.8, -0.5]
TOLERANCE = [{"name": j, "position": 0.01, "velocity": 0.0, "acceleration": 0.0} for j in JOINTS]


def _goal(positions: list[float], seconds: float) -> dict:
    sec = int(seconds)
    return {
        "trajectory": {
            "joint_names": JOINTS,
            "points": [
                {
                    "positions": positions,
                    "time_from_start": {"sec": sec, "nanosec": round((seconds - sec) * 1e9)},
                }
            ],
        },
        "goal_tolerance": TOLERANCE,
        "goal_time_tolerance": {"sec": 1, "nanosec": 0},
    }


@pytest.fixture
def session():
    with Session("demo", clock="lockstep") as s:
        yield s


def test_a_goal_succeeds_with_feedback_in_lockstep(session):
    with connect(session.url) as client:
        start = client.step(0)
        goal = client.send_goal(ARM, FJT, _goal(TARGET, 0.6))
        first = goal.wait_for_feedback(sim_timeout=1.0)
        assert first["joint_names"] == JOINTS
        assert len(first["actual"]["positions"]) == 7
        result = goal.result(sim_timeout=5.0)
        assert result == GoalResult(
            4, {"error_code": 0, "error_string": "Goal successfully reached!"}
        )
        assert result.succeeded
        assert goal.done
        # the client stepped the session: about the trajectory's 0.6 s, feedback at 20 Hz
        elapsed = (client.step(0) - start) / 1e9
        assert 0.6 <= elapsed < 2.0
        assert len(goal.feedback) >= 10
        positions = dict(
            zip(
                client.state()["joint_state"]["name"],
                client.state()["joint_state"]["position"],
                strict=True,
            )
        )
    for joint, target in zip(JOINTS, TARGET, strict=True):
        assert abs(positions[joint] - target) < 0.01, joint


def test_cancel_ends_the_goal_canceled(session):
    with connect(session.url) as client:
        goal = client.send_goal(ARM, FJT, _goal(TARGET, 2.0))
        client.step(50)
        assert not goal.done
        goal.cancel()
        result = goal.result(sim_timeout=1.0)
        assert result.status == GoalResult.CANCELED


def test_a_goal_not_ended_in_time_is_a_sim_time_timeout(session):
    with connect(session.url) as client:
        goal = client.send_goal(ARM, FJT, _goal(TARGET, 2.0))
        with pytest.raises(TestClientTimeout, match=r"not within 0.1 s of simulation time"):
            goal.result(sim_timeout=0.1)


def test_an_unknown_action_is_one_line(session):
    with connect(session.url) as client:
        goal = client.send_goal("/no_such/action", FJT, {})
        with pytest.raises(ActionGoalFailed, match=r"/no_such/action.*does not exist"):
            goal.result(sim_timeout=0.1)
