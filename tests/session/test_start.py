"""Start control of free-running clocks, client readiness, pause_at, the /harness/step cap."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest

from harness.models import LoadedRobot
from harness.recording import Recording
from harness.replay.pipeline import replay_pipeline
from harness.session import (
    ClientTimeoutError,
    Session,
    SessionConfigError,
)
from tests.session.session_helpers import Client


@pytest.mark.slow
def test_on_client_clock_starts_at_step_zero_when_the_first_client_connects(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client], tmp_path: Path
) -> None:
    path = tmp_path / "run.mcap"
    with Session(demo_position, clock="fast", start="on_client", record_to=path) as session:
        assert session.paused
        assert (session.client_count, session.clients_seen) == (0, 0)
        with pytest.raises(ClientTimeoutError, match=r"0 of 1 client\(s\) connected to ws://"):
            session.wait_for_client(timeout=0.05)
        assert session.step_index == 0  # nobody connected: the clock has not started
        client = client_factory(session.url)
        assert session.wait_for_client(timeout=10) == 1
        client.publish("/joint_command", {"name": ["joint1"], "position": [0.3]})
        reached = session.run_until(lambda: session.sim.step_index >= 200, sim_timeout=10.0)
        assert reached >= 200
        assert not session.paused
        assert session.client_count == 1
        client.close()
        session.run_until(lambda: session.client_count == 0, sim_timeout=10.0)
        assert session.clients_seen == 1
    with Recording(path) as rec:
        assert rec.metadata["clock"] == "fast"
        assert rec.metadata["start"] == "on_client"
        first = next(iter(rec.bridge_frames()))
    # The start is the first input, before any frame of the client, at step 0's boundary.
    assert (first.step, first.sim_time_ns, first.connection, first.topic) == (
        1,
        0,
        0,
        "harness/python",
    )
    assert json.loads(first.text) == {"call": "pause", "paused": False}
    assert replay_pipeline(path).reproduced


def test_paused_start_and_pause_at_stop_exactly(demo_position: LoadedRobot) -> None:
    with Session(demo_position, clock="realtime", rate=100.0, start="paused") as session:
        assert session.paused
        assert session.step(3) == 3  # a paused free clock steps on request
        session.pause_at(120)
        session.resume()
        assert session.run_until(lambda: session.sim.step_index >= 120, sim_timeout=5.0) == 120
        assert session.call(lambda: session.core.paused)
        assert session.step_index == 120  # paused exactly there, nothing more
        assert session.step(1) == 121


def test_now_start_steps_without_any_client(demo_position: LoadedRobot) -> None:
    with Session(demo_position, clock="fast") as session:
        assert not session.paused
        assert session.run_until(lambda: session.sim.step_index >= 50, sim_timeout=5.0) >= 50
        assert session.clients_seen == 0


def test_start_modes_are_refused_where_they_mean_nothing(demo_position: LoadedRobot) -> None:
    with pytest.raises(SessionConfigError, match="start='on_client' applies to the fast and"):
        Session(demo_position, start="on_client")
    with pytest.raises(SessionConfigError, match="start must be one of now, paused, on_client"):
        Session(demo_position, clock="fast", start="later")  # type: ignore[arg-type]
    with pytest.raises(SessionConfigError, match="max_step_request must be an integer >= 1"):
        Session(demo_position, max_step_request=0)


def test_step_requests_above_the_cap_fail_without_stepping(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client], tmp_path: Path
) -> None:
    path = tmp_path / "run.mcap"
    with Session(demo_position, max_step_request=100, record_to=path) as session:
        client = client_factory(session.url)
        refused = client.call("/harness/step", {"steps": 101})
        assert refused["result"] is False
        assert "101 steps requested, more than max_step_request=100 per call" in str(
            refused["values"]
        )
        assert session.step_index == 0
        assert client.step(100)["values"]["sim_time"]["nanosec"] == 200_000_000
        assert session.step_index == 100
    with Recording(path) as rec:
        assert rec.metadata["max_step_request"] == "100"
    assert replay_pipeline(path).reproduced  # the refusal replays identically
