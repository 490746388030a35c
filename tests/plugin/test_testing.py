"""harness.testing: the synchronous rosbridge client and sim-time waits, on real sessions."""

from __future__ import annotations

import pytest

from harness import Session
from harness.testing import ServiceCallFailed, TestClientTimeout, advance, connect


@pytest.fixture
def session():
    with Session("demo") as s:
        yield s


def test_wait_for_message_steps_in_sim_time(session):
    with connect(session.url) as client:
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        msg = states.wait_for_message(sim_timeout=1.0)
        # joint_states at 100 Hz of sim time, 2 ms steps: the first one after 5 steps.
        assert msg["header"]["stamp"] == {"sec": 0, "nanosec": 10_000_000}
        assert session.step_index == 5
        later = states.wait_for_message(
            sim_timeout=1.0, predicate=lambda m: m["header"]["stamp"]["nanosec"] >= 50_000_000
        )
        assert later["header"]["stamp"]["nanosec"] == 50_000_000
        assert session.step_index == 25


def test_wait_timeout_names_the_sim_time(session):
    with connect(session.url) as client:
        quiet = client.subscribe("/nobody_publishes", "std_msgs/msg/String")
        with pytest.raises(TestClientTimeout, match=r"not within 0\.02 s of simulation time"):
            quiet.wait_for_message(sim_timeout=0.02)
        assert session.step_index == 10


def test_publish_sync_then_python_step_applies_the_command(session):
    with connect(session.url) as client:
        client.publish(
            "/joint_command",
            "sensor_msgs/msg/JointState",
            {"name": ["joint1"], "position": [0.25]},
        )
        client.sync()
        assert session.joint_commands()[0] == pytest.approx(0.25)
        assert advance(session, 0.1) == 50
        assert client.state()["step"] == 50


def test_refused_call_and_error_status(session):
    with connect(session.url) as client:
        with pytest.raises(ServiceCallFailed, match="/no/such/service"):
            client.call_service("/no/such/service")
        client.publish(
            "/joint_command", "sensor_msgs/msg/JointState", {"name": ["elbow"], "position": [1.0]}
        )
        client.sync()
        assert any("unknown joint 'elbow'" in s["msg"] for s in client.statuses)


def test_free_running_clock_waits_follow_clock():
    with Session("demo", clock="fast") as session, connect(session.url, lockstep=False) as client:
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        msg = states.wait_for_message(sim_timeout=5.0)
        assert msg["name"][0] == "joint1"
        quiet = client.subscribe("/nobody_publishes", "std_msgs/msg/String")
        with pytest.raises(TestClientTimeout, match="simulation time"):
            quiet.wait_for_message(sim_timeout=0.05)
