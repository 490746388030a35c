"""Deterministic close, snapshots of a running session, recordings without bridge frames, and
the golden comparison that ignores exactly the frames after the last step."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from harness.models import LoadedRobot
from harness.recording import BridgeFrame, Recording
from harness.replay import LevelUnavailableError, verify
from harness.replay.diff import diff, frames_after_last_step
from harness.replay.pipeline import replay_pipeline
from harness.session import Session, SessionError
from tests.session.session_helpers import Client


def _frames(path: Path) -> list[BridgeFrame]:
    with Recording(path) as rec:
        assert rec.complete
        return list(rec.bridge_frames())


def _tail(frames: list[BridgeFrame], last: int) -> list[tuple[int, int, int, str, str]]:
    """(step, direction, connection, op, topic) of every frame after the last step."""
    cut = next(i for i, f in enumerate(frames) if f.direction == 0 and f.step > last)
    return [(f.step, f.direction, f.connection, f.op, f.topic) for f in frames[cut:]]


def _run_with_goodbye(robot: LoadedRobot, path: Path) -> None:
    """A client steps, then sends frames after its last step without waiting for answers and
    stays connected while the session closes; a second client closed its socket earlier."""
    with Session(robot, record_to=path) as session:
        early = Client(session.url)
        early.step(5)
        early.close()
        client = Client(session.url)
        client.publish("/joint_command", {"name": ["joint1"], "position": [0.2]})
        client.step(20)
        client.send({"op": "subscribe", "topic": "/joint_states"})
        client.send({"op": "publish", "topic": "/joint_command", "msg": {"name": ["joint1"]}})
        client.send(
            {"op": "call_service", "service": "/harness/step", "args": {"steps": 5}, "id": "late"}
        )
        client.send({"op": "unsubscribe", "topic": "/joint_states"})
    client.close()


def test_close_processes_every_received_frame_then_records_close_and_disconnects(
    demo_position: LoadedRobot, tmp_path: Path
) -> None:
    path = tmp_path / "run.mcap"
    _run_with_goodbye(demo_position, path)
    frames = _frames(path)
    with Recording(path) as rec:
        last = rec.last_step
    # Processed as at any boundary, whether before close() or during it: the late step
    # request steps (lockstep), what follows it lands after the last step.
    assert last == 30
    late = [(f.step, f.op) for f in frames if f.direction == 0 and f.connection == 2][-4:]
    assert late == [
        (26, "subscribe"),
        (26, "publish"),
        (26, "call_service"),
        (31, "unsubscribe"),
    ]
    (answer,) = [f for f in frames if f.op == "service_response" and '"late"' in f.text]
    assert answer.step == 30
    assert json.loads(answer.text)["result"] is True
    assert _tail(frames, last) == [
        (31, 0, 2, "unsubscribe", "/joint_states"),
        (31, 0, 0, "", "harness/disconnect"),
        (31, 0, 0, "", "harness/close"),
    ]
    disconnects = [json.loads(f.text) for f in frames if f.topic == "harness/disconnect"]
    assert disconnects == [{"connection": 1}, {"connection": 2}]  # each exactly once
    close = [json.loads(f.text) for f in frames if f.topic == "harness/close"]
    assert close == [{"step": 30}]
    with Recording(path) as rec:
        assert frames_after_last_step(rec) == 3
    report = replay_pipeline(path)
    assert report.reproduced, report.mismatch


@pytest.mark.slow
def test_the_same_client_behaviour_ends_the_recording_the_same_way(
    demo_position: LoadedRobot, tmp_path: Path
) -> None:
    runs = [tmp_path / f"run{i}.mcap" for i in range(3)]
    for path in runs:
        _run_with_goodbye(demo_position, path)
    shapes = []
    for path in runs:
        frames = _frames(path)
        shapes.append([(f.step, f.direction, f.connection, f.seq, f.op, f.topic) for f in frames])
    assert shapes[0] == shapes[1] == shapes[2]
    assert diff(runs[0], runs[1]).same  # every topic's count, bridge frames included


def test_golden_diff_ignores_exactly_the_frames_after_the_last_step(
    demo_position: LoadedRobot, tmp_path: Path, client_factory: Callable[[str], Client]
) -> None:
    quiet, chatty = tmp_path / "quiet.mcap", tmp_path / "chatty.mcap"
    for path, late in ((quiet, 0), (chatty, 3)):
        with Session(demo_position, record_to=path) as session:
            client = client_factory(session.url)
            client.step(10)
            for _ in range(late):
                client.call("/harness/get_state")
    with Recording(chatty) as rec:
        assert frames_after_last_step(rec) == 3 * 2 + 2  # 3 calls + answers, disconnect, close
    counted = diff(quiet, chatty)
    assert [(e.quantity, e.name, e.a, e.b) for e in counted.entries] == [
        ("message_count", "/harness/bridge", 4, 10)  # step call + answer, disconnect, close
    ]
    assert diff(quiet, chatty, ignore_after_last_step=True).same

    # A frame inside the run is still counted: one more step request differs.
    longer = tmp_path / "longer.mcap"
    with Session(demo_position, record_to=longer) as session:
        client = client_factory(session.url)
        client.step(5)
        client.step(5)
    entries = diff(quiet, longer, ignore_after_last_step=True).entries
    assert [(e.quantity, e.name) for e in entries] == [("message_count", "/harness/bridge")]


def test_snapshot_is_a_complete_recording_of_the_run_so_far(
    demo_position: LoadedRobot, tmp_path: Path, client_factory: Callable[[str], Client]
) -> None:
    path, snap = tmp_path / "run.mcap", tmp_path / "snap.mcap"
    with Session(demo_position, record_to=path) as session:
        client = client_factory(session.url)
        client.publish("/joint_command", {"name": ["joint1"], "position": [0.4]})
        client.step(30)
        assert session.snapshot(snap) == 30
        client.step(20)  # the session keeps running
        with Recording(snap) as rec:
            assert rec.complete
            assert rec.last_step == 30
            assert [s.step for s in rec.physics_states()] == list(range(31))
            assert rec.metadata["clock"] == "lockstep"
            assert rec.attachment_names  # the model travels with it
        assert verify(snap).reproduced
        assert replay_pipeline(snap).reproduced
    with Recording(path) as full, Recording(snap) as part:
        assert full.last_step == 50
        want = [s.qpos.tolist() for s in full.physics_states() if s.step <= 30]
        assert [s.qpos.tolist() for s in part.physics_states()] == want
    with Session(demo_position) as session, pytest.raises(SessionError, match="records nothing"):
        session.snapshot(tmp_path / "none.mcap")


def test_record_bridge_frames_false_records_no_frames_and_full_replay_refuses(
    demo_position: LoadedRobot, tmp_path: Path, client_factory: Callable[[str], Client]
) -> None:
    path = tmp_path / "run.mcap"
    with Session(demo_position, record_to=path, record_bridge_frames=False) as session:
        client = client_factory(session.url)
        client.publish("/joint_command", {"name": ["joint1"], "position": [0.4]})
        client.step(20)
        session.set_positions({"joint2": 0.1})  # a Python command: no marker either
        session.step(5)
    with Recording(path) as rec:
        assert "/harness/bridge" not in rec.topics
        assert rec.metadata["bridge_frames"] == "false"
        assert rec.last_step == 25
    assert verify(path).reproduced  # physics replay needs no frames
    with pytest.raises(LevelUnavailableError, match="record_bridge_frames=False"):
        replay_pipeline(path)
    # The refusal is about the file, not the name: a copy is refused the same way.
    copy = tmp_path / "copy.mcap"
    shutil.copy(path, copy)
    with pytest.raises(LevelUnavailableError, match="use --level physics"):
        replay_pipeline(copy)
