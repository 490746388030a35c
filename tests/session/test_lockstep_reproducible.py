"""A lockstep session driven over the WebSocket records the same bytes every time: the frames a
client sends are applied as they are read (in the socket's callback when time stands still,
at the driver's wake-up otherwise), and which of these happens, or how the frames are split
between reads, must not show in the recording."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from harness.models import LoadedRobot
from harness.recording import Recording
from harness.session import Session
from tests.session.session_helpers import Client

TOPIC = "/forward_position_controller/commands"


def _run(robot: LoadedRobot, path: Path) -> tuple[str, list[int]]:
    """Steps with a command each (two messages, or one carrying both), a bad frame, a refused
    command and a get_state on the way; the file's SHA-256 and the steps answered."""
    with Session(robot, record_to=path) as session:
        client = Client(session.url)
        client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        answered = []
        for k in range(60):
            data = [0.1 * (k % 10) / 10, -0.78, 0.0, -2.35, 0.0, 1.57, 0.78, 0.02]
            cmd = json.dumps({"op": "publish", "topic": TOPIC, "msg": {"data": data}})
            args = {"steps": 1 + k % 3}
            call = json.dumps({"op": "call_service", "service": "/harness/step", "args": args})
            if k % 2:
                client.send(cmd + call)
            else:
                client.send(cmd)
                client.send(call)
            if k == 10:
                client.send("{not json")
                client.send({"op": "publish", "topic": TOPIC, "msg": {"data": [1.0]}})
                client.send({"op": "call_service", "service": "/harness/get_state", "id": "g"})
            answer = client.recv_until(
                lambda f: f.get("op") == "service_response" and f["service"] == "/harness/step"
            )
            assert answer["result"] is True, answer
            answered.append(session.step_index)
        session.step(2)
    client.close()
    return hashlib.sha256(path.read_bytes()).hexdigest(), answered


def test_a_lockstep_client_run_records_the_same_bytes_twice(
    demo_position: LoadedRobot, tmp_path: Path
) -> None:
    first, steps = _run(demo_position, tmp_path / "a.mcap")
    second, steps_again = _run(demo_position, tmp_path / "b.mcap")
    assert steps == steps_again
    assert steps[-1] == sum(1 + k % 3 for k in range(60))
    assert first == second
    with Recording(tmp_path / "a.mcap") as rec:
        frames = [f for f in rec.bridge_frames() if f.direction == 0 and f.connection > 0]
        assert rec.last_step == steps[-1] + 2
    # every frame the client sent is in the recording, in order, at the step it took effect
    assert len(frames) == 1 + 60 + 30 + 3
    assert [f.step for f in frames] == sorted(f.step for f in frames)
