"""A mobile robot's controller under test: drive straight at SPEED (m/s, env) to a stop point
GOAL metres ahead (by wheel odometry, /odom), then stop. Its bug: it commands zero only once
the odometry says it is *past* the goal (no braking distance, checked once per 0.1 s control
period), so it overshoots by a period's travel plus the braking distance (the drive's
deceleration is limited): above some speed the robot runs into the wall behind the stop point.

Lockstep over raw rosbridge v2 frames: publishes geometry_msgs/Twist on /cmd_vel, calls
/harness/step for one period at a time until SECONDS (argv[1]) of simulation time.
"""

import json
import os
import sys

from websockets.sync.client import connect

seconds = float(sys.argv[1])
speed = float(os.environ.get("SPEED", "0.2"))
goal = float(os.environ.get("GOAL", "0.5"))
period_steps = 50  # 0.1 s at 2 ms
with connect(os.environ["HARNESS_ROSBRIDGE_URL"]) as ws:
    ws.send(json.dumps({"op": "advertise", "topic": "/cmd_vel", "type": "geometry_msgs/msg/Twist"}))
    ws.send(json.dumps({"op": "subscribe", "topic": "/odom", "type": "nav_msgs/msg/Odometry"}))
    now, calls, travelled, v = 0.0, 0, 0.0, speed
    while now < seconds - 1e-9:
        if travelled >= goal:
            v = 0.0  # the bug: stops only once past the goal
        twist = {"linear": {"x": v, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
        ws.send(json.dumps({"op": "publish", "topic": "/cmd_vel", "msg": twist}))
        calls += 1
        ws.send(
            json.dumps(
                {
                    "op": "call_service",
                    "id": f"step{calls}",
                    "service": "/harness/step",
                    "type": "harness_msgs/srv/Step",
                    "args": {"steps": period_steps},
                }
            )
        )
        while True:
            frame = json.loads(ws.recv())
            if frame.get("op") == "publish" and frame.get("topic") == "/odom":
                travelled = frame["msg"]["pose"]["pose"]["position"]["x"]
            if frame.get("op") == "service_response" and frame.get("id") == f"step{calls}":
                break
        if not frame.get("result"):
            print(f"step call failed: {frame}", flush=True)
            sys.exit(1)
        stamp = frame["values"]["sim_time"]
        now = stamp["sec"] + stamp["nanosec"] / 1e9
print(f"odometry {travelled:.3f} m at {now:.3f} s", flush=True)
