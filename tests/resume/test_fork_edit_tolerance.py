"""A fork with a changed JTC tolerance turns a failing run into a passing one: the parent's
trajectory controller has tight path tolerances and aborts the client's goal; resumed before
the goal with ``param.joint_trajectory_controller.constraints.<joint>.trajectory`` widened and
fed the parent's frames, the same goal succeeds. The edit is recorded as the fork step's input:
the child replays on its own."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from harness import Session
from harness.cli import main
from harness.recording import Recording
from harness.testing import connect

from .conftest import ARM, FJT, JOINTS, TARGET, feed, goal, incoming_after, states

SUCCEEDED, ABORTED = 4, 6
FORK = 50
STEPS = 600
CONTROLLERS = f"""
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster
    joint_trajectory_controller:
      type: joint_trajectory_controller/JointTrajectoryController
joint_trajectory_controller:
  ros__parameters:
    joints: {json.dumps(JOINTS)}
    command_interfaces: [position]
    state_interfaces: [position, velocity]
    constraints:
{"".join(f"      {j}: {{trajectory: 0.002}}{chr(10)}" for j in JOINTS)}"""


def _results(path: Path, start: int = 0) -> list[int]:
    with Recording(path) as rec:
        return [
            json.loads(f.text)["status"]
            for f in rec.bridge_frames(start)
            if f.direction == 1 and f.op == "action_result"
        ]


@pytest.fixture(scope="module")
def failing(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The failing run: the goal, sent after step 50, is aborted on a path tolerance."""
    path = tmp_path_factory.mktemp("tolerance") / "failing.mcap"
    with (
        Session("demo", clock="lockstep", controllers=CONTROLLERS, record_to=path) as session,
        connect(session.url) as client,
    ):
        client.step(FORK)
        handle = client.send_goal(ARM, FJT, goal(TARGET, 0.6))
        for _ in range((STEPS - FORK) // 50):
            client.step(50)
        result = handle.result(sim_timeout=0.0)
    assert result.status == ABORTED
    assert "path tolerance" in result.values["error_string"]
    return path


def test_a_wider_tolerance_at_the_fork_makes_the_goal_succeed(
    failing: Path, tmp_path: Path
) -> None:
    child = tmp_path / "passing.mcap"
    edits = [f"param.joint_trajectory_controller.constraints.{j}.trajectory=0.5" for j in JOINTS]
    with Session.resume(failing, step=FORK, record_to=child, edits=edits) as session:
        feed(session, incoming_after(failing, FORK), STEPS)
    assert _results(failing) == [ABORTED]
    assert _results(child) == [SUCCEEDED]
    # the same run up to the fork; the edit is the child's input at the step after it
    assert {k: v for k, v in states(child).items() if k <= FORK} == {
        k: v for k, v in states(failing).items() if k <= FORK
    }
    with Recording(child) as rec:
        (marker,) = [f for f in rec.bridge_frames(FORK) if f.topic == "harness/python"][:1]
    assert marker.step == FORK + 1
    assert json.loads(marker.text) == {
        "call": "set_parameter",
        "controller": "joint_trajectory_controller",
        "name": "constraints.joint1.trajectory",
        "value": 0.5,
    }
    assert main(["replay", str(child), "--level", "full"]) == 0


def test_a_parameter_the_controller_cannot_change_is_one_line(
    failing: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["serve", "--port", "0", "--from", str(failing), "--at", str(FORK), "--set"]
    assert main([*args, "param.joint_trajectory_controller.gains.joint1.p=3"]) == 2
    err = capsys.readouterr().err
    assert "'gains.joint1.p' is not a parameter that can change while running" in err
    assert err.count("\n") == 1
    assert main([*args, "param.nope.constraints.goal_time=1"]) == 2
    err = capsys.readouterr().err
    assert "no controller 'nope' (controllers: joint_state_broadcaster, " in err
