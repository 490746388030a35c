"""The scenario runner on the Session's public API: fast and realtime scenarios run in their
own clock mode (started by the client, paused exactly at the limit), and
``recording.bridge_frames: false`` is honoured."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

from harness.recording import Recording
from harness.replay import LevelUnavailableError, verify
from harness.replay.pipeline import replay_pipeline
from harness.scenario import iteration_specs, load_run_file, session_iteration_runner

# Connects, commands joint1 once, then reads until the runner stops it at the sim-time limit.
CLIENT = """
import json, os
from websockets.sync.client import connect
with connect(os.environ["HARNESS_ROSBRIDGE_URL"]) as ws:
    ws.send(json.dumps({"op": "publish", "topic": "/joint_command",
                        "msg": {"name": ["joint1"], "position": [0.3]}}))
    for _ in ws:
        pass
"""


def _scenario(tmp_path: Path, **overrides: Any) -> Path:
    doc = {
        "robots": [{"robot": "demo"}],
        "environment": {"map": "empty"},
        "duration": 0.3,
        "criteria": {"no_collisions": False, "joint_limit_tolerance": 1e-4},  # gripper settling
        **overrides,
    }
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


@pytest.mark.parametrize("clock", [{"mode": "fast"}, {"mode": "realtime", "rate": 5.0}])
@pytest.mark.slow
def test_free_clock_scenarios_run_in_their_own_clock_from_the_client_to_the_limit(
    tmp_path: Path, clock: dict[str, Any]
) -> None:
    client = {"command": [sys.executable, "-c", CLIENT], "readiness_timeout": 20}
    path = _scenario(tmp_path, clock=clock, client=client)
    (spec,) = iteration_specs(load_run_file(path), tmp_path / "out")
    result = session_iteration_runner()(spec)
    assert result.passed, result.reason
    assert result.client is not None
    assert result.client.status == "sim_limit"
    assert result.steps == 150  # exactly 0.3 s at 2 ms: the clock paused at the limit
    with Recording(result.recording) as rec:
        assert rec.metadata["clock"] == clock["mode"]
        assert rec.metadata["start"] == "on_client"
        assert rec.last_step == 150
        frames = [f for f in rec.bridge_frames() if f.direction == 0]
    start = frames[0]
    assert (start.step, start.topic, json.loads(start.text)) == (
        1,
        "harness/python",
        {"call": "pause", "paused": False},
    )
    if clock["mode"] == "realtime":
        # a fast clock may reach its limit before the client's first frame arrives (a race
        # with the wall clock by design); at 5x real time 0.3 s of sim time is 60 ms of wall
        assert any(f.op == "publish" and f.topic == "/joint_command" for f in frames)
    assert replay_pipeline(result.recording).reproduced


def test_bridge_frames_false_is_honoured(tmp_path: Path) -> None:
    path = _scenario(tmp_path, clock={"mode": "fast"}, recording={"bridge_frames": False})
    (spec,) = iteration_specs(load_run_file(path), tmp_path / "out")
    result = session_iteration_runner()(spec)
    assert result.passed, result.reason
    assert result.steps == 150
    with Recording(result.recording) as rec:
        assert "/harness/bridge" not in rec.topics
        assert rec.metadata["bridge_frames"] == "false"
        assert rec.metadata["clock"] == "fast"
    assert verify(result.recording).reproduced
    with pytest.raises(LevelUnavailableError, match="record_bridge_frames=False"):
        replay_pipeline(result.recording)
