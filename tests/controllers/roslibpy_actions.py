"""A roslibpy client run in its own process (twisted's reactor runs once per process):
python roslibpy_actions.py PORT

Drives the demo arm's controllers through their actions on a lockstep session, stepping with
/harness/step, and prints one JSON line per case ({"case": ..., ...}), then "OK".
"""

from __future__ import annotations

import json
import sys
import threading
from typing import Any

import roslibpy

TIMEOUT = 10.0
JOINTS = [f"joint{i}" for i in range(1, 8)]
HOME = [0.0, 0.0, 0.0, -1.57079, 0.0, 1.57079, -0.7853]
TARGET = [0.3, 0.2, 0.1, -1.4, 0.1, 1.8, -0.5]
FJT = "control_msgs/action/FollowJointTrajectory"
ARM = "/joint_trajectory_controller/follow_joint_trajectory"


def duration(seconds: float) -> dict[str, int]:
    ns = round(seconds * 1e9)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


class Goal:
    """One goal in flight: its feedback and result."""

    def __init__(self, client: roslibpy.ActionClient, goal: dict[str, Any]) -> None:
        self.feedback: list[dict[str, Any]] = []
        self.result: dict[str, Any] | None = None
        self.done = threading.Event()
        self.id = client.send_goal(
            goal, self._result, lambda f: self.feedback.append(dict(f)), self._error
        )

    def _result(self, result: Any) -> None:
        self.result = {"status": int(result["status"].value), "values": result["values"]}
        self.done.set()

    def _error(self, error: Any) -> None:
        self.result = {"error": str(error)}
        self.done.set()


class Driver:
    def __init__(self, port: int) -> None:
        self.ros = roslibpy.Ros("127.0.0.1", port)
        self.ros.run(timeout=TIMEOUT)
        self.step_srv = roslibpy.Service(self.ros, "/harness/step", "harness_msgs/srv/Step")
        self.state_srv = roslibpy.Service(
            self.ros, "/harness/get_state", "harness_msgs/srv/GetState"
        )
        self.arm = roslibpy.ActionClient(self.ros, ARM, FJT)
        self.gripper = roslibpy.ActionClient(
            self.ros, "/gripper_controller/gripper_cmd", "control_msgs/action/GripperCommand"
        )

    def step(self, n: int) -> None:
        self.step_srv.call(roslibpy.ServiceRequest({"steps": n}), timeout=TIMEOUT)

    def until_done(self, goal: Goal, chunk: int = 50, limit: int = 4000) -> None:
        for _ in range(limit // chunk):
            if goal.done.wait(0.0):
                return
            self.step(chunk)
        goal.done.wait(TIMEOUT)

    def positions(self) -> dict[str, float]:
        state = self.state_srv.call(roslibpy.ServiceRequest({}), timeout=TIMEOUT)
        js = state["joint_state"]
        return dict(zip(js["name"], js["position"], strict=True))

    def now(self) -> float:
        state = self.state_srv.call(roslibpy.ServiceRequest({}), timeout=TIMEOUT)
        return state["sim_time"]["sec"] + state["sim_time"]["nanosec"] / 1e9


def trajectory(positions: list[float], seconds: float, names: list[str] = JOINTS) -> dict:
    return {
        "joint_names": names,
        "points": [{"positions": positions, "time_from_start": duration(seconds)}],
    }


def emit(case: str, goal: Goal, **extra: Any) -> None:
    print(
        json.dumps(
            {
                "case": case,
                "result": goal.result,
                "feedback": len(goal.feedback),
                "first_feedback": goal.feedback[0] if goal.feedback else None,
                **extra,
            }
        ),
        flush=True,
    )


def main() -> int:
    d = Driver(int(sys.argv[1]))
    tolerance = [
        {"name": j, "position": 0.01, "velocity": 0.0, "acceleration": 0.0} for j in JOINTS
    ]

    goal = Goal(
        d.arm,
        {
            "trajectory": trajectory(TARGET, 0.6),
            "goal_tolerance": tolerance,
            "goal_time_tolerance": duration(1.0),
        },
    )
    d.until_done(goal)
    emit("success", goal, positions=d.positions())

    goal = Goal(d.arm, {"trajectory": trajectory([*HOME[:6], 0.0], 0.5, [*JOINTS[:6], "elbow"])})
    d.until_done(goal)
    emit("unknown_joint", goal)

    bad = trajectory(HOME, 0.5)
    bad["points"] = [
        {"positions": HOME, "time_from_start": duration(0.5)},
        {"positions": TARGET, "time_from_start": duration(0.5)},
    ]
    goal = Goal(d.arm, {"trajectory": bad})
    d.until_done(goal)
    emit("non_increasing", goal)

    d.step(100)
    past = trajectory(HOME, 0.1)
    past["header"] = {"stamp": duration(0.05), "frame_id": ""}
    goal = Goal(d.arm, {"trajectory": past})
    d.until_done(goal)
    emit("past_start", goal, now=d.now())

    path = [{"name": j, "position": 1e-4, "velocity": 0.0, "acceleration": 0.0} for j in JOINTS]
    goal = Goal(d.arm, {"trajectory": trajectory(HOME, 0.3), "path_tolerance": path})
    d.until_done(goal)
    emit("path_tolerance", goal)

    first = Goal(d.arm, {"trajectory": trajectory(HOME, 1.0)})
    d.step(50)
    second = Goal(
        d.arm,
        {"trajectory": trajectory(TARGET, 0.5), "goal_time_tolerance": duration(1.0),
         "goal_tolerance": tolerance},
    )  # fmt: skip
    d.until_done(second)
    first.done.wait(TIMEOUT)
    emit("preempted", first)
    emit("preempting", second, positions=d.positions())

    goal = Goal(d.arm, {"trajectory": trajectory(HOME, 2.0)})
    d.step(50)
    d.arm.cancel_goal(goal.id)
    d.step(1)
    goal.done.wait(TIMEOUT)
    emit("canceled", goal)

    goal = Goal(d.gripper, {"command": {"position": 0.02, "max_effort": 10.0}})
    d.until_done(goal)
    emit("gripper", goal)

    listing = roslibpy.Service(
        d.ros, "/controller_manager/list_controllers", "controller_manager_msgs/srv/ListControllers"
    ).call(roslibpy.ServiceRequest({}), timeout=TIMEOUT)
    print(json.dumps({"case": "list_controllers", "controllers": listing["controller"]}))
    print("OK", flush=True)
    d.ros.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
