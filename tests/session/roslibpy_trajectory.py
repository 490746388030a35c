"""A roslibpy client run in its own process (twisted's reactor runs once per process):
python roslibpy_trajectory.py PORT

Subscribes to /joint_states, sends one trajectory for the demo arm on /joint_trajectory, then
drives the lockstep clock with /harness/step (50 x 10 steps). Prints every /joint_states
message it received as one JSON line, then "OK".
"""

from __future__ import annotations

import json
import sys

import roslibpy

TIMEOUT = 10.0


def main() -> int:
    ros = roslibpy.Ros("127.0.0.1", int(sys.argv[1]))
    ros.run(timeout=TIMEOUT)
    states: list[dict] = []
    listener = roslibpy.Topic(ros, "/joint_states", "sensor_msgs/JointState")
    listener.subscribe(states.append)
    trajectory = roslibpy.Topic(ros, "/joint_trajectory", "trajectory_msgs/JointTrajectory")
    trajectory.publish(
        roslibpy.Message(
            {
                "joint_names": ["joint1", "joint2", "joint4"],
                "points": [
                    {
                        "positions": [0.5, -0.3, -2.0],
                        "time_from_start": {"sec": 0, "nanosec": 400_000_000},
                    },
                    {
                        "positions": [-0.2, -0.6, -1.6],
                        "time_from_start": {"sec": 0, "nanosec": 800_000_000},
                    },
                ],
            }
        )
    )
    step = roslibpy.Service(ros, "/harness/step", "harness_msgs/Step")
    for _ in range(50):
        answer = step.call(roslibpy.ServiceRequest({"steps": 10}), timeout=TIMEOUT)
    print(json.dumps({"states": states, "last_answer": dict(answer)}), flush=True)
    ros.terminate()
    print("OK", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
