"""An rclpy ActionClient in a process of its own (run in the ROS 2 interpreter): sends one
FollowJointTrajectory goal to the demo arm's joint_trajectory_controller over DDS, moves time
through /harness/step (the session runs in lockstep) until the result arrives, then sends a
second goal (back home) and cancels it mid-motion. Prints one JSON line: the first goal's
status, result, feedback count, first feedback, the joint positions /harness/get_state gives
after it, and the second goal's cancel answer and status."""

from __future__ import annotations

import json
import sys
import time
from typing import Any

import rclpy
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTolerance
from harness_msgs.srv import GetState, Step
from rclpy.action import ActionClient
from rclpy.node import Node
from trajectory_msgs.msg import JointTrajectoryPoint

READY_TIMEOUT_S = 30.0  # wall clock: discovery and start-up only, never simulation
ACTION = "/joint_trajectory_controller/follow_joint_trajectory"
JOINTS = [f"joint{i}" for i in range(1, 8)]
TARGET = [0.3, 0.2, 0.1, -1.4, 0.1, 1.8, -0.5]
HOME = [0.0, 0.0, 0.0, -1.57079, 0.0, 1.57079, -0.7853]
STEPS_PER_CALL = 25  # 50 ms of simulation per /harness/step call
MAX_CALLS = 80  # 4 s of simulation at most


def spin_until(node: Node, done: Any, what: str) -> None:
    deadline = time.monotonic() + READY_TIMEOUT_S
    while not done():
        if time.monotonic() > deadline:
            raise SystemExit(f"follow_trajectory: timed out waiting for {what}")
        rclpy.spin_once(node, timeout_sec=0.05)


def call(node: Node, client: Any, request: Any, what: str) -> Any:
    future = client.call_async(request)
    spin_until(node, future.done, what)
    return future.result()


def main() -> int:
    rclpy.init()
    node = rclpy.create_node("trajectory_client")
    arm = ActionClient(node, FollowJointTrajectory, ACTION)
    step = node.create_client(Step, "/harness/step")
    get_state = node.create_client(GetState, "/harness/get_state")
    if not arm.wait_for_server(timeout_sec=READY_TIMEOUT_S):
        raise SystemExit(f"follow_trajectory: no action server {ACTION}")
    if not step.wait_for_service(timeout_sec=READY_TIMEOUT_S):
        raise SystemExit("follow_trajectory: no /harness/step service")
    get_state.wait_for_service(timeout_sec=READY_TIMEOUT_S)
    # A response can be lost while the server has not yet discovered the client's readers
    # (DDS discovery): ask a question without side effects until one is answered.
    deadline = time.monotonic() + READY_TIMEOUT_S
    while True:
        probe = get_state.call_async(GetState.Request())
        rclpy.spin_until_future_complete(node, probe, timeout_sec=1.0)
        if probe.done():
            break
        if time.monotonic() > deadline:
            raise SystemExit("follow_trajectory: /harness/get_state never answered")

    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = JOINTS
    goal.trajectory.points = [
        JointTrajectoryPoint(positions=TARGET, time_from_start=Duration(nanosec=600_000_000))
    ]
    goal.goal_tolerance = [JointTolerance(name=j, position=0.01) for j in JOINTS]
    goal.goal_time_tolerance = Duration(sec=1)
    feedback: list[Any] = []
    sent = arm.send_goal_async(goal, feedback_callback=lambda f: feedback.append(f.feedback))
    spin_until(node, sent.done, "the goal's acceptance")
    handle = sent.result()
    if not handle.accepted:
        raise SystemExit("follow_trajectory: goal rejected")
    result = handle.get_result_async()
    calls = 0
    while not result.done() and calls < MAX_CALLS:
        call(node, step, Step.Request(steps=STEPS_PER_CALL), "the /harness/step answer")
        calls += 1
    spin_until(node, result.done, "the goal's result")
    done = result.result()
    state = call(node, get_state, GetState.Request(), "the /harness/get_state answer")

    back = FollowJointTrajectory.Goal()
    back.trajectory.joint_names = JOINTS
    back.trajectory.points = [JointTrajectoryPoint(positions=HOME, time_from_start=Duration(sec=2))]
    sent = arm.send_goal_async(back)
    spin_until(node, sent.done, "the second goal's acceptance")
    second = sent.result()
    call(node, step, Step.Request(steps=STEPS_PER_CALL), "the /harness/step answer")
    cancel = second.cancel_goal_async()
    spin_until(node, cancel.done, "the cancel answer")
    canceled = second.get_result_async()
    for _ in range(MAX_CALLS):
        if canceled.done():
            break
        call(node, step, Step.Request(steps=STEPS_PER_CALL), "the /harness/step answer")
    spin_until(node, canceled.done, "the canceled goal's result")
    js = state.joint_state
    first = feedback[0] if feedback else None
    print(
        json.dumps(
            {
                "status": done.status,
                "error_code": done.result.error_code,
                "error_string": done.result.error_string,
                "feedback": len(feedback),
                "first_feedback": None
                if first is None
                else {
                    "joint_names": list(first.joint_names),
                    "desired": list(first.desired.positions),
                    "actual": list(first.actual.positions),
                    "error": list(first.error.positions),
                },
                "positions": dict(zip(js.name, js.position, strict=True)),
                "step_calls": calls,
                "cancel_goals": len(cancel.result().goals_canceling),
                "canceled_status": canceled.result().status,
            }
        ),
        flush=True,
    )
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
