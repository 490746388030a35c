"""Client mode: the session connects out to an external rosbridge server (here the harness's
own BridgeServer in a thread) and is driven through it by another client."""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from harness.events import CollectingSink, LogMessage
from harness.models import LoadedRobot
from harness.recording import Recording
from harness.replay.pipeline import replay_pipeline
from harness.rosbridge import BridgeServer
from harness.session import Session
from harness.session.live.upstream import UpstreamError
from tests.session.session_helpers import Client


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


class _External:
    """A standalone rosbridge server (the harness's BridgeServer) on its own loop thread that
    can be stopped and started again on the same port (a server restart)."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name="external-rosbridge")
        self.thread.start()
        self.port = 0
        self.server: BridgeServer | None = None

    def start(self) -> str:
        self.server = BridgeServer(port=self.port)
        url = asyncio.run_coroutine_threadsafe(self.server.start(), self.loop).result()
        self.port = int(url.rsplit(":", 1)[1].split("/")[0])
        return url

    def stop(self) -> None:
        if self.server is not None:
            asyncio.run_coroutine_threadsafe(self.server.stop(), self.loop).result()
            self.server = None

    def close(self) -> None:
        self.stop()
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join()
        self.loop.close()


@pytest.fixture
def restartable() -> Iterator[_External]:
    external = _External()
    try:
        yield external
    finally:
        external.close()


def _wait_service(client: Client, service: str) -> None:
    deadline = time.monotonic() + 20  # readiness of the link (wall clock), not simulation
    while time.monotonic() < deadline:
        if service in client.call("/rosapi/services")["values"]["services"]:
            return
    raise AssertionError(f"{service} never appeared")


@pytest.mark.slow
def test_client_mode_records_every_frame_and_replays_at_full_level(
    demo_position: LoadedRobot,
    restartable: _External,
    client_factory: Callable[[str], Client],
    tmp_path: Path,
) -> None:
    url = restartable.start()
    path = tmp_path / "client.mcap"
    with Session(demo_position, connect_to=url, record_to=path) as session:
        robot_code = client_factory(url)
        _wait_service(robot_code, "/harness/step")
        robot_code.publish("/joint_command", {"name": ["joint1"], "position": [0.4]})
        robot_code.step(100)
        restartable.stop()  # the server restarts mid-run: the session reconnects
        session.step(10)  # published while the server is away: recorded, not delivered
        assert session.upstream is not None
        assert session.upstream.send_failures > 0
        url_again = restartable.start()
        assert url_again == url
        robot_code = client_factory(url)
        _wait_service(robot_code, "/harness/step")  # re-advertised after the reconnect
        robot_code.step(100)
        assert session.step_index == 210
        assert session.upstream.reconnects == 1
    with Recording(path) as rec:
        assert rec.metadata["transport"] == "client"
        assert rec.metadata["upstream"] == url
        frames = list(rec.bridge_frames())
    ops_in = {(f.op, f.topic) for f in frames if f.direction == 0}
    ops_out = {(f.op, f.topic) for f in frames if f.direction == 1}
    assert ("publish", "/joint_command") in ops_in
    assert ("call_service", "/harness/step") in ops_in
    assert ("publish", "/joint_states") in ops_out
    assert ("service_response", "/harness/step") in ops_out
    gap = [f.text for f in frames if f.topic == "harness/transport_status"]  # the markers
    assert any("lost: reconnecting" in t for t in gap), gap
    assert any("reconnected" in t for t in gap), gap
    report = replay_pipeline(path)
    assert report.reproduced, report.mismatch
    assert report.steps == 210


def test_a_send_to_a_dropped_link_is_counted_logged_and_recorded(
    demo_position: LoadedRobot,
    restartable: _External,
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
) -> None:
    url = restartable.start()
    path = tmp_path / "dropped.mcap"
    with (
        caplog.at_level(logging.WARNING, logger="harness.session.live.upstream"),
        Session(demo_position, connect_to=url, record_to=path) as session,
    ):
        stats = session.upstream
        assert stats is not None
        assert stats.send_failures == 0
        restartable.stop()  # the link drops; the session keeps stepping
        session.step(10)  # what it publishes for the server cannot be sent
        assert stats.send_failures >= 1
        assert "could not send publish /" in stats.last_send_failure
        session.step(1)  # the report is applied (and recorded) at a step boundary
    logged = [r.getMessage() for r in caplog.records if r.name == "harness.session.live.upstream"]
    assert any("could not send publish /" in m for m in logged), logged
    with Recording(path) as rec:
        reports = [f for f in rec.bridge_frames() if f.topic == "harness/transport_status"]
    assert any("could not send publish /" in f.text for f in reports), [f.text for f in reports]


def test_a_refused_advertisement_fails_the_start_with_one_line(
    demo_position: LoadedRobot, external_server: str, client_factory: Callable[[str], Client]
) -> None:
    squatter = client_factory(external_server)  # /joint_states taken with another type
    squatter.send({"op": "advertise", "topic": "/joint_states", "type": "std_msgs/msg/String"})
    squatter.call("/rosapi/topics")  # the advertisement is processed
    with pytest.raises(UpstreamError) as failure:
        Session(demo_position, connect_to=external_server)
    line = str(failure.value)
    assert "\n" not in line
    assert f"rosbridge server {external_server} refused /joint_states" in line
    assert "(sensor_msgs/msg/JointState)" in line
    assert "already established with type std_msgs/msg/String" in line


def test_allow_refused_runs_and_reports_the_server_status_as_events(
    demo_position: LoadedRobot,
    external_server: str,
    client_factory: Callable[[str], Client],
    tmp_path: Path,
) -> None:
    squatter = client_factory(external_server)
    squatter.send({"op": "advertise", "topic": "/joint_states", "type": "std_msgs/msg/String"})
    squatter.call("/rosapi/topics")
    events = CollectingSink()
    path = tmp_path / "refused.mcap"
    with Session(
        demo_position,
        connect_to=external_server,
        connect_allow_refused=True,
        sinks=[events],
        record_to=path,
    ) as session:
        session.step(10)
        assert session.upstream is not None
        assert [r.split(":")[0] for r in session.upstream.refused] == [
            "/joint_states (sensor_msgs/msg/JointState)"
        ]
        assert session.upstream.statuses == {"error": 1}
        assert session.core.peer_statuses == {"error": 1}
        assert "status error 1" in session.upstream.summary()
    texts = [e.message() for e in events.events if isinstance(e, LogMessage)]
    assert any("status error" in t and "/joint_states" in t for t in texts), texts
    assert replay_pipeline(path).reproduced
