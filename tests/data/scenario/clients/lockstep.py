"""A lockstep client under test over raw rosbridge v2 frames (websockets).

Usage: lockstep.py SECONDS JOINT [TOPIC]

Connects to $HARNESS_ROSBRIDGE_URL, advertises TOPIC (default /joint_command) as
sensor_msgs/msg/JointState, then until SECONDS of simulation time: publishes a position for
JOINT (0.5 sin(2 pi t)) and calls /harness/step for 10 steps, waiting for each answer.
Prints the sim time reached and exits 0; exits 1 when a step call fails.
"""

import json
import math
import os
import sys

from websockets.sync.client import connect

seconds, joint = float(sys.argv[1]), sys.argv[2]
topic = sys.argv[3] if len(sys.argv) > 3 else "/joint_command"
with connect(os.environ["HARNESS_ROSBRIDGE_URL"]) as ws:
    ws.send(json.dumps({"op": "advertise", "topic": topic, "type": "sensor_msgs/msg/JointState"}))
    now, calls = 0.0, 0
    while now < seconds - 1e-9:
        target = 0.5 * math.sin(2 * math.pi * now)
        ws.send(
            json.dumps(
                {"op": "publish", "topic": topic, "msg": {"name": [joint], "position": [target]}}
            )
        )
        calls += 1
        ws.send(
            json.dumps(
                {
                    "op": "call_service",
                    "id": f"step{calls}",
                    "service": "/harness/step",
                    "type": "harness_msgs/srv/Step",
                    "args": {"steps": 10},
                }
            )
        )
        while True:
            frame = json.loads(ws.recv())
            if frame.get("op") == "service_response" and frame.get("id") == f"step{calls}":
                break
        if not frame.get("result"):
            print(f"step call failed: {frame}", flush=True)
            sys.exit(1)
        stamp = frame["values"]["sim_time"]
        now = stamp["sec"] + stamp["nanosec"] / 1e9
print(f"reached {now:.3f} s in {calls} step calls", flush=True)
