"""Busy-polling while time stands still (harness.session.live.polling): it runs for lockstep clients
in other processes only, adapts its window, backs off when a thread of ours wants the GIL, and
never changes what is recorded."""

from __future__ import annotations

import hashlib
import os
import selectors
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from harness.models import LoadedRobot
from harness.session import Session
from harness.session.live.polling import (
    GROW_START_NS,
    MAX_NS,
    PollingSelector,
    next_window,
    peer_in_process,
)

# a client in its own process: connects, then echoes one byte per byte it reads until EOF
_ECHO = r"""
import socket, sys
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])))
while (b := s.recv(1)):
    s.sendall(b)
"""


@pytest.fixture
def listener() -> Iterator[socket.socket]:
    server = socket.create_server(("127.0.0.1", 0))
    yield server
    server.close()


@pytest.fixture
def remote(listener: socket.socket) -> Iterator[socket.socket]:
    """Our end of a connection from a process of its own (an echo client)."""
    port = listener.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-c", _ECHO, str(port)])
    conn, _ = listener.accept()
    yield conn
    conn.close()
    proc.wait(timeout=30)


@pytest.fixture
def mine(listener: socket.socket) -> Iterator[tuple[socket.socket, socket.socket]]:
    """Both ends of a connection within this process (client end, accepted end)."""
    client = socket.create_connection(listener.getsockname())
    accepted, _ = listener.accept()
    yield client, accepted
    client.close()
    accepted.close()


@pytest.fixture
def selector() -> Iterator[PollingSelector]:
    polling = PollingSelector()
    polling.should_poll = lambda: True
    yield polling
    polling.close()


def test_a_peer_of_this_process_is_told_from_one_in_another(
    listener: socket.socket,
    remote: socket.socket,
    mine: tuple[socket.socket, socket.socket],
) -> None:
    client, accepted = mine
    assert peer_in_process(accepted)
    assert peer_in_process(client)
    assert not peer_in_process(remote)
    assert peer_in_process(listener)  # no peer: unknown, taken as local


def test_polling_runs_only_for_peers_in_other_processes_when_asked(
    listener: socket.socket,
    remote: socket.socket,
    mine: tuple[socket.socket, socket.socket],
    selector: PollingSelector,
) -> None:
    _, accepted = mine
    assert not selector.polling  # no peer registered
    selector.register(listener, selectors.EVENT_READ)
    assert not selector.polling  # a listening socket is no peer
    selector.register(remote, selectors.EVENT_READ)
    assert selector.polling
    selector.should_poll = lambda: False
    assert not selector.polling  # the owner's clock runs
    selector.should_poll = lambda: True
    selector.register(accepted, selectors.EVENT_READ)
    assert not selector.polling  # a client of this process would lose the GIL to us
    selector.modify(accepted, selectors.EVENT_WRITE)
    assert selector.polling  # not read from any more
    selector.unregister(accepted)
    selector.unregister(remote)
    assert not selector.polling
    assert PollingSelector(max_ns=0).polling is False


def test_a_quick_peer_grows_the_window_and_is_answered_while_polling(
    remote: socket.socket, selector: PollingSelector
) -> None:
    selector.cpu_free = lambda: True  # whatever else the machine runs now
    selector.register(remote, selectors.EVENT_READ)
    for _ in range(200):
        remote.sendall(b"x")
        ready = selector.select(timeout=30)
        assert [key.fileobj for key, _ in ready] == [remote]
        assert remote.recv(1) == b"x"
    assert selector.window_ns > 0
    assert selector.polled > 0  # some echoes came while polling


# a client in its own process that only listens (subscribed to /joint_states) until closed
_LISTENER = r"""
import json, sys
from websockets.sync.client import connect
with connect(sys.argv[1], compression=None) as ws:
    ws.send(json.dumps({"op": "subscribe", "topic": "/joint_states"}))
    for frame in ws:
        pass
"""


def test_a_session_stepped_from_python_does_not_poll(demo_position: LoadedRobot) -> None:
    """Between its calls the stepping thread runs Python and would wait for our GIL."""
    with Session(demo_position) as session:
        listener = subprocess.Popen([sys.executable, "-c", _LISTENER, session.url])
        try:
            session.wait_for_client(timeout=60)
            graph = session.core.graph
            # its subscription in, so that nothing but our calls wakes the loop from now on
            session.run_until(lambda: graph.has_subscribers("/joint_states"), sim_timeout=1000.0)
            selector = session._runner.selector
            selector.polled = 0
            assert selector.polling  # a client of another process, time standing still
            for _ in range(200):
                session.step(1)
            assert selector.polled == 0
        finally:
            session.close()
            listener.wait(timeout=60)


_SPIN = "while True: pass"


def test_no_polling_while_more_tasks_are_runnable_than_cpus(selector: PollingSelector) -> None:
    cpus = len(os.sched_getaffinity(0))
    spinners = [subprocess.Popen([sys.executable, "-c", _SPIN]) for _ in range(cpus + 1)]
    try:
        assert not selector.runnable_fit()
    finally:
        for proc in spinners:
            proc.kill()
            proc.wait(timeout=30)


@given(
    window=st.integers(0, MAX_NS),
    waited=st.integers(0, 10 * MAX_NS),
    max_ns=st.integers(GROW_START_NS, 10 * MAX_NS),
)
def test_the_window_grows_after_short_waits_and_shrinks_after_long(
    window: int, waited: int, max_ns: int
) -> None:
    window = min(window, max_ns)
    after = next_window(window, waited, max_ns)
    assert 0 <= after <= max_ns
    if waited <= max_ns:
        assert after >= min(max_ns, max(GROW_START_NS, window))
    else:
        assert after <= window // 2
        assert after == 0 or after >= GROW_START_NS


# a lockstep client in its own process, as robot software is: a command and a step per step
_CLIENT = r"""
import json, sys
from websockets.sync.client import connect
topic = "/forward_position_controller/commands"
with connect(sys.argv[1], compression=None) as ws:
    ws.send(json.dumps({"op": "subscribe", "topic": "/joint_states"}))
    for k in range(300):
        data = [0.1 * (k % 10) / 10, -0.78, 0.0, -2.35, 0.0, 1.57, 0.78, 0.02]
        ws.send(json.dumps({"op": "publish", "topic": topic, "msg": {"data": data}}))
        ws.send(json.dumps({"op": "call_service", "service": "/harness/step", "id": "s",
                            "args": {"steps": 1}}))
        while json.loads(ws.recv())["op"] != "service_response":
            pass
"""


def _recorded(robot: LoadedRobot, path: Path, max_ns: int) -> tuple[str, int]:
    with Session(robot, record_to=path) as session:
        session._runner.selector.max_ns = max_ns
        session._runner.selector.cpu_free = lambda: True  # whatever else the machine runs
        subprocess.run([sys.executable, "-c", _CLIENT, session.url], check=True, timeout=120)
        polled = session._runner.selector.polled
        assert session.step_index == 300
    return hashlib.sha256(path.read_bytes()).hexdigest(), polled


@pytest.mark.slow
def test_polling_changes_nothing_recorded(demo_position: LoadedRobot, tmp_path: Path) -> None:
    polling, polled = _recorded(demo_position, tmp_path / "polling.mcap", MAX_NS)
    blocking, none = _recorded(demo_position, tmp_path / "blocking.mcap", 0)
    assert polled > 0  # the client's requests were met by polling
    assert none == 0
    assert polling == blocking
