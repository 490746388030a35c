"""Client mode: the session connects out to an external rosbridge server (here the harness's
own BridgeServer in a thread) and is driven through it by another client."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable, Iterator

import pytest
from session_helpers import Client

from harness.models import LoadedRobot
from harness.rosbridge import BridgeServer
from harness.session import Session


@pytest.fixture
def external_server() -> Iterator[str]:
    """A standalone rosbridge server on its own loop thread; yields its URL."""
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


def test_session_as_client_of_an_external_server(
    demo_position: LoadedRobot, external_server: str, client_factory: Callable[[str], Client]
) -> None:
    with Session(demo_position, connect_to=external_server) as session:
        assert session.url == external_server
        robot_code = client_factory(external_server)
        for _ in range(100):  # the session's registrations travel on another connection
            services = robot_code.call("/rosapi/services")["values"]["services"]
            if "/harness/step" in services:
                break
        assert "/harness/step" in services
        robot_code.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        robot_code.publish("/joint_command", {"name": ["joint1"], "position": [0.4]})
        answer = robot_code.step(250)
        assert answer["values"] == {"sim_time": {"sec": 0, "nanosec": 500_000_000}}
        assert session.step_index == 250
        assert session.joint_positions()[0] == pytest.approx(0.4, abs=0.02)
        stamps = [m["header"]["stamp"] for m in robot_code.messages("/joint_states")]
        assert stamps[-1] == {"sec": 0, "nanosec": 500_000_000}
