"""A free-running (fast) run resumed: the session waits paused at the step (recorded as a
``pause`` marker), runs on when resumed, and its child replays on its own."""

from __future__ import annotations

import json
from pathlib import Path

from harness import Session
from harness.cli import main
from harness.recording import Recording

from .conftest import states


def test_a_fast_run_resumes_paused(tmp_path: Path) -> None:
    parent, child = tmp_path / "fast.mcap", tmp_path / "child.mcap"
    with Session("demo", clock="fast", start="paused", record_to=parent) as session:
        session.set_positions({"joint1": 0.5})
        session.pause_at(500)
        session.resume()
        session.run_until(lambda: session.sim.step_index >= 500, sim_timeout=2.0)
    with Session.resume(parent, step=200, record_to=child) as session:
        assert session.clock == "fast"
        assert session.paused
        assert session.step_index == 200
        session.pause_at(500)
        session.resume()
        session.run_until(lambda: session.sim.step_index >= 500, sim_timeout=2.0)
    with Recording(child) as rec:
        pauses = [
            (f.step, json.loads(f.text))
            for f in rec.bridge_frames(200)
            if f.topic == "harness/python"
        ]
    assert pauses[0] == (201, {"call": "pause", "paused": True})
    assert states(child, 200) == {k: v for k, v in states(parent, 200).items() if k <= 500}
    assert main(["replay", str(child), "--level", "full"]) == 0
