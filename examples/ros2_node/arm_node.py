"""A small ROS 2 node as a robot project would write it (rclpy only, nothing from the harness):
it listens to ``/joint_states``, sends a ``JointTrajectory`` moving joint1 to ``--target``, lets
``--sim-seconds`` of simulation time pass and prints one JSON line with what it saw.

With ``--lockstep`` it moves time itself through the ``/harness/step`` service, 10 ms at a
time (the simulation runs with a lockstep clock); otherwise it waits in simulation time
(``use_sim_time``: its clock follows ``/clock``). At the end a late subscriber reads the
latched ``/robot_description``.

    python arm_node.py --target 0.3 --sim-seconds 1.0 [--lockstep]
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import rclpy
from builtin_interfaces.msg import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

READY_TIMEOUT_S = 30.0  # wall clock: discovery and start-up only, never simulation


def ns(stamp) -> int:  # noqa: ANN001
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def spin_until(node: Node, done, what: str) -> None:  # noqa: ANN001
    deadline = time.monotonic() + READY_TIMEOUT_S
    while not done():
        if time.monotonic() > deadline:
            raise SystemExit(f"arm_node: timed out waiting for {what}")
        rclpy.spin_once(node, timeout_sec=0.05)


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--target", type=float, default=0.3)
    parser.add_argument("--sim-seconds", type=float, default=1.0)
    parser.add_argument("--lockstep", action="store_true")
    args = parser.parse_args()

    rclpy.init()
    node = rclpy.create_node(
        "arm_node", parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)]
    )
    states: list[JointState] = []
    node.create_subscription(JointState, "/joint_states", states.append, 10)
    trajectory = node.create_publisher(JointTrajectory, "/joint_trajectory", 10)
    spin_until(
        node, lambda: trajectory.get_subscription_count() > 0, "the /joint_trajectory subscriber"
    )
    step = None
    if args.lockstep:
        from harness_msgs.srv import GetState, Step

        step = node.create_client(Step, "/harness/step")
        if not step.wait_for_service(timeout_sec=READY_TIMEOUT_S):
            raise SystemExit("arm_node: no /harness/step service")
        # A response can be lost while the server has not yet discovered the client's reader
        # (DDS discovery): ask a question without side effects until one is answered.
        get_state = node.create_client(GetState, "/harness/get_state")
        get_state.wait_for_service(timeout_sec=READY_TIMEOUT_S)
        deadline = time.monotonic() + READY_TIMEOUT_S
        while True:
            probe = get_state.call_async(GetState.Request())
            rclpy.spin_until_future_complete(node, probe, timeout_sec=1.0)
            if probe.done():
                break
            if time.monotonic() > deadline:
                raise SystemExit("arm_node: /harness/get_state never answered")

    msg = JointTrajectory()
    msg.joint_names = ["joint1"]
    half_second = Duration(sec=0, nanosec=500_000_000)
    msg.points = [JointTrajectoryPoint(positions=[args.target], time_from_start=half_second)]
    trajectory.publish(msg)

    target_ns = round(args.sim_seconds * 1e9)
    if step is not None:
        # 10 ms of simulation per call, as a control loop would step (a command that goes
        # through a rosbridge server travels beside the step calls, not before them)
        total = round(args.sim_seconds / 0.002)
        for done in range(0, total, 5):
            request = Step.Request()
            request.steps = min(5, total - done)
            future = step.call_async(request)
            spin_until(node, future.done, "the /harness/step answer")
        answered_ns = ns(future.result().sim_time)
    else:
        answered_ns = None
    spin_until(
        node,
        lambda: bool(states) and ns(states[-1].header.stamp) >= target_ns,
        f"/joint_states stamped {args.sim_seconds} s",
    )
    spin_until(node, lambda: node.get_clock().now().nanoseconds >= target_ns, "/clock")
    clock_ns = node.get_clock().now().nanoseconds

    descriptions: list[String] = []
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(String, "/robot_description", descriptions.append, latched)
    spin_until(node, lambda: bool(descriptions), "/robot_description")

    last = states[-1]
    print(
        json.dumps(
            {
                "joint1": last.position[list(last.name).index("joint1")],
                "stamp_ns": ns(last.header.stamp),
                "clock_ns": clock_ns,
                "step_answer_ns": answered_ns,
                "joint_states": len(states),
                "description_bytes": len(descriptions[0].data),
            }
        ),
        flush=True,
    )
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
