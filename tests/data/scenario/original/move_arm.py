"""A client under test in the original framework's style: publishes one JointState on
/joint/states (the demo arm's joint1, joint2, ... to the positions given as arguments, finger
last when eight are given) and exits 0 once the simulation clock passed ``0.8`` s."""

import os
import sys
import threading
from urllib.parse import urlparse

import roslibpy

JOINTS = [*(f"joint{i}" for i in range(1, 8)), "finger_joint1"]

url = urlparse(os.environ["HARNESS_ROSBRIDGE_URL"])
ros = roslibpy.Ros(host=url.hostname, port=url.port)
ros.run(timeout=10)
target = [float(x) for x in sys.argv[1:]]
command = roslibpy.Topic(ros, "/joint/states", "sensor_msgs/msg/JointState")
command.advertise()
done = threading.Event()


def on_clock(message):
    if message["clock"]["sec"] + message["clock"]["nanosec"] / 1e9 > 0.8:
        done.set()


clock = roslibpy.Topic(ros, "/clock", "rosgraph_msgs/msg/Clock")
clock.subscribe(on_clock)
command.publish(roslibpy.Message({"name": JOINTS[: len(target)], "position": target}))
ok = done.wait(30)
ros.terminate()
sys.exit(0 if ok else 1)
