"""A client under test with a bug that needs two parameters: it leans the demo arm toward a
reach target (TARGET_X, metres) at a speed profile (MODE: slow | fast). The fast profile
scales the shoulder lean by its speed gain (3x), a bug that only matters for a far target:
TARGET_X 0.3 with MODE fast drives the arm (turned away from the table) into the floor;
every other pair is fine.

Lockstep over raw rosbridge v2 frames (websockets): publishes the joint command, then calls
/harness/step 25 steps at a time until SECONDS (argv[1]) of simulation time.
"""

import json
import os
import sys

from websockets.sync.client import connect

seconds = float(sys.argv[1])
reach = float(os.environ.get("TARGET_X", "0.1"))
mode = os.environ.get("MODE", "slow")
shoulder = 0.2 + reach
if mode == "fast" and reach > 0.25:
    shoulder *= 3  # the bug: the speed gain applied to the lean too
topic = "/joint_command"
with connect(os.environ["HARNESS_ROSBRIDGE_URL"]) as ws:
    ws.send(json.dumps({"op": "advertise", "topic": topic, "type": "sensor_msgs/msg/JointState"}))
    now, calls = 0.0, 0
    while now < seconds - 1e-9:
        msg = {"name": ["joint1", "joint2", "joint4"], "position": [-1.5, shoulder, -1.6]}
        ws.send(json.dumps({"op": "publish", "topic": topic, "msg": msg}))
        calls += 1
        ws.send(
            json.dumps(
                {
                    "op": "call_service",
                    "id": f"step{calls}",
                    "service": "/harness/step",
                    "type": "harness_msgs/srv/Step",
                    "args": {"steps": 25},
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
print(f"reached {now:.3f} s", flush=True)
