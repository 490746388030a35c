"""The mobile demo's client under test: drives the bundled mobile robot around a square and
back to its start through the rosbridge bridge with roslibpy.

It connects to HARNESS_ROSBRIDGE_URL and, in lockstep with the simulation, steers by the
robot's wheel odometry (``/odom``): for each corner of a ``--side`` metre square (counter-
clockwise, ending where it started) it turns in place to face the corner, then drives to it,
publishing a ``geometry_msgs/msg/Twist`` on ``/cmd_vel`` and calling ``/harness/step`` for
the next ``--every`` steps. Exits 0 when back at the start, 1 on an error or when
``--seconds`` of simulation time ran out (printed).

Usage: python mobile_square.py [--side 1.0] [--seconds 60] [--every 25]
"""

import argparse
import math
import os
import sys
import threading
from urllib.parse import urlparse

import roslibpy

MAX_LINEAR = 0.25  # m/s
MAX_ANGULAR = 1.2  # rad/s


def _clamp(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


def _wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", type=float, default=1.0, help="side of the square (m)")
    parser.add_argument("--seconds", type=float, default=60.0, help="simulation time budget")
    parser.add_argument("--every", type=int, default=25, help="steps per command")
    args = parser.parse_args()
    url = urlparse(os.environ["HARNESS_ROSBRIDGE_URL"])
    ros = roslibpy.Ros(host=url.hostname, port=url.port)
    ros.run(timeout=10)
    ros.factory.on_ready(lambda protocol: protocol.transport.setTcpNoDelay(True))
    pose = {"x": 0.0, "y": 0.0, "yaw": 0.0}
    lock = threading.Lock()

    def on_odom(msg: dict) -> None:
        p, q = msg["pose"]["pose"]["position"], msg["pose"]["pose"]["orientation"]
        with lock:
            pose["x"], pose["y"] = p["x"], p["y"]
            pose["yaw"] = math.atan2(
                2 * (q["w"] * q["z"] + q["x"] * q["y"]), 1 - 2 * (q["y"] ** 2 + q["z"] ** 2)
            )

    try:
        odom = roslibpy.Topic(ros, "/odom", "nav_msgs/msg/Odometry")
        odom.subscribe(on_odom)
        cmd = roslibpy.Topic(ros, "/cmd_vel", "geometry_msgs/msg/Twist")
        cmd.advertise()
        step = roslibpy.Service(ros, "/harness/step", "harness_msgs/srv/Step")
        now = 0.0

        def drive(linear: float, angular: float) -> None:
            nonlocal now
            cmd.publish(
                roslibpy.Message(
                    {
                        "linear": {"x": linear, "y": 0.0, "z": 0.0},
                        "angular": {"x": 0.0, "y": 0.0, "z": angular},
                    }
                )
            )
            answer = step.call(roslibpy.ServiceRequest({"steps": args.every}), timeout=30)
            now = answer["sim_time"]["sec"] + answer["sim_time"]["nanosec"] / 1e9
            if now > args.seconds:
                raise TimeoutError(f"not back at the start after {now:.1f} s of sim time")

        side = args.side
        corners = [(side, 0.0), (side, side), (0.0, side), (0.0, 0.0)]
        for cx, cy in corners:
            while True:  # face the corner
                with lock:
                    x, y, yaw = pose["x"], pose["y"], pose["yaw"]
                error = _wrap(math.atan2(cy - y, cx - x) - yaw)
                if abs(error) < 0.01:
                    break
                drive(0.0, _clamp(3.0 * error, MAX_ANGULAR))
            while True:  # drive to it, steering on the way
                with lock:
                    x, y, yaw = pose["x"], pose["y"], pose["yaw"]
                distance = math.hypot(cx - x, cy - y)
                if distance < 0.02:
                    break
                error = _wrap(math.atan2(cy - y, cx - x) - yaw)
                linear = _clamp(1.5 * distance, MAX_LINEAR) * max(0.0, math.cos(error))
                drive(linear, _clamp(3.0 * error, MAX_ANGULAR))
            print(f"corner ({cx:g}, {cy:g}) reached at sim time {now:.2f} s", flush=True)
        for _ in range(10):  # stop
            drive(0.0, 0.0)
        with lock:
            print(f"back at ({pose['x']:.3f}, {pose['y']:.3f}) by odometry", flush=True)
        cmd.unadvertise()
        return 0
    except Exception as exc:
        print(f"mobile_square: {type(exc).__name__}: {exc}", flush=True)
        return 1
    finally:
        ros.terminate()


if __name__ == "__main__":
    sys.exit(main())
