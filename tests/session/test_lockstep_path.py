"""The lockstep client's path through the session (a forward command and a step per step),
sans I/O: what each shortcut on it gives is what the general path gives."""

from __future__ import annotations

import json

import numpy as np
import pytest

from harness.controllers.forward_command import ForwardCommandController
from harness.models import load_robot
from harness.session import Session

FORWARD = "/forward_position_controller/commands"


def _session() -> Session:
    robot = load_robot("demo", control="position")
    return Session(robot)


def test_forward_controller_is_given_no_readings() -> None:
    with _session() as session:

        def check() -> None:
            control = session.core.control
            robot = control.robots[0]
            active = robot.manager.active()
            forward = [c for c in active if isinstance(c, ForwardCommandController)]
            others = [c for c in active if not isinstance(c, ForwardCommandController)]
            assert forward
            assert others
            unread = robot.read_for(forward)
            assert unread.sim_time_ns == session.core.sim.sim_time_ns
            with pytest.raises(RuntimeError, match="reads_state = False"):
                unread.position["joint1"]
            with pytest.raises(RuntimeError, match="reads_state = False"):
                len(unread.velocity)
            # one controller that reads is enough for the real readings
            read = robot.read_for([*forward, *others])
            expected = session.core.sim.joint_positions().tolist()
            assert list(read.position.values()) == expected

        session.call(check)


def test_forward_commands_step_by_step_move_the_arm() -> None:
    with _session() as session:
        target = [0.3, -0.5, 0.2, -2.0, 0.1, 1.6, 0.9, 0.02]

        def run() -> list[str]:
            bridge = session.core.bridge
            assert bridge is not None
            cid = bridge.connect("lockstep")
            out: list[str] = []
            publish = {"op": "publish", "topic": FORWARD, "msg": {"data": target}}
            call = {"op": "call_service", "service": "/harness/step", "args": {"steps": 1}}
            for k in range(300):
                for frame in (publish, {**call, "id": f"s{k}"}):
                    out += [str(o.data) for o in bridge.receive(cid, json.dumps(frame), 0)]
                out += [str(o.data) for o in bridge.drain()]
            bridge.disconnect(cid)
            return out

        frames = session.call(run)
        responses = [json.loads(f) for f in frames if '"service_response"' in f]
        assert len(responses) == 300
        assert all(r["result"] for r in responses)
        assert responses[-1]["id"] == "s299"
        sim = session.core.sim
        assert sim.step_index == 300
        assert responses[-1]["values"]["sim_time"] == {
            "sec": sim.sim_time_ns // 10**9,
            "nanosec": sim.sim_time_ns % 10**9,
        }
        assert np.allclose(session.call(sim.joint_positions)[:7], target[:7], atol=0.05)


CONTROLLERS = """
controller_manager:
  ros__parameters:
    update_rate: 100
    vel:
      type: velocity_controllers/JointGroupVelocityController
    idle:
      type: velocity_controllers/JointGroupVelocityController
vel:
  ros__parameters:
    joints: [joint1, joint2]
idle:
  ros__parameters:
    joints: [joint1]
"""


def test_velocity_group_commands_and_refusals() -> None:
    robot = load_robot("demo", control="velocity")
    with Session(robot, controllers=CONTROLLERS) as session:

        def run() -> list[tuple[str, str]]:
            bridge = session.core.bridge
            assert bridge is not None
            cid = bridge.connect("client")
            replies: list[tuple[str, str]] = []
            bridge.receive(cid, json.dumps({"op": "set_level", "level": "warning"}), 0)

            def publish(topic: str, data: list[float]) -> None:
                frame = {"op": "publish", "topic": topic, "msg": {"data": data}}
                for o in [*bridge.receive(cid, json.dumps(frame), 0), *bridge.drain()]:
                    reply = json.loads(o.data)
                    replies.append((reply["level"], reply["msg"]))

            publish("/vel/commands", [0.25, -0.5])
            commands = session.core.sim.joint_commands()
            names = session.core.sim.joint_names
            assert commands[names.index("joint1")] == 0.25
            assert commands[names.index("joint2")] == -0.5
            publish("/vel/commands", [0.25])
            publish("/idle/commands", [0.1])
            publish("/vel/commands", [1e9, 0.0])
            assert session.core.sim.joint_commands()[names.index("joint2")] == 0.0
            bridge.disconnect(cid)
            return replies

        replies = session.call(run)
        assert replies[0] == (
            "error",
            "/vel/commands: command refused: expected 2 values (one per joint: joint1, joint2), "
            "got 1",
        )
        assert replies[1] == ("error", "/idle/commands: inactive, command ignored")
        assert replies[2][0] == "warning"
        assert replies[2][1].startswith("/vel/commands: joint 'joint1': velocity 1e+09 is beyond")
        assert len(replies) == 3
