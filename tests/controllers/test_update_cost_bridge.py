"""What a client of the demo arm's joint_trajectory_controller sees over the real bridge
(``~/controller_state``, FollowJointTrajectory feedback and results, the joints it moved) is what
it was before the controllers' per-update shortcuts (issue 36's speed): pinned, every bit."""

from __future__ import annotations

import hashlib
import json
from typing import Any

from harness import Session
from harness.testing import connect

JOINTS = [f"joint{i}" for i in range(1, 8)]
TARGET = [0.3, 0.2, 0.1, -1.4, 0.1, 1.8, -0.5]
MIDDLE = [0.15, 0.1, 0.05, -1.5, 0.05, 1.7, -0.6]
ARM = "/joint_trajectory_controller"
FJT = "control_msgs/action/FollowJointTrajectory"
STATE = "control_msgs/msg/JointTrajectoryControllerState"
PINNED = "22ffcb99682dc05e35747c1f4281bf66558d44f793ee4a13ba03386cbfbbd7c0"
"""SHA-256 of the transcript below from the controller before the shortcuts (main at 16c044b)."""


def _duration(seconds: float) -> dict[str, int]:
    ns = round(seconds * 1e9)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def _goal(points: list[tuple[float, list[float], list[float] | None]]) -> dict[str, Any]:
    return {
        "trajectory": {
            "joint_names": JOINTS,
            "points": [
                {
                    "positions": positions,
                    "velocities": velocities or [],
                    "time_from_start": _duration(t),
                }
                for t, positions, velocities in points
            ],
        },
        "goal_time_tolerance": _duration(0.5),
    }


def test_what_a_client_sees_of_the_trajectory_controller_is_pinned() -> None:
    transcript: list[Any] = []
    with Session("demo") as session, connect(session.url) as client:
        state = client.subscribe(f"{ARM}/controller_state", STATE)
        client.step(6)  # holding where it starts
        cubic = _goal([(0.2, MIDDLE, [0.5] * 7), (0.4, TARGET, [0.0] * 7)])
        first = client.send_goal(f"{ARM}/follow_joint_trajectory", FJT, cubic)
        result = first.result(sim_timeout=3.0)
        transcript += [["first", result.status, result.values, first.feedback]]
        back = client.send_goal(f"{ARM}/follow_joint_trajectory", FJT, _goal([(0.5, MIDDLE, None)]))
        client.step(60)
        back.cancel()
        result = back.result(sim_timeout=1.0)
        transcript += [["canceled", result.status, result.values, back.feedback]]
        client.step(25)  # holding where it stopped
        client.sync()
        joints = client.state()["joint_state"]
        transcript += [["state", state.messages], ["joints", joints]]
    assert transcript[0][1] == 4, transcript[0][2]  # succeeded
    assert len(transcript[0][3]) >= 8  # feedback at 20 Hz
    assert transcript[1][1] == 5
    text = json.dumps(transcript, sort_keys=True)
    assert hashlib.sha256(text.encode()).hexdigest() == PINNED
