"""The client under test: started once the endpoint listens, judged, and always stopped.

The endpoint is a real WebSocket server on 127.0.0.1 (StandInHost): the readiness condition
is a client connecting to it. Clients are real processes (tests/data/scenario/clients)."""

import sys
from pathlib import Path

import pytest

from harness.scenario import ClientSpec, run_client
from tests.scenario.scenario_testlib import CLIENT, process_gone
from tests.scenario.standins import StandInHost


def _spec(tmp_path, mode, readiness=20.0, wall=60.0):
    pidfile = tmp_path / "pids"
    command = (sys.executable, str(CLIENT), mode, str(pidfile))
    return ClientSpec(command, tmp_path, {}, readiness, wall), pidfile


def _pids(pidfile: Path) -> list[int]:
    return [int(p) for p in pidfile.read_text().split()]


def test_client_that_connects_and_exits_zero_passes(tmp_path):
    spec, pidfile = _spec(tmp_path, "ok")
    with StandInHost() as host:
        outcome = run_client(spec, host, 10.0, tmp_path / "client.log")
        assert host.client_connected()
    assert outcome.status == "exited"
    assert outcome.exit_code == 0
    assert outcome.passed
    assert all(process_gone(p) for p in _pids(pidfile))


def test_environment_carries_the_bridge_url(tmp_path):
    code = "import os; print(os.environ['HARNESS_ROSBRIDGE_URL'], os.environ['EXTRA'])"
    spec = ClientSpec((sys.executable, "-c", code), tmp_path, {"EXTRA": "yes"}, 20.0, 60.0)
    with StandInHost() as host:
        outcome = run_client(spec, host, 10.0, tmp_path / "client.log")
        url = host.url
    assert (tmp_path / "client.log").read_text().split() == [url, "yes"]
    # Exiting 0 without ever connecting is not a pass: the client did not test anything.
    assert outcome.status == "not_ready"
    assert outcome.exit_code == 0
    assert not outcome.passed
    assert "without connecting" in outcome.reason


def test_crashing_client_fails_with_exit_code_and_its_last_output(tmp_path):
    spec, pidfile = _spec(tmp_path, "crash")
    with StandInHost() as host:
        outcome = run_client(spec, host, 10.0, tmp_path / "client.log")
    assert outcome.status == "exited"
    assert outcome.exit_code == 3
    assert not outcome.passed
    assert "client exited with code 3" in outcome.reason
    assert "simulated failure in the client under test" in outcome.reason
    assert all(process_gone(p) for p in _pids(pidfile))


def test_client_that_never_connects_fails_at_the_readiness_timeout(tmp_path):
    spec, pidfile = _spec(tmp_path, "noconnect", readiness=1.0)
    with StandInHost() as host:
        outcome = run_client(spec, host, 10.0, tmp_path / "client.log", grace=2.0)
        url = host.url
    assert outcome.status == "not_ready"
    assert outcome.reason == f"client did not connect to {url} within 1 s"
    # On time: not before the limit, and within the limit plus the stop grace (and slack).
    assert 1.0 <= outcome.wall_seconds < 1.0 + 2.0 + 10.0
    assert all(process_gone(p) for p in _pids(pidfile))


def test_hanging_client_is_stopped_at_the_wall_time_limit(tmp_path):
    spec, pidfile = _spec(tmp_path, "hang", wall=1.5)
    with StandInHost() as host:
        outcome = run_client(spec, host, 10.0, tmp_path / "client.log", grace=2.0)
    assert outcome.status == "wall_timeout"
    assert "wall-time limit 1.5 s" in outcome.reason
    assert "sim time 0.000 s of 10 s" in outcome.reason
    assert 1.5 <= outcome.wall_seconds < 1.5 + 2.0 + 10.0
    assert all(process_gone(p) for p in _pids(pidfile))


def test_client_ignoring_sigterm_and_its_child_are_killed(tmp_path):
    spec, pidfile = _spec(tmp_path, "stubborn", wall=1.0)
    with StandInHost() as host:
        outcome = run_client(spec, host, 10.0, tmp_path / "client.log", grace=0.5)
    pids = _pids(pidfile)
    assert len(pids) == 2
    assert outcome.status == "wall_timeout"
    assert all(process_gone(p) for p in pids)


def test_run_ends_at_the_sim_time_limit_and_that_passes(tmp_path):
    spec, pidfile = _spec(tmp_path, "hang")
    with StandInHost(clock="fast", sim_time_limit=0.5) as host:
        outcome = run_client(spec, host, 0.5, tmp_path / "client.log")
        assert host.sim_time() >= 0.5
    assert outcome.status == "sim_limit"
    assert outcome.passed
    assert outcome.reason == "sim-time limit 0.5 s reached"
    assert all(process_gone(p) for p in _pids(pidfile))


def test_command_that_cannot_start(tmp_path):
    spec = ClientSpec(("/nonexistent/client-binary",), tmp_path, {}, 5.0, 5.0)
    with StandInHost() as host:
        outcome = run_client(spec, host, 1.0, tmp_path / "client.log")
    assert not outcome.passed
    assert "'/nonexistent/client-binary' could not start" in outcome.reason


@pytest.mark.parametrize("mode", ["hang", "noconnect"])
def test_endpoint_closes_with_clients_attached(tmp_path, mode):
    # The stand-in endpoint itself must not keep anything running after the block.
    spec, _ = _spec(tmp_path, mode, readiness=0.5, wall=0.5)
    host = StandInHost()
    with host:
        run_client(spec, host, 10.0, tmp_path / "client.log", grace=1.0)
    assert all(not t.is_alive() for t in host._threads)
