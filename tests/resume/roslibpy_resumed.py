"""A roslibpy client run in its own process (twisted's reactor runs once per process) against
a resumed session: python roslibpy_resumed.py PORT

Reads where the resumed run stands, steps it until the goal the recorded client left in
flight has moved the arm to its target, then sends a goal of its own back home and steps until
it is done. Prints one JSON line, then "OK".
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
FJT = "control_msgs/action/FollowJointTrajectory"
ARM = "/joint_trajectory_controller/follow_joint_trajectory"


def main() -> int:
    ros = roslibpy.Ros("127.0.0.1", int(sys.argv[1]))
    ros.run(timeout=TIMEOUT)
    step = roslibpy.Service(ros, "/harness/step", "harness_msgs/srv/Step")
    get_state = roslibpy.Service(ros, "/harness/get_state", "harness_msgs/srv/GetState")

    def state() -> dict[str, Any]:
        return dict(get_state.call(roslibpy.ServiceRequest({}), timeout=TIMEOUT))

    def positions() -> dict[str, float]:
        js = state()["joint_state"]
        return dict(zip(js["name"], js["position"], strict=True))

    start = state()["step"]
    step.call(roslibpy.ServiceRequest({"steps": 400}), timeout=TIMEOUT)
    reached = positions()
    done = threading.Event()
    result: dict[str, Any] = {}

    def on_result(r: Any) -> None:
        result.update(status=int(r["status"].value), values=r["values"])
        done.set()

    client = roslibpy.ActionClient(ros, ARM, FJT)
    client.send_goal(
        {
            "trajectory": {
                "joint_names": JOINTS,
                "points": [
                    {"positions": HOME, "time_from_start": {"sec": 0, "nanosec": 600_000_000}}
                ],
            },
            "goal_time_tolerance": {"sec": 1, "nanosec": 0},
        },
        on_result,
        lambda feedback: None,
        lambda error: (result.update(error=str(error)), done.set()),
    )
    for _ in range(40):
        if done.wait(0.0):
            break
        step.call(roslibpy.ServiceRequest({"steps": 50}), timeout=TIMEOUT)
    done.wait(TIMEOUT)
    home = positions()
    print(
        json.dumps(
            {"start": start, "reached": reached, "result": result, "home": home,
             "end": state()["step"]}
        ),
        flush=True,
    )  # fmt: skip
    ros.terminate()
    print("OK", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
