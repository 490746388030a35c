"""Session(record_to=...) and `harness serve --record`: complete, readable recordings; a
CollisionLogger on the session puts begin/end events in the recording."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from harness.events import CollisionLogger
from harness.models import LoadedRobot
from harness.recording import Recording
from harness.session import Session
from tests.session.session_helpers import Client


def test_record_to_holds_every_frame_input_and_state(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client], tmp_path: Path
) -> None:
    path = tmp_path / "run.mcap"
    with Session(demo_position, record_to=path) as session:
        client = client_factory(session.url)
        client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        client.publish("/joint_command", {"name": ["joint1"], "position": [0.2]})
        client.step(20)
        client.publish("/joint_command", {"name": ["elbow"], "position": [0.2]})  # refused
        client.recv_until(lambda f: f.get("op") == "status")
        client.publish("/forward_position_controller/commands", {"data": [0.1] * 8})
        client.step(30)
        session.step(7)
        final_state = session.get_state()
        client.recv_until(
            lambda f: (
                f.get("msg", {}).get("header", {}).get("stamp")
                == {"sec": 0, "nanosec": 110_000_000}
            )
        )  # published at step 55
        sent, received = client.sent, list(client.received)
        client.close()
        # the server sees the close; the session closes with the recording after it
    with Recording(path) as recording:
        assert recording.complete
        assert recording.problems == []
        assert recording.metadata["clock"] == "lockstep"
        states = list(recording.physics_states())
        assert [s.step for s in states] == list(range(58))
        assert np.array_equal(states[-1].state, final_state)
        inputs = list(recording.applied_inputs())
        assert [i.step for i in inputs] == [1, 21]  # the two accepted commands
        frames = list(recording.bridge_frames())
        # connection 0: markers (a disconnect), not frames a client sent
        incoming = [f for f in frames if f.direction == 0 and f.connection != 0]
        outgoing = [f for f in frames if f.direction == 1]
        assert len(incoming) == sent
        assert [json.loads(f.text) for f in outgoing] == received
        # incoming frames carry the step before which they took effect
        publishes = [f for f in incoming if f.op == "publish"]
        assert [f.step for f in publishes] == [1, 21, 21]
        assert [f.sim_time_ns for f in publishes] == [0, 40_000_000, 40_000_000]
        joint_states = list(recording.messages(topics=["/joint_states"], decode=True))
        assert len(joint_states) == 58 // 5 + 1  # 100 Hz at 500 Hz steps, step 0 included
        rosout = [recording.decode(m).msg for m in recording.messages(topics=["/rosout"])]
        assert rosout[0] == (
            "/joint_command: command refused: unknown joint 'elbow' (controllable joints: "
            "joint1, joint2, joint3, joint4, joint5, joint6, joint7, finger_joint1)"
        )
        # 0.1 is beyond joint4's range [-3.0718, -0.0698] and the finger's [0, 0.04]
        assert [text.split(":")[1] for text in rosout[1:]] == [
            " joint 'joint4'",
            " joint 'finger_joint1'",
        ]
        assert all("clamped to" in text for text in rosout[1:])
        assert recording.attachment("model.mjb") == demo_position.mjb


def _touch_box_trajectory() -> dict[str, object]:
    """Linear moves between the waypoints of `harness demo`: beside the box, through it."""
    beside = [-0.027, -0.076, -0.26, -2.159, -0.022, 2.085, 0.449]
    through = [0.027, -0.076, 0.26, -2.159, 0.022, 2.085, 1.122]
    home = [0.0, -0.7853981633974483, 0.0, -2.356194490192345, 0.0, 1.5707963267948966, 0.785]
    return {
        "joint_names": [f"joint{i}" for i in range(1, 8)],
        "points": [
            {"positions": beside, "time_from_start": {"sec": 1, "nanosec": 200_000_000}},
            {"positions": through, "time_from_start": {"sec": 3, "nanosec": 400_000_000}},
            {"positions": home, "time_from_start": {"sec": 5, "nanosec": 0}},
        ],
    }


@pytest.mark.slow
def test_collision_logger_events_in_the_recording(
    demo_kinematic: LoadedRobot, client_factory: Callable[[str], Client], tmp_path: Path
) -> None:
    path = tmp_path / "touch.mcap"
    with Session(demo_kinematic, record_to=path, state_every=10) as session:
        session.add_logger(
            CollisionLogger(
                session.model, robot_bodies=session.link_names, robot_vs_world_only=True
            )
        )
        client = client_factory(session.url)
        client.publish("/joint_trajectory", _touch_box_trajectory())
        client.step(2600)
    with Recording(path) as recording:
        events = list(recording.collision_events())
        with_box = [e for e in events if "box" in (e.body1, e.body2)]
        kinds = [e.kind for e in with_box]
        assert kinds.count(0) >= 1
        assert kinds.count(0) == kinds.count(1)  # every begin has its end
        first = with_box[0]
        assert first.kind == 0
        robot_side = first.body2 if first.body1 == "box" else first.body1
        assert robot_side in session.link_names
        assert 600 <= first.step <= 1700  # between reaching the box and leaving it
        ends = [e for e in with_box if e.kind == 1]
        assert all(e.duration_ns > 0 for e in ends)
        rosout = [recording.decode(m).msg for m in recording.messages(topics=["/rosout"])]
        assert any("collision began" in text and "box" in text for text in rosout)


@pytest.mark.slow
def test_serve_record_then_sigint_leaves_a_valid_file(tmp_path: Path) -> None:
    path = tmp_path / "serve.mcap"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "harness",
            "serve",
            "--port",
            "0",
            "--clock",
            "fast",
            "--record",
            str(path),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        first = proc.stdout.readline()
        assert first.startswith("harness serve: ws://127.0.0.1:"), first
        client = Client(first.split()[2])
        client.subscribe("/clock", "rosgraph_msgs/msg/Clock")
        client.recv_until(lambda f: f.get("topic") == "/clock")
        client.close()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert "stopped at step" in out
    with Recording(path) as recording:
        assert recording.complete
        assert recording.problems == []
        assert recording.last_step is not None
        assert recording.last_step > 0
        steps = [s.step for s in recording.physics_states()]
        assert steps == list(range(recording.last_step + 1))
        assert any(f.op == "subscribe" for f in recording.bridge_frames())
