"""diff: identical runs are the same, perturbed runs name the quantity, tolerances hold."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from harness.cli import main
from harness.replay.diff import Tolerances, diff


@pytest.fixture(scope="module")
def twin(helper: ModuleType, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("twin")
    a = helper.record(folder / "a.mcap", {0: helper.REACH, 150: helper.BACK}, 300)
    b = helper.record(folder / "b.mcap", {0: helper.REACH, 150: helper.BACK}, 300)
    return a, b


def test_identical_runs_are_the_same(twin: tuple[Path, Path], capsys: Any) -> None:
    a, b = twin
    report = diff(a, b)
    assert report.same
    assert report.steps_compared == 301
    assert main(["diff", str(a), str(b)]) == 0
    assert "SAME" in capsys.readouterr().out


def test_perturbed_run_names_the_quantity_and_tolerances_hold(
    helper: ModuleType, tmp_path: Path, capsys: Any
) -> None:
    # Away from the box (a reach into it is chaotic): joint3 commanded 2 mrad apart.
    a = helper.record(tmp_path / "a.mcap", {0: {"joint1": 0.3, "joint3": 0.0}}, 200)
    c = helper.record(tmp_path / "c.mcap", {0: {"joint1": 0.3, "joint3": 0.002}}, 200)
    report = diff(a, c)
    names = {(e.quantity, e.name) for e in report.entries}
    assert ("joint_position", "joint3") in names
    entry = next(e for e in report.entries if (e.quantity, e.name) == ("joint_position", "joint3"))
    assert entry.step == 1
    assert 0 < entry.max_delta < 0.05
    assert ("link_position", "link7") in names
    # Generous tolerances on every continuous quantity: only discrete ones could remain.
    loose = diff(a, c, Tolerances(joint_position=0.05, joint_velocity=10.0, link_position=0.05,
                                  link_rotation=0.05, collision_time_ns=10**9))  # fmt: skip
    assert loose.same, loose.format()
    out_json = tmp_path / "diff.json"
    assert main(["diff", str(a), str(c), "--report", str(out_json)]) == 1
    assert "joint_position" in capsys.readouterr().out
    assert json.loads(out_json.read_text())["same"] is False
    assert main(["diff", str(a), str(c), "--joint-position", "0.05", "--joint-velocity", "10",
                 "--link-position", "0.05", "--link-rotation", "0.05",
                 "--collision-time-ns", "1000000000"]) == 0  # fmt: skip


def test_collision_sets_with_time_tolerance(
    twin: tuple[Path, Path], mcap_edit: ModuleType, tmp_path: Path
) -> None:
    a, _ = twin
    events = [e for e in __import__("harness.recording", fromlist=["Recording"]).Recording(a)
              .collision_events()]  # fmt: skip
    assert events, "the base run must touch something (box on table)"

    def shift(topic: str, msg: Any) -> Any:
        if (
            topic == "/harness/collisions"
            and msg.body1 == events[0].body1
            and msg.step == events[0].step
        ):
            msg.sim_time_ns += 4_000_000
            msg.step += 2
        return msg

    late = mcap_edit.rewrite(a, tmp_path / "late.mcap", edit=shift)
    strict = diff(a, late)
    assert {e.quantity for e in strict.entries} == {"collisions"}
    assert len(strict.entries) == 2  # missing at the old time, extra at the new one
    assert diff(a, late, collision_time_ns=4_000_000).same

    dropped = mcap_edit.rewrite(
        a, tmp_path / "dropped.mcap",
        edit=lambda t, m: None if t == "/harness/collisions" and m.step == events[0].step else m,
    )  # fmt: skip
    report = diff(a, dropped, collision_time_ns=10**9)
    kinds = {(e.quantity, e.name) for e in report.entries}
    assert ("collisions", f"begin {events[0].body1}|{events[0].body2}") in kinds
    assert ("message_count", "/harness/collisions") in kinds


def test_first_divergence_names_the_input(helper: ModuleType, tmp_path: Path) -> None:
    a = helper.record(tmp_path / "a.mcap", {0: {"joint1": 0.3}, 40: {"joint3": 0.1}}, 80)
    b = helper.record(tmp_path / "b.mcap", {0: {"joint1": 0.3}, 40: {"joint3": 0.102}}, 80)
    report = diff(a, b)
    first = report.first_divergence
    assert first is not None
    assert first.cause is not None
    assert (first.cause.kind, first.cause.step) == ("input", 41)
    assert first.cause.what.startswith("ctrl[2] (joint3")
    assert (first.cause.a, first.cause.b) == ("0.1", "0.102")
    # The servo's force stays saturated for a while: the states part later than the inputs.
    assert first.step > 41
    assert first.quantity.startswith(f"joint_position joint3 at step {first.step} (A ")
    steps = [e.step for e in report.entries if e.step >= 0]
    assert steps == sorted(steps)
    link = next(e for e in report.entries if e.quantity == "link_position")
    assert isinstance(link.a, tuple)  # both positions, not A = 0
    assert len(link.a) == len(link.b) == 3
    assert link.a != link.b
    lines = report.format().splitlines()
    assert lines[3].startswith(
        f"FIRST DIVERGENCE at step {first.step} (sim time {first.step * 0.002:.6f} s): cause: "
    )
    assert "applied input ctrl[2] (joint3" in lines[3]


CLIENT = r"""
import json, sys
from websockets.sync.client import connect

ws = connect(sys.argv[1], compression=None)
def call(service, args, ident):
    ws.send(json.dumps({"op": "call_service", "service": service, "args": args, "id": ident}))
    while json.loads(ws.recv(timeout=10)).get("id") != ident:
        pass
def command(joint2):
    ws.send(json.dumps({"op": "publish", "topic": "/joint_command",
                        "msg": {"name": ["joint1", "joint2"], "position": [0.3, joint2]}}))
command(0.1)
call("/harness/step", {"steps": 30}, "a")
command(float(sys.argv[2]))
call("/harness/step", {"steps": 30}, "b")
if sys.argv[3] == "goodbye":
    call("/harness/get_state", {}, "c")
ws.close()
"""


def _client_run(path: Path, joint2: float, goodbye: bool) -> Path:
    import subprocess
    import sys

    from harness.session import Session

    with Session("demo", record_to=path, joint_states_hz=100) as session:
        subprocess.run(
            [sys.executable, "-c", CLIENT, session.url, repr(joint2),
             "goodbye" if goodbye else "-"],
            check=True, timeout=60,
        )  # fmt: skip
    return path


@pytest.mark.slow
def test_first_divergence_names_the_frame_and_goodbyes_can_be_ignored(
    tmp_path: Path, capsys: Any
) -> None:
    a = _client_run(tmp_path / "a.mcap", 0.2, goodbye=False)
    b = _client_run(tmp_path / "b.mcap", 0.25, goodbye=False)
    report = diff(a, b)
    first = report.first_divergence
    assert first is not None
    assert first.cause is not None
    assert first.cause.kind == "frame"
    assert "publish /joint_command" in first.cause.what
    assert first.cause.step == 31
    assert "0.2" in first.cause.a
    assert "0.25" in first.cause.b
    assert first.step == 31
    assert report.frames_compared > 3
    # The same run with a goodbye after the last step: only the frame count differs, and
    # --ignore-after-last-step leaves it out.
    c = _client_run(tmp_path / "c.mcap", 0.2, goodbye=True)
    assert main(["diff", str(a), str(c)]) == 1
    out = capsys.readouterr().out
    assert "message_count" in out
    assert main(["diff", str(a), str(c), "--ignore-after-last-step"]) == 0
    assert "SAME" in capsys.readouterr().out


def test_a_state_recorded_twice_is_noted(
    twin: tuple[Path, Path], mcap_edit: ModuleType, tmp_path: Path
) -> None:
    a, _ = twin

    def twice(topic: str, msg: Any) -> Any:
        if topic == "/harness/state" and int(msg.step) == 11:
            msg.step = 10  # as a reset recorded before epochs existed left it
        return msg

    legacy = mcap_edit.rewrite(a, tmp_path / "legacy.mcap", edit=twice)
    report = diff(a, legacy)
    assert report.notes == (
        "B: the state of step 10 is recorded twice (a reset recorded before resets became "
        "epochs): the first is compared",
    )
    assert "note: B: the state of step 10" in report.format()


def test_the_first_divergence_is_one_row_and_each_value_says_its_step(
    helper: ModuleType, tmp_path: Path
) -> None:
    """Issue 35: the headline, the FIRST DIVERGENCE line and the table named different
    joints (alphabetical vs largest), and the table's A and B (at the first step) stood next
    to the run's largest delta. One row is first (the largest difference at the first step,
    joints first), and each value says at which step it is."""
    # joint1 commanded 0.1 mrad apart, joint3 10 mrad: both differ from step 1 on.
    a = helper.record(tmp_path / "a.mcap", {0: {"joint1": 0.3, "joint3": 0.0}}, 60)
    b = helper.record(tmp_path / "b.mcap", {0: {"joint1": 0.3001, "joint3": 0.01}}, 60)
    report = diff(a, b)
    first = report.first_entry
    assert first is not None
    assert (first.quantity, first.name, first.step) == ("joint_position", "joint3", 1)
    assert report.entries[0] == first
    assert report.first_divergence is not None
    assert report.first_divergence.quantity.startswith("joint_position joint3 at step 1 (A ")
    lines = report.format().splitlines()
    header = next(i for i, line in enumerate(lines) if line.split()[:2] == ["step", "quantity"])
    assert lines[header].split() == [
        "step", "quantity", "name", "A", "B", "delta", "max", "delta", "max", "at", "tolerance"
    ]  # fmt: skip
    assert lines[header + 1].split()[:3] == ["1", "joint_position", "joint3"]
    joints = [e for e in report.entries if e.quantity.startswith("joint_")]
    assert len(joints) > 2
    for e in joints:
        assert e.delta == abs(e.b - e.a)  # A, B and delta: at the first step
        assert e.delta <= e.max_delta
        assert e.max_step >= e.step
    assert any(e.max_step > e.step and e.max_delta > e.delta for e in joints)
    at_one = [e.delta for e in joints if e.quantity == "joint_position" and e.step == 1]
    assert at_one == sorted(at_one, reverse=True)
    assert {"delta", "max_step"} <= set(report.to_json()["entries"][0])
