"""Resets replay: a reset from a client (``/harness/reset``) and from Python (``Session.reset``)
are recorded as epochs (``/harness/epoch``), and the recording replays at both levels, diffs
against itself and inspects as sound."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from websockets.sync.client import connect

from harness.cli import main
from harness.recording import Recording
from harness.recording.inspect import inspect
from harness.recording.layout import TOPIC_EPOCH
from harness.replay import verify
from harness.replay.diff import diff


def _call(ws: object, service: str, args: dict[str, object], ident: str) -> dict[str, object]:
    ws.send(json.dumps({"op": "call_service", "service": service, "args": args, "id": ident}))  # type: ignore[attr-defined]
    while True:
        frame = json.loads(ws.recv(timeout=10))  # type: ignore[attr-defined]
        if frame.get("op") == "service_response" and frame.get("id") == ident:
            assert frame["result"], frame
            return frame["values"]  # type: ignore[no-any-return]


def _record(path: Path) -> None:
    from harness.session import Session

    with Session("demo", record_to=path, joint_states_hz=100) as session:
        with connect(session.url, compression=None) as ws:
            command = {"name": ["joint1", "joint2"], "position": [0.5, 0.3]}
            ws.send(json.dumps({"op": "publish", "topic": "/joint_command", "msg": command}))
            _call(ws, "/harness/step", {"steps": 40}, "a")
            _call(ws, "/harness/reset", {}, "b")  # a reset from a client
            _call(ws, "/harness/step", {"steps": 20}, "c")
        session.set_positions({"joint3": 0.2})
        session.step(15)
        session.reset()  # and from Python
        session.reset()  # twice at one step: the last state wins
        session.step(10)


@pytest.fixture(scope="module")
def reset_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("epochs") / "resets.mcap"
    _record(path)
    return path


def test_resets_are_epochs_and_states_stay_one_per_step(reset_recording: Path) -> None:
    with Recording(reset_recording) as rec:
        epochs = rec.epochs()
        states = rec.physics_state_arrays()
        assert rec.topics[TOPIC_EPOCH].messages == 3
    assert [(e.step, e.epoch, e.reason) for e in epochs] == [
        (40, 1, "reset"),
        (75, 2, "reset"),
        (75, 3, "reset"),
    ]
    assert np.all(np.diff(states.steps) == 1)  # no step recorded twice
    # The state recorded for step 40 ends the first epoch; the epoch's state starts the next.
    at40 = int(np.flatnonzero(states.steps == 40)[0])
    assert not np.array_equal(states.qpos[at40], epochs[0].qpos)
    assert np.array_equal(epochs[0].qpos, states.qpos[0])  # back to the initial pose
    assert float(epochs[0].state[0]) == pytest.approx(40 * 0.002)  # time continues


def test_reset_recording_replays_at_both_levels(
    reset_recording: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    physics = verify(reset_recording)
    assert physics.reproduced, physics.format()
    assert physics.states_compared == 85  # steps 1..85 against step 0, each once
    assert any("3 epoch(s)" in n for n in physics.notes)
    full = verify(reset_recording, level="full")
    assert full.reproduced, full.format()
    assert main(["replay", str(reset_recording), "--level", "full"]) == 0
    assert "PIPELINE REPRODUCED" in capsys.readouterr().out


def test_a_wrong_epoch_state_is_found(
    reset_recording: Path, mcap_edit: object, tmp_path: Path
) -> None:
    def edit(topic: str, msg: object) -> object:
        if topic == TOPIC_EPOCH and int(msg.epoch) == 1:  # type: ignore[attr-defined]
            state = np.array(msg.state)  # type: ignore[attr-defined]
            state[8] += 1e-6  # a joint position of the state the run continues from
            msg.state = state  # type: ignore[attr-defined]
        return msg

    altered = mcap_edit.rewrite(reset_recording, tmp_path / "bad.mcap", edit=edit)  # type: ignore[attr-defined]
    report = verify(altered)
    assert not report.reproduced
    assert report.divergence is not None
    assert report.divergence.step == 41  # the first step after the altered reset


def test_inspect_and_diff_know_epochs(reset_recording: Path) -> None:
    report = inspect(reset_recording)
    assert report["verdict"] == "ok"
    assert [e["step"] for e in report["epochs"]] == [40, 75, 75]
    assert diff(reset_recording, reset_recording).same


def test_resimulation_replays_the_resets(reset_recording: Path) -> None:
    from harness.replay.resim import resimulate

    report = resimulate(reset_recording, "servo")
    assert report.recorded_reproduced  # the recorded run, resets included, bit for bit
    assert report.passed, report.format()
