"""The demo's client under test: drives the demo arm through the rosbridge bridge with roslibpy.

It connects to HARNESS_ROSBRIDGE_URL, then, in lockstep with the simulation, repeatedly
publishes the scripted joint targets (``harness.demo.trajectory``: the hand sweeps through the
box on the table) as a ``sensor_msgs/msg/JointState`` on the command topic and calls
``/harness/step`` for the next ``--every`` steps, until ``--seconds`` of simulation time have
passed. Each step call is answered once its steps are done, and the command published before
it takes effect before them, so the run is the same every time. Exits 0 when done, 1 on an
error (printed).

Usage: python demo_arm.py [--seconds 5] [--every 10] [--topic /joint_command]
"""

import argparse
import os
import sys
from urllib.parse import urlparse

import roslibpy

from harness.demo import JOINTS, trajectory


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="simulation seconds to drive")
    parser.add_argument("--every", type=int, default=10, help="steps per command")
    parser.add_argument("--topic", default="/joint_command", help="the joint command topic")
    args = parser.parse_args()
    url = urlparse(os.environ["HARNESS_ROSBRIDGE_URL"])
    ros = roslibpy.Ros(host=url.hostname, port=url.port)
    ros.run(timeout=10)
    # Small frames go out at once (Nagle's algorithm would hold each command ~40 ms).
    ros.factory.on_ready(lambda protocol: protocol.transport.setTcpNoDelay(True))
    try:
        command = roslibpy.Topic(ros, args.topic, "sensor_msgs/msg/JointState")
        command.advertise()
        step = roslibpy.Service(ros, "/harness/step", "harness_msgs/srv/Step")
        now = 0.0
        calls = 0
        while now < args.seconds - 1e-9:
            positions, _ = trajectory(now)
            command.publish(
                roslibpy.Message({"name": list(JOINTS), "position": positions.tolist()})
            )
            answer = step.call(roslibpy.ServiceRequest({"steps": args.every}), timeout=30)
            now = answer["sim_time"]["sec"] + answer["sim_time"]["nanosec"] / 1e9
            calls += 1
        print(f"drove the arm to sim time {now:.3f} s in {calls} step calls", flush=True)
        command.unadvertise()
        return 0
    except Exception as exc:
        print(f"demo_arm: {type(exc).__name__}: {exc}", flush=True)
        return 1
    finally:
        ros.terminate()


if __name__ == "__main__":
    sys.exit(main())
