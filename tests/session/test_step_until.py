"""The batched /harness/step form: step until a topic has published N messages."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from harness.models import LoadedRobot
from harness.recording import Recording
from harness.replay.pipeline import replay_pipeline
from harness.session import Session
from tests.session.session_helpers import Client


def test_step_until_a_topic_has_published(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client], tmp_path: Path
) -> None:
    path = tmp_path / "run.mcap"
    with Session(demo_position, record_to=path) as session:
        client = client_factory(session.url)
        before = session.step_index
        answer = client.call(
            "/harness/step", {"steps": 1000, "until_topic": "/joint_states", "until_count": 3}
        )
        assert answer["result"] is True, answer
        end_ns = session.sim.sim_time_ns
        assert answer["values"]["sim_time"] == {"sec": 0, "nanosec": end_ns}
        done = session.step_index - before
        assert 0 < done < 1000
        # the old form answers as it always did
        old = client.call("/harness/step", {"steps": 7})["values"]
        assert old == {"sim_time": {"sec": 0, "nanosec": session.sim.sim_time_ns}}
        # a topic the session never publishes: every step is taken
        at = session.step_index
        client.call("/harness/step", {"steps": 5, "until_topic": "/nobody"})
        assert session.step_index == at + 5
        # until_count without a topic is refused, nothing stepped
        at = session.step_index
        refused = client.call("/harness/step", {"steps": 5, "until_count": 2})
        assert refused["result"] is False
        assert "needs an until_topic" in str(refused["values"])
        assert session.step_index == at
    with Recording(path) as rec:
        times = [m.sim_time_ns for m in rec.messages(topics=["/joint_states"])]
    during = [t for t in times if t <= end_ns]
    # exactly three joint states in the call (one before it may come from the start-up step 0)
    assert len([t for t in during if t > before * session.dt_ns]) == 3
    assert during[-1] == end_ns  # it stopped at the step that published the third
    assert replay_pipeline(path).reproduced
