"""Real ROS 2 nodes against the harness (needs `make ros2`; rows say so when it is missing).

- ``/joint_states`` at 1 kHz delivered to an rclpy node over DDS (``Session(ros2=True)``, fast
  clock, 1 kHz sim rate): messages the node received per simulated second, against what a raw
  rclpy publisher at 1 kHz delivers between two processes in the same run (same counter node);
  and the same through rosbridge-server-rs with the session connected to it as a client.
- Service round trip from a node: ``/harness/get_state`` (answered at once) called N times
  through the gateway, and the same through rosbridge-server-rs with the session connected to
  it as a client; the limit is a raw rclpy service (``std_srvs/srv/Trigger``) in another process.
- Command -> applied latency: a node publishes ``/joint_command`` (joint1 to +-0.3 in turn) and
  waits for the first ``/joint_states`` whose joint1 effort has the new command's sign (the
  position actuator's force turns at the next step); realtime, 1 kHz sim rate, 1 kHz
  ``/joint_states``. The limit is a raw rclpy ping-pong (publish, echo node, back) between two
  processes.
"""

from __future__ import annotations

import json
import subprocess
import sys

from common import Row

from harness.models import load_robot
from harness.ros2 import Ros2Unavailable, choose_domain_id, find_ros2
from harness.ros2.testing import rosbridge_server, run_node, start_node
from harness.session import Session

_COUNT = r"""
import json, sys, time, rclpy
from sensor_msgs.msg import JointState
rclpy.init(); node = rclpy.create_node("counter")
got = []
node.create_subscription(JointState, "/joint_states", lambda m: got.append(1), 1000)
print("ready", flush=True)
deadline = None
while True:
    rclpy.spin_once(node, timeout_sec=0.1)
    if got and deadline is None:
        deadline = time.monotonic() + float(sys.argv[1])
        got.clear()
    if deadline is not None and time.monotonic() >= deadline:
        break
print(json.dumps({"count": len(got)}), flush=True)
"""

_RAW_PUB = r"""
import sys, time, rclpy
from sensor_msgs.msg import JointState
rclpy.init(); node = rclpy.create_node("raw_pub")
pub = node.create_publisher(JointState, "/joint_states", 1000)
msg = JointState(name=[f"joint{i}" for i in range(7)], position=[0.0] * 7)
while pub.get_subscription_count() == 0:
    rclpy.spin_once(node, timeout_sec=0.01)
end = time.monotonic() + float(sys.argv[1])
next_t = time.monotonic()
while time.monotonic() < end:
    pub.publish(msg)
    next_t += 0.001
    time.sleep(max(0.0, next_t - time.monotonic()))
"""

_CALLS = r"""
import json, sys, time, importlib, rclpy
service, type_name, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
pkg, kind, name = type_name.split("/")
cls = getattr(importlib.import_module(f"{pkg}.{kind}"), name)
rclpy.init(); node = rclpy.create_node("caller")
client = node.create_client(cls, service)
assert client.wait_for_service(timeout_sec=30), service
times = []
for _ in range(n):
    t = time.perf_counter()
    future = client.call_async(cls.Request())
    rclpy.spin_until_future_complete(node, future)
    times.append(time.perf_counter() - t)
times.sort()
print(json.dumps({"p50": times[len(times) // 2] * 1e3, "p99": times[int(len(times) * 0.99)] * 1e3}))
"""

_LATENCY = r"""
import json, sys, time, rclpy
from sensor_msgs.msg import JointState
n = int(sys.argv[1])
rclpy.init(); node = rclpy.create_node("latency")
last = []
node.create_subscription(JointState, "/joint_states", last.append, 1000)
pub = node.create_publisher(JointState, "/joint_command", 10)
while pub.get_subscription_count() == 0 or not last:
    rclpy.spin_once(node, timeout_sec=0.05)
times = []
for i in range(n + 5):  # the first few may go before discovery completes: not counted
    target = 0.3 if i % 2 == 0 else -0.3
    last.clear()
    t = time.perf_counter()
    pub.publish(JointState(name=["joint1"], position=[target]))
    deadline = t + 2.0
    def applied():
        for m in last:
            e = m.effort[list(m.name).index("joint1")]
            if e * target > 0:
                return True
        last.clear()
        return False
    while not applied() and time.perf_counter() < deadline:
        rclpy.spin_once(node, timeout_sec=0.01)
    if i >= 5:
        times.append(time.perf_counter() - t)
times.sort()
print(json.dumps({"p50": times[len(times) // 2] * 1e3, "p99": times[int(len(times) * 0.99)] * 1e3}))
"""

_PING = r"""
import json, sys, time, rclpy
from std_msgs.msg import Int64
n = int(sys.argv[1])
rclpy.init(); node = rclpy.create_node("ping")
got = []
node.create_subscription(Int64, "/pong", lambda m: got.append(m.data), 10)
pub = node.create_publisher(Int64, "/ping", 10)
while pub.get_subscription_count() == 0 or node.count_publishers("/pong") == 0:
    rclpy.spin_once(node, timeout_sec=0.05)
times = []
for i in range(n + 5):
    got.clear()
    t = time.perf_counter()
    pub.publish(Int64(data=i))
    deadline = t + 2.0
    while i not in got and time.perf_counter() < deadline:
        rclpy.spin_once(node, timeout_sec=0.01)
    if i >= 5:
        times.append(time.perf_counter() - t)
times.sort()
print(json.dumps({"p50": times[len(times) // 2] * 1e3, "p99": times[int(len(times) * 0.99)] * 1e3}))
"""

_PONG = r"""
import rclpy
from std_msgs.msg import Int64
rclpy.init(); node = rclpy.create_node("pong")
pub = node.create_publisher(Int64, "/pong", 10)
node.create_subscription(Int64, "/ping", pub.publish, 10)
print("ready", flush=True)
rclpy.spin(node)
"""

_RAW_SERVICE = r"""
import rclpy
from std_srvs.srv import Trigger
rclpy.init(); node = rclpy.create_node("raw_service")
node.create_service(Trigger, "/raw_trigger", lambda req, res: res)
print("ready", flush=True)
rclpy.spin(node)
"""


def _count(ros2, domain, seconds, start_source) -> int:
    counter = start_node(ros2, domain, _COUNT, [str(seconds)])
    assert counter.stdout is not None
    counter.stdout.readline()
    source = start_source()
    out, _ = counter.communicate(timeout=120)
    if isinstance(source, subprocess.Popen):
        source.kill()
        source.communicate()
    return int(json.loads(out.strip().splitlines()[-1])["count"])


def run(quick: bool) -> list[Row]:
    try:
        ros2 = find_ros2()
    except Ros2Unavailable as exc:
        return [Row("ros2: not measured", 0.0, 0.0, "", "(info)", True, note=str(exc)[:120])]
    seconds = 1.0 if quick else 3.0
    calls = 100 if quick else 500
    rows: list[Row] = []
    robot = load_robot("demo", control="position")
    robot.model.opt.timestep = 0.001  # a 1 kHz simulation
    domain = choose_domain_id()
    raw = _count(
        ros2, domain, seconds, lambda: start_node(ros2, domain, _RAW_PUB, [str(seconds + 5)])
    )
    with Session(
        robot, ros2=True, clock="realtime", joint_states_hz=1000.0, tf_hz=100.0, clock_hz=100.0
    ) as session:
        ours = _count(ros2, session.ros_domain_id or 0, seconds, lambda: None)
        applied = run_node(ros2, session.ros_domain_id or 0, _LATENCY, [str(calls)])
    pong = start_node(ros2, domain, _PONG)
    assert pong.stdout is not None
    pong.stdout.readline()
    ping = run_node(ros2, domain, _PING, [str(calls)])
    pong.kill()
    pong.communicate()
    with (
        rosbridge_server(ros2, domain) as url,
        Session(
            robot,
            connect_to=url,
            clock="realtime",
            joint_states_hz=1000.0,
            tf_hz=100.0,
            clock_hz=100.0,
        ),
    ):
        through_rs = _count(ros2, domain, seconds, lambda: None)
    with Session("demo", ros2=True) as session:
        gateway = run_node(
            ros2,
            session.ros_domain_id or 0,
            _CALLS,
            ["/harness/get_state", "harness_msgs/srv/GetState", str(calls)],
        )
    rows.append(
        Row(
            "ros2: /joint_states 1 kHz delivered over DDS",
            ours / seconds,
            raw / seconds,
            "msg/s",
            ">=90% raw",
            ours >= 0.9 * raw,
            note="realtime, 1 kHz sim rate (/tf, /clock 100 Hz) vs a raw rclpy publisher",
        )
    )
    rows.append(
        Row(
            "ros2: /joint_states 1 kHz delivered via rosbridge-server-rs",
            through_rs / seconds,
            raw / seconds,
            "msg/s",
            "(info)",
            True,
            note="client mode, same session settings, vs a raw rclpy publisher",
        )
    )
    for q in ("p50", "p99"):
        rows.append(
            Row(
                f"ros2: command->applied latency {q} via gateway",
                applied[q],
                ping[q],
                "ms",
                "(info)",
                True,
                higher_is_better=False,
                note="/joint_command to /joint_states effort, 1 kHz realtime; vs rclpy ping-pong",
            )
        )
    server = start_node(ros2, domain, _RAW_SERVICE)
    assert server.stdout is not None
    server.stdout.readline()
    raw_calls = run_node(ros2, domain, _CALLS, ["/raw_trigger", "std_srvs/srv/Trigger", str(calls)])
    server.kill()
    server.communicate()
    with rosbridge_server(ros2, domain) as url, Session("demo", connect_to=url):
        relayed = run_node(
            ros2, domain, _CALLS, ["/harness/get_state", "harness_msgs/srv/GetState", str(calls)]
        )
    for label, got in (("gateway", gateway), ("rosbridge-server-rs client mode", relayed)):
        for q in ("p50", "p99"):
            rows.append(
                Row(
                    f"ros2: service round trip {q} via {label}",
                    got[q],
                    raw_calls[q],
                    "ms",
                    "(info)",
                    True,
                    higher_is_better=False,
                    note="/harness/get_state vs raw rclpy Trigger",
                )
            )
    return rows


if __name__ == "__main__":
    for row in run("--quick" in sys.argv):
        print(row)
