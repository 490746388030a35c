"""``harness replay --level full``: a real client in a subprocess drives a recorded lockstep
session (publishes, a trajectory, services, a refused command, a subscription, a Python
command); the bridge pipeline re-run reproduces every frame, applied input and state, and an
altered outgoing or incoming frame is reported at its step."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from websockets.sync.client import connect

from harness.cli import main
from harness.models import load_robot
from harness.recording import Recording
from harness.replay import verify
from harness.replay.errors import LevelUnavailableError
from harness.replay.pipeline import replay_pipeline
from harness.session import CoreOptions, Session, SessionCore
from harness.session.core import MARKER_PYTHON, is_marker

CLIENT = r"""
import json, sys
from websockets.sync.client import connect

ws = connect(sys.argv[1], compression=None)
ids = 0

def send(frame):
    ws.send(json.dumps(frame))

def call(service, args):
    global ids
    ids += 1
    send({"op": "call_service", "service": service, "args": args, "id": f"c{ids}"})
    while True:
        frame = json.loads(ws.recv(timeout=10))
        if frame.get("op") == "service_response" and frame.get("id") == f"c{ids}":
            assert frame["result"], frame
            return frame["values"]

send({"op": "subscribe", "topic": "/joint_states", "type": "sensor_msgs/msg/JointState"})
send({"op": "set_level", "level": "warning"})
send({"op": "publish", "topic": "/joint_command",
      "msg": {"name": ["joint1"], "position": [0.3]}})
call("/harness/step", {"steps": 20})
send({"op": "publish", "topic": "/joint_command",
      "msg": {"name": ["elbow"], "position": [0.1]}})
send({"op": "publish", "topic": "/joint_trajectory", "msg": {
    "joint_names": ["joint2"],
    "points": [{"positions": [0.25], "time_from_start": {"sec": 0, "nanosec": 40000000}}]}})
call("/harness/step", {"steps": 30})
state = call("/harness/get_state", {})
send({"op": "publish", "topic": "/joint_command",
      "msg": {"name": ["joint6"], "position": [1.5]}})
call("/harness/step", {"steps": 10})
call("/rosapi/topics", {})
print(json.dumps({"step": state["step"]}), flush=True)
ws.close()
"""


def _record(path: Path) -> dict[str, Any]:
    with Session("demo", record_to=path, joint_states_hz=100) as session:
        done = subprocess.run(
            [sys.executable, "-c", CLIENT, session.url],
            capture_output=True,
            text=True,
            timeout=60,
            check=True,
        )
        session.set_positions({"joint3": 0.2})  # a Python command: recorded as a marker
        session.step(10)
    result: dict[str, Any] = json.loads(done.stdout)
    return result


@pytest.fixture(scope="module")
def session_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("full") / "session.mcap"
    assert _record(path) == {"step": 50}
    return path


def _frames(path: Path) -> list[Any]:
    with Recording(path) as rec:
        return list(rec.bridge_frames())


def test_recorded_session_replays_at_full_level(
    session_recording: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    frames = _frames(session_recording)
    ops = {(f.direction, f.op, f.topic) for f in frames}
    assert (0, "call_service", "/harness/step") in ops
    assert (0, "publish", "/joint_trajectory") in ops
    assert (1, "publish", "/joint_states") in ops
    assert any(f.op == "status" and "command refused" in f.text for f in frames)
    markers = [f for f in frames if is_marker(f.direction, f.connection, f.op, f.topic)]
    assert MARKER_PYTHON in {m.topic for m in markers}

    assert main(["replay", str(session_recording), "--level", "full"]) == 0
    out = capsys.readouterr().out
    assert "PIPELINE REPRODUCED" in out

    report = replay_pipeline(session_recording)
    assert report.reproduced
    assert report.frames_compared == len(frames)
    assert report.steps == 70
    assert report.inputs_compared >= 4  # joint1, the trajectory's steps, joint6, joint3
    assert report.states_compared == 71


def _alter(mcap_edit: ModuleType, src: Path, dst: Path, seq: int, change: Any) -> Path:
    def edit(topic: str, msg: Any) -> Any:
        if topic == "/harness/bridge" and int(msg.seq) == seq and int(msg.connection) != 0:
            msg.text = change(msg.text)
        return msg

    return mcap_edit.rewrite(src, dst, edit=edit)  # type: ignore[no-any-return]


def test_altered_outgoing_frame_is_named(
    session_recording: Path,
    mcap_edit: ModuleType,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    outgoing = [
        f for f in _frames(session_recording) if f.direction == 1 and f.topic == "/joint_states"
    ]
    target = outgoing[len(outgoing) // 2]
    position = json.loads(target.text)["msg"]["position"][0]
    altered = _alter(
        mcap_edit,
        session_recording,
        tmp_path / "out.mcap",
        target.seq,
        lambda text: text.replace(repr(position), repr(position + 1.0), 1),
    )
    report_path = tmp_path / "report.json"
    assert main(["replay", str(altered), "--level", "full", "--report", str(report_path)]) == 1
    out = capsys.readouterr().out
    assert "PHYSICS REPRODUCED" in out  # the physics is untouched: only the frame changed
    assert f"PIPELINE DIVERGED at step {target.step} " in out
    assert f"connection {target.connection}, op 'publish', topic '/joint_states'" in out
    mismatch = json.loads(report_path.read_text())["pipeline"]["mismatch"]
    assert mismatch["kind"] == "frame"
    assert mismatch["step"] == target.step
    assert mismatch["connection"] == target.connection
    assert mismatch["direction"] == "out"
    assert mismatch["topic"] == "/joint_states"
    assert mismatch["what"] == "text differs"
    assert repr(position + 1.0) in mismatch["expected"]
    assert repr(position) in mismatch["actual"]


def test_altered_incoming_command_is_an_input_mismatch(
    session_recording: Path, mcap_edit: ModuleType, tmp_path: Path
) -> None:
    command = next(
        f
        for f in _frames(session_recording)
        if f.direction == 0 and f.topic == "/joint_command" and '"joint6"' in f.text
    )
    altered = _alter(
        mcap_edit,
        session_recording,
        tmp_path / "in.mcap",
        command.seq,
        lambda text: text.replace("[1.5]", "[1.25]"),
    )
    report = verify(altered, level="full")
    assert not report.reproduced
    assert report.divergence is None  # the recorded inputs still replay the physics
    assert report.pipeline is not None
    mismatch = report.pipeline.mismatch
    assert mismatch is not None
    assert mismatch.kind == "input"
    assert mismatch.step == command.step  # the step before which the command took effect
    assert mismatch.what.startswith("ctrl[5] (joint6")
    assert mismatch.expected == "1.5"
    assert mismatch.actual == "1.25"


def test_recordings_the_pipeline_cannot_rerun_are_refused(base_recording: Path) -> None:
    with pytest.raises(LevelUnavailableError, match="not a session recording"):
        replay_pipeline(base_recording)


def test_fast_clock_session_replays(tmp_path: Path) -> None:
    """Free-running steps: frames take effect wherever the clock was; their recorded steps
    are all the re-run needs (a pause from a client and from Python, a disconnect)."""
    path = tmp_path / "fast.mcap"
    with Session("demo", clock="fast", record_to=path) as session:
        ws = connect(session.url, compression=None).__enter__()  # closed by ws.close()
        ws.send(json.dumps({"op": "subscribe", "topic": "/clock", "type": "rosgraph_msgs/Clock"}))
        for i in range(3):
            while json.loads(ws.recv(timeout=10)).get("topic") != "/clock":
                pass
            command = {"name": ["joint1"], "position": [0.1 * (i + 1)]}
            ws.send(json.dumps({"op": "publish", "topic": "/joint_command", "msg": command}))
        ws.send(
            json.dumps({"op": "call_service", "service": "/harness/pause", "args": {"data": True}})
        )
        while json.loads(ws.recv(timeout=10)).get("op") != "service_response":
            pass
        session.step(3)
        session.resume()
        ws.close()
        session.run_until(lambda: session.sim.step_index >= 80, sim_timeout=10)
    report = replay_pipeline(path)
    assert report.reproduced, report.format()
    assert report.markers >= 1  # Python resume (and the disconnect, when seen before close)
    assert report.inputs_compared >= 1


def test_core_without_sockets() -> None:
    """The core alone: a frame in at a boundary, outputs from the bridge's outbox."""
    robot = load_robot("demo", control="position")
    core = SessionCore(robot, CoreOptions(joint_states_hz=0, tf_hz=0, clock_hz=0))
    bridge = core.bridge
    assert bridge is not None
    core.start()
    core.publish_initial()
    c = bridge.connect()
    command = {"op": "publish", "topic": "/joint_command", "msg": {"name": ["x"], "position": [1]}}
    (status,) = [json.loads(o.data) for o in bridge.receive(c, json.dumps(command), 0)]
    assert status["level"] == "error"
    assert "command refused: unknown joint 'x'" in status["msg"]
    call = {"op": "call_service", "service": "/harness/step", "args": {"steps": 4}, "id": 1}
    (answer,) = bridge.receive(c, json.dumps(call), 0)
    assert json.loads(answer.data)["values"]["sim_time"]["nanosec"] == 4 * core.dt_ns
    assert core.sim.step_index == 4
