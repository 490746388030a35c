"""The pick-and-place controller: robot software that talks to its robot through rosbridge
with roslibpy, exactly as it would talk to the real arm.

It takes the arm from its home pose above the box (approach), down to a pre-grasp pose just
above it, holds, and back home: one ``trajectory_msgs/JointTrajectory`` on
``/joint_trajectory`` (linear interpolation in joint space between the waypoints). Because the
simulation runs in lockstep, the controller advances time itself with the ``/harness/step``
service, one control period at a time, and checks the tracking error on ``/joint_states``
after each: the run is the same every time, whatever the machine's speed.

Run: ``python -m pick_and_place.controller ws://127.0.0.1:PORT``; prints one JSON line (the
final joint positions and the largest tracking error) and exits 0 when the arm came home.
"""

from __future__ import annotations

import itertools
import json
import sys
import threading
from collections.abc import Sequence
from typing import Any

import roslibpy

ARM = ("joint1", "joint2", "joint3", "joint4", "joint5", "joint6", "joint7", "finger_joint1")
HOME = (0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398, 0.04)
ABOVE_BOX = (0.0, -0.1944, 0.0, -1.9182, 0.0, 1.7238, 0.785398, 0.04)  # hand 25 cm above
PRE_GRASP = (0.0, -0.179, 0.0, -2.1319, 0.0, 1.9529, 0.785398, 0.04)  # pads 2.5 cm above
# (time in s, pose): the path, linearly interpolated in joint space.
PLAN: tuple[tuple[float, Sequence[float]], ...] = (
    (0.0, HOME),
    (1.0, ABOVE_BOX),
    (1.6, PRE_GRASP),
    (2.0, PRE_GRASP),
    (2.6, ABOVE_BOX),
    (3.6, HOME),
)
DT = 0.002  # the demo world's timestep (s)
PERIOD_STEPS = 25  # check the tracking every 50 ms of simulation time
SETTLE_S = 0.4  # after the last waypoint, let the arm settle
HOME_TOLERANCE = 0.02  # rad (m for the finger)
TIMEOUT = 10.0  # wall-clock bound on one bridge round trip (a dead server), never a wait


def setpoint(t: float) -> list[float]:
    """The planned joint positions at time ``t`` (s)."""
    for (t0, a), (t1, b) in itertools.pairwise(PLAN):
        if t <= t1:
            u = 0.0 if t1 == t0 else max(0.0, (t - t0) / (t1 - t0))
            return [x + u * (y - x) for x, y in zip(a, b, strict=True)]
    return list(PLAN[-1][1])


class Controller:
    """Connects to the robot's rosbridge at ``url`` and runs the plan."""

    def __init__(self, url: str) -> None:
        self.ros = roslibpy.Ros(url)
        self.ros.run(timeout=TIMEOUT)
        self._lock = threading.Lock()
        self.positions: dict[str, float] = {}
        self.states = roslibpy.Topic(self.ros, "/joint_states", "sensor_msgs/JointState")
        self.states.subscribe(self._on_state)
        self.command = roslibpy.Topic(
            self.ros, "/joint_trajectory", "trajectory_msgs/JointTrajectory"
        )
        self.command.advertise()
        self.step = roslibpy.Service(self.ros, "/harness/step", "harness_msgs/Step")

    def _on_state(self, msg: dict[str, Any]) -> None:
        with self._lock:
            self.positions = dict(zip(msg["name"], msg["position"], strict=True))

    def run(self) -> dict[str, Any]:
        """Follow the plan; returns the final positions and the largest tracking error."""
        points = [
            {
                "positions": list(pose),
                "time_from_start": {"sec": int(t), "nanosec": round((t - int(t)) * 1e9)},
            }
            for t, pose in PLAN[1:]
        ]
        # Starts when the session applies it: before the first step below.
        self.command.publish(roslibpy.Message({"joint_names": list(ARM), "points": points}))
        t_end = PLAN[-1][0] + SETTLE_S
        k = 0
        worst = 0.0
        seen: list[float] = []
        while k * DT < t_end - 1e-9:
            self.step.call(roslibpy.ServiceRequest({"steps": PERIOD_STEPS}), timeout=TIMEOUT)
            k += PERIOD_STEPS
            with self._lock:
                seen = [self.positions.get(j, float("nan")) for j in ARM]
            worst = max(worst, max(abs(a - b) for a, b in zip(seen, setpoint(k * DT), strict=True)))
        final = dict(zip(ARM, seen, strict=True))
        home_error = max(abs(final[j] - h) for j, h in zip(ARM, HOME, strict=True))
        return {"final": final, "max_tracking_error": worst, "home_error": home_error}

    def close(self) -> None:
        """Disconnect and stop roslibpy's event loop (once per process)."""
        self.states.unsubscribe()
        self.command.unadvertise()
        self.ros.terminate()


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m pick_and_place.controller URL``."""
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 1 or not args[0].startswith("ws://"):
        print("usage: python -m pick_and_place.controller ws://HOST:PORT", file=sys.stderr)
        return 2
    controller = Controller(args[0])
    try:
        result = controller.run()
    finally:
        controller.close()
    print(json.dumps(result), flush=True)
    return 0 if result["home_error"] < HOME_TOLERANCE else 1


if __name__ == "__main__":
    sys.exit(main())
