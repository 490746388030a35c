"""Command topics through a real server and client: kinematic vs dynamic tracking of the same
trajectory, limits, and refused commands (exact status text, nothing changed)."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from harness.models import LoadedRobot
from harness.session import Session
from tests.session.session_helpers import Client

ARM = [f"joint{i}" for i in range(1, 8)]
HOME = [0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4]
GOAL = [0.4, -0.4, 0.3, -2.0, 0.3, 1.9, 1.0]
DT_NS = 2_000_000
STEPS = 400  # 0.8 s; the move takes 0.5 s


def _trajectory() -> dict[str, Any]:
    return {
        "joint_names": ARM,
        "points": [{"positions": GOAL, "time_from_start": {"sec": 0, "nanosec": 500_000_000}}],
    }


def _expected(t_ns: int) -> np.ndarray:
    """Linear interpolation from HOME at t = 0 to GOAL at 0.5 s, then hold (written here
    independently of the session's implementation)."""
    u = min(t_ns / 500_000_000, 1.0)
    home, goal = np.array(HOME), np.array(GOAL)
    return np.asarray(home + (goal - home) * u)


def _run(session: Session, client: Client) -> list[dict[str, Any]]:
    client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
    client.publish("/joint_trajectory", _trajectory())
    client.step(STEPS)
    return client.messages("/joint_states")


def _t(msg: dict[str, Any]) -> int:
    stamp = msg["header"]["stamp"]
    return int(stamp["sec"]) * 1_000_000_000 + int(stamp["nanosec"])


def test_kinematic_tracks_exactly_dynamic_lags_within_effort_limits(
    demo_kinematic: LoadedRobot,
    demo_position: LoadedRobot,
    client_factory: Callable[[str], Client],
) -> None:
    with Session(demo_kinematic) as kin:
        kin_states = _run(kin, client_factory(kin.url))
    with Session(demo_position) as dyn:
        dyn_states = _run(dyn, client_factory(dyn.url))

    assert len(kin_states) == len(dyn_states) == STEPS // 5
    for msg in kin_states:
        q = np.array(msg["position"][:7])
        np.testing.assert_allclose(q, _expected(_t(msg)), rtol=0, atol=1e-12)

    errors = [np.max(np.abs(np.array(m["position"][:7]) - _expected(_t(m)))) for m in dyn_states]
    assert max(errors) > 1e-3  # the servos lag behind the moving setpoint
    assert errors[-1] < 0.02  # and settle on the goal once it holds
    limits = np.array([demo_position.description.joint(j).limits.effort for j in ARM])
    efforts = np.array([m["effort"][:7] for m in dyn_states])
    assert np.all(np.abs(efforts) <= limits * (1 + 1e-9))
    assert np.any(np.abs(efforts) > 0.5 * limits)  # the motion actually loads the joints


def _limit_case(
    robot: LoadedRobot, client_factory: Callable[[str], Client], **options: Any
) -> tuple[float, float, float, dict[str, Any] | None]:
    upper = float(robot.model.jnt_range[robot.model.joint("joint1").id][1])
    with Session(robot, **options) as session:
        client = client_factory(session.url)
        client.send({"op": "set_level", "level": "warning"})
        client.publish("/joint_command", {"name": ["joint1"], "position": [upper + 0.5]})
        client.step(800)  # joint1 covers ~2.9 rad at its 2.175 rad/s velocity limit
        statuses = [f for f in client.received if f.get("op") == "status"]
        position = float(session.joint_positions()[0])
        command = float(session.joint_commands()[0])
    return upper, position, command, statuses[0] if statuses else None


def test_beyond_limits_kinematic_clamp_and_allow(
    demo_kinematic: LoadedRobot, client_factory: Callable[[str], Client]
) -> None:
    upper, position, _, status = _limit_case(demo_kinematic, client_factory)
    assert position == upper
    assert status is not None
    assert status["level"] == "warning"
    assert status["msg"] == (
        f"/joint_command: joint 'joint1': position {upper + 0.5:g} is beyond its limits "
        f"[{-upper:g}, {upper:g}]: clamped to {upper:g}"
    )

    upper, position, _, status = _limit_case(
        demo_kinematic, client_factory, kinematic_limits="allow"
    )
    assert position == upper + 0.5  # the original framework's teleport past the limit
    assert status is None


def test_beyond_limits_dynamic_clamped_with_warning(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client]
) -> None:
    upper, position, command, status = _limit_case(demo_position, client_factory)
    assert status is not None
    assert status["level"] == "warning"
    assert status["msg"].endswith(f"clamped to {upper:g}")
    assert command == upper
    assert position == pytest.approx(upper, abs=0.02)


BAD = [
    pytest.param(
        "/joint_command",
        {"name": ["joint1", "elbow"], "position": [0.1, 0.2]},
        "/joint_command: command refused: unknown joint 'elbow' (controllable joints: "
        "joint1, joint2, joint3, joint4, joint5, joint6, joint7, finger_joint1)",
        id="unknown-joint",
    ),
    pytest.param(
        "/joint_command",
        {"name": ["joint1"], "position": [0.1, 0.2]},
        "/joint_command: command refused: joint state command has 2 position values for 1 names",
        id="joint-state-length",
    ),
    pytest.param(
        "/forward_position_controller/commands",
        {"data": [0.1] * 7},
        "/forward_position_controller/commands: command refused: expected 8 values (one per "
        "joint: joint1, joint2, joint3, joint4, joint5, joint6, joint7, finger_joint1), got 7",
        id="forward-length",
    ),
    pytest.param(
        "/forward_position_controller/commands",
        {"data": [0.1, math.nan, 0, 0, 0, 0, 0, 0]},
        "/forward_position_controller/commands: command refused: joint 'joint2': position nan "
        "is not finite",
        id="forward-nan",
    ),
    pytest.param(
        "/joint_trajectory",
        {
            "joint_names": ["joint1"],
            "points": [{"positions": [math.inf], "time_from_start": {"sec": 1, "nanosec": 0}}],
        },
        "/joint_trajectory: command refused: point 0: position of joint 'joint1' is inf",
        id="trajectory-inf",
    ),
    pytest.param(
        "/joint_trajectory",
        {
            "joint_names": ["joint1", "joint2"],
            "points": [{"positions": [0.1], "time_from_start": {"sec": 1, "nanosec": 0}}],
        },
        "/joint_trajectory: command refused: point 0 has 1 positions for 2 joints",
        id="trajectory-length",
    ),
]


@pytest.mark.parametrize(("topic", "msg", "text"), BAD)
def test_bad_command_refused_and_nothing_changes(
    demo_position: LoadedRobot,
    client_factory: Callable[[str], Client],
    topic: str,
    msg: dict[str, Any],
    text: str,
) -> None:
    with Session(demo_position) as session:
        client = client_factory(session.url)
        client.step(3)
        state = session.get_state()
        commands = session.joint_commands()
        # json.dumps writes NaN/Infinity literals, as roslibpy does
        client.send(json.dumps({"op": "publish", "topic": topic, "msg": msg}))
        status = client.recv_until(lambda f: f.get("op") == "status")
        assert status == {"op": "status", "level": "error", "msg": text}
        assert session.get_state().tobytes() == state.tobytes()
        assert session.joint_commands().tobytes() == commands.tobytes()
        client.step(1)
        assert session.call(lambda: session.sim.input_changed) is False
