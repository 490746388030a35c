"""A step request that carries its command: one WebSocket message holding a ``publish`` and the
``/harness/step`` call (rosbridge v2 lets a message hold several JSON objects, processed in
order). It must act exactly like the two messages sent one after the other."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from harness.models import LoadedRobot
from harness.recording import Recording
from harness.replay.pipeline import replay_pipeline
from harness.session import Session
from tests.session.session_helpers import Client

TOPIC = "/forward_position_controller/commands"


def _command(k: int) -> dict[str, object]:
    data = [0.05 * (k % 7), -0.78, 0.0, -2.35, 0.0, 1.57, 0.78, 0.02]
    return {"op": "publish", "topic": TOPIC, "msg": {"data": data}}


def _step(k: int) -> dict[str, object]:
    return {"op": "call_service", "service": "/harness/step", "args": {"steps": 1}, "id": k}


def _drive(session: Session, client: Client, steps: int, carry: bool) -> list[int]:
    """Step ``steps`` times with one command each; the answers' step ids in order."""
    answered = []
    for k in range(steps):
        if carry:
            client.send(json.dumps(_command(k)) + json.dumps(_step(k)))
        else:
            client.send(_command(k))
            client.send(_step(k))
        answer = client.recv_until(lambda f: f.get("op") == "service_response")
        assert answer["result"] is True, answer
        answered.append(answer["id"])
    return answered


@pytest.mark.slow
def test_a_step_request_carrying_its_command_acts_like_two_messages(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client], tmp_path: Path
) -> None:
    steps = 40
    finals = {}
    for carry in (True, False):
        path = tmp_path / f"carry-{carry}.mcap"
        with Session(demo_position, record_to=path) as session:
            client = client_factory(session.url)
            assert _drive(session, client, steps, carry) == list(range(steps))
            assert session.step_index == steps
            # the last command is the one in force
            np.testing.assert_array_equal(session.joint_commands()[:1], [0.05 * ((steps - 1) % 7)])
            finals[carry] = session.get_state()
        with Recording(path) as rec:
            frames = [f for f in rec.bridge_frames() if f.direction == 0 and f.connection > 0]
        if carry:
            # one frame per step, named by its first object, holding both
            publishes = [f for f in frames if f.op == "publish"]
            assert len(publishes) == steps
            assert all('"/harness/step"' in f.text for f in publishes)
            assert [f.step for f in publishes] == list(range(1, steps + 1))
        assert replay_pipeline(path).reproduced
    # the same commands at the same steps: the same physics, bit for bit
    np.testing.assert_array_equal(finals[True], finals[False])
