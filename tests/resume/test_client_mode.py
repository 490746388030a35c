"""A resumed session on the ``--connect`` transport: it connects out to an external rosbridge
server (the harness's own BridgeServer in a thread) and is driven through it; the goal the
recorded client left in flight finishes as the robot code steps."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from harness import Session
from harness.rosbridge import BridgeServer
from harness.testing import connect

from .conftest import ARM_FORK, JOINTS, TARGET


@pytest.fixture
def external_server() -> Iterator[str]:
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, name="external-rosbridge")
    thread.start()
    server = BridgeServer()
    try:
        yield asyncio.run_coroutine_threadsafe(server.start(), loop).result()
    finally:
        asyncio.run_coroutine_threadsafe(server.stop(), loop).result()
        loop.call_soon_threadsafe(loop.stop)
        thread.join()
        loop.close()


def test_a_resumed_session_in_client_mode(arm_parent: Path, external_server: str) -> None:
    with (
        Session.resume(arm_parent, step=ARM_FORK, connect_to=external_server) as session,
        connect(external_server) as robot_code,
    ):
        assert session.url == external_server
        assert robot_code.step(0) == ARM_FORK * session.dt_ns
        robot_code.step(400)
        state = robot_code.state()
        assert session.step_index == ARM_FORK + 400
    positions = dict(
        zip(state["joint_state"]["name"], state["joint_state"]["position"], strict=True)
    )
    for joint, target in zip(JOINTS, TARGET, strict=True):
        assert positions[joint] == pytest.approx(target, abs=0.01)
