"""Teardown leaves nothing behind; clock modes, run_until, the harness services, namespaces."""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable
from pathlib import Path

import pytest
from websockets.exceptions import ConnectionClosed

from harness.models import LoadedRobot
from harness.recording import Recording
from harness.session import Session, SessionConfigError, SessionError, SimTimeoutError
from tests.session.session_helpers import Client


def _listening_ports() -> set[int]:
    """Local ports in LISTEN state, from /proc/net/tcp and tcp6."""
    ports = set()
    for name in ("/proc/net/tcp", "/proc/net/tcp6"):
        path = Path(name)
        if not path.exists():
            continue
        for line in path.read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A":  # TCP_LISTEN
                ports.add(int(fields[1].rsplit(":", 1)[1], 16))
    return ports


def _port(url: str) -> int:
    return int(url.rsplit(":", 1)[1])


def _assert_closed_by_server(client: Client) -> list[dict[str, object]]:
    """The server closed the client's connection (1001, going away). Frames the server sent
    before closing are still buffered on the client and come first: websockets delivers every
    frame received before the close (reading once and expecting ConnectionClosed was the
    flake: it failed whenever a frame was still buffered). Returns those frames."""
    unread: list[dict[str, object]] = []
    with pytest.raises(ConnectionClosed) as info:  # TimeoutError if the close never comes
        _read_until_closed(client, unread)
    assert info.value.rcvd is not None
    assert info.value.rcvd.code == 1001
    return unread


def _read_until_closed(client: Client, into: list[dict[str, object]]) -> None:
    while True:
        into.append(client.recv())


def _assert_gone(port: int, threads_before: set[threading.Thread], client: Client) -> None:
    assert port not in _listening_ports()
    with pytest.raises(ConnectionRefusedError), socket.create_connection(("127.0.0.1", port), 2):
        pass
    _assert_closed_by_server(client)
    # The client's own threads (websockets' reader, keepalive) end on their own schedule.
    ws = client.ws
    own = {ws.recv_events_thread, getattr(ws, "keepalive_thread", None)}
    assert set(threading.enumerate()) - own <= threads_before


def test_teardown_leaves_no_socket_and_no_thread(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client], tmp_path: Path
) -> None:
    before = set(threading.enumerate())
    with Session(demo_position, record_to=tmp_path / "run.mcap") as session:
        port = _port(session.url)
        assert port in _listening_ports()
        client = client_factory(session.url)
        client.step(10)
        assert {t.name for t in threading.enumerate()} >= {"harness-session", "harness-recorder"}
    _assert_gone(port, before, client)


def test_frames_sent_before_teardown_reach_the_client_before_the_close(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client]
) -> None:
    # The flake made deterministic: the client has not read what the server sent when the
    # session closes; it gets all of it, then the close.
    with Session(demo_position, joint_states_hz=100) as session:
        client = client_factory(session.url)
        client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        client.call("/harness/get_state")  # the subscription is in place
        session.step(50)  # 10 joint_states the client does not read
    unread = _assert_closed_by_server(client)
    assert [f["topic"] for f in unread] == ["/joint_states"] * 10


def test_teardown_after_an_exception_in_the_with_block(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client], tmp_path: Path
) -> None:
    before = set(threading.enumerate())
    path = tmp_path / "run.mcap"
    ports: list[int] = []
    clients: list[Client] = []

    def body() -> None:
        with Session(demo_position, clock="fast", record_to=path) as session:
            ports.append(_port(session.url))
            client = client_factory(session.url)
            clients.append(client)
            client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
            client.recv_until(lambda f: f.get("topic") == "/joint_states")
            raise RuntimeError("test body failed")

    with pytest.raises(RuntimeError, match="test body failed"):
        body()
    port, client = ports[0], clients[0]
    _assert_gone(port, before, client)
    with Recording(path) as recording:
        assert recording.complete
        assert recording.last_step is not None
        assert recording.last_step > 0


def test_bad_options_are_refused_before_anything_starts(demo_position: LoadedRobot) -> None:
    before = set(threading.enumerate())
    with pytest.raises(SessionConfigError, match="clock must be one of"):
        Session(demo_position, clock="wallclock")  # type: ignore[arg-type]
    with pytest.raises(SessionConfigError, match="rate must be"):
        Session(demo_position, rate=0.0)
    with pytest.raises(SessionConfigError, match="namespace 'a b'"):
        Session(demo_position, namespace="a b")
    assert set(threading.enumerate()) <= before


def test_run_until_steps_in_lockstep_and_times_out_in_sim_time(
    demo_position: LoadedRobot,
) -> None:
    with Session(demo_position) as session:
        session.set_positions({"joint1": 0.5})
        step = session.run_until(lambda: session.sim.joint_positions()[0] > 0.25, sim_timeout=2.0)
        assert 0 < step == session.step_index
        assert session.joint_positions()[0] > 0.25
        with pytest.raises(SimTimeoutError) as info:
            session.run_until(lambda: False, sim_timeout=0.1)
        assert str(info.value) == (
            f"condition not met within 0.1 s of simulation time (now step {step + 50}, "
            f"sim time {(step + 50) * 0.002:.6f} s)"
        )


def test_fast_clock_runs_by_itself_pause_and_step(demo_position: LoadedRobot) -> None:
    with Session(demo_position, clock="fast") as session:
        reached = session.run_until(lambda: session.sim.step_index >= 200, sim_timeout=10.0)
        assert reached >= 200
        with pytest.raises(SessionError, match="the clock is fast"):
            session.step(1)
        session.pause()
        paused_at = session.step_index
        assert session.step(3) == paused_at + 3
        assert session.step_index == paused_at + 3
        session.resume()
        session.run_until(lambda: session.sim.step_index > paused_at + 100, sim_timeout=10.0)


def test_services_get_state_pause_reset(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client]
) -> None:
    with Session(demo_position) as session:
        client = client_factory(session.url)
        client.publish("/joint_command", {"name": ["joint1"], "position": [0.3]})
        answer = client.step(100)
        assert answer["values"] == {"sim_time": {"sec": 0, "nanosec": 200_000_000}}
        state = client.call("/harness/get_state")["values"]
        assert state["step"] == 100
        assert state["clock"] == "lockstep"
        assert state["joint_state"]["name"][0] == "joint1"
        assert state["joint_state"]["position"][0] == pytest.approx(0.3, abs=0.02)
        assert state["joint_state"]["header"]["stamp"] == {"sec": 0, "nanosec": 200_000_000}

        pause = client.call("/harness/pause", {"data": True})["values"]
        assert pause == {
            "success": True,
            "message": "lockstep clock: time moves only on /harness/step (step 100)",
        }

        home = session.robot.model.key("home").qpos
        reset = client.call("/harness/reset")["values"]
        assert reset == {
            "success": True,
            "message": "reset to the initial state at step 100 (step numbering continues)",
        }
        assert session.step_index == 100
        assert session.joint_positions()[0] == pytest.approx(float(home[7]), abs=1e-12)
        client.step(1)
        assert session.step_index == 101


def test_namespace_and_rosapi(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client]
) -> None:
    with Session(demo_position, namespace="arm1") as session:
        assert session.topics.joint_states == "/arm1/joint_states"
        client = client_factory(session.url)
        client.subscribe("/arm1/joint_states", "sensor_msgs/msg/JointState")
        client.subscribe("/arm1/tf", "tf2_msgs/msg/TFMessage")
        client.subscribe("/arm1/tf_static", "tf2_msgs/msg/TFMessage")
        client.step(5)
        tf = client.messages("/arm1/tf")[-1]
        parents = {t["child_frame_id"]: t["header"]["frame_id"] for t in tf["transforms"]}
        assert parents["arm1/link1"] == "arm1/link0"
        assert parents["arm1/left_finger"] == "arm1/hand"
        (static,) = client.messages("/arm1/tf_static")
        fixed = {t["child_frame_id"]: t["header"]["frame_id"] for t in static["transforms"]}
        assert fixed == {"arm1/link0": "world", "arm1/hand": "arm1/link7"}
        topics = client.call("/rosapi/topics")["values"]
        assert "/arm1/joint_states" in topics["topics"]
        assert "/arm1/joint_command" in topics["topics"]
        services = client.call("/rosapi/services")["values"]["services"]
        assert {"/harness/step", "/harness/reset", "/harness/pause", "/harness/get_state"} <= set(
            services
        )
        details = client.call("/rosapi/service_request_details", {"type": "harness_msgs/srv/Step"})[
            "values"
        ]
        assert details["typedefs"][0]["fieldnames"] == ["steps", "until_topic", "until_count"]
        description = client.call("/rosapi/message_details", {"type": "harness_msgs/BridgeFrame"})
        assert "connection" in description["values"]["typedefs"][0]["fieldnames"]


def test_realtime_clock_advances_and_pauses(demo_position: LoadedRobot) -> None:
    with Session(demo_position, clock="realtime", rate=50.0) as session:
        assert session.run_until(lambda: session.sim.step_index >= 100, sim_timeout=5.0) >= 100
        session.pause()
        paused_at = session.step_index
        assert session.step_index == paused_at  # nothing moves while paused
        assert session.step(2) == paused_at + 2
