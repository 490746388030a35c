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
