"""verify: bit-exact replay of real recordings, and first-divergence reports."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from harness.cli import main
from harness.replay import verify

ARM = ("joint1", "joint2", "joint3", "joint4", "joint5", "joint6", "joint7")
RANGES = {
    "joint1": (-2.8, 2.8),
    "joint2": (-1.7, 1.7),
    "joint3": (-2.8, 2.8),
    "joint4": (-3.0, -0.1),
    "joint5": (-2.8, 2.8),
    "joint6": (0.0, 3.7),
    "joint7": (-2.8, 2.8),
}


@st.composite
def command_sequences(draw: st.DrawFn) -> dict[int, dict[str, float]]:
    steps = draw(st.lists(st.integers(0, 119), min_size=1, max_size=4, unique=True))
    out: dict[int, dict[str, float]] = {}
    for step in steps:
        joints = draw(st.lists(st.sampled_from(ARM), min_size=1, max_size=3, unique=True))
        out[step] = {
            j: draw(st.floats(*RANGES[j], allow_nan=False, allow_infinity=False)) for j in joints
        }
    return out


@settings(
    max_examples=4,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(commands=command_sequences(), control=st.sampled_from(["position", "kinematic"]))
def test_random_command_sequences_replay_bit_exactly(
    helper: ModuleType, tmp_path: Path, commands: dict[int, dict[str, float]], control: str
) -> None:
    path = helper.record(tmp_path / f"random-{control}.mcap", commands, 120, control=control)
    report = verify(path)
    assert report.reproduced, report.format()
    assert report.divergence is None
    assert report.states_compared == 120
    assert report.model_source == "model.mjb"


def test_replay_from_source_attachments_without_mjb(helper: ModuleType, tmp_path: Path) -> None:
    path = helper.record(tmp_path / "nomjb.mcap", {0: {"joint1": 0.3}}, 80, with_mjb=False)
    report = verify(path)
    assert report.reproduced, report.format()
    assert report.model_source.startswith("source attachments")


def _changed_input(mcap_edit: ModuleType, src: Path, dst: Path, step: int) -> Path:
    def edit(topic: str, msg: Any) -> Any:
        if topic == "/harness/inputs" and msg.step == step:
            msg.ctrl = msg.ctrl.copy()
            msg.ctrl[1] += 0.01  # joint2's actuator
        return msg

    return mcap_edit.rewrite(src, dst, edit=edit)  # type: ignore[no-any-return]


def test_changed_input_is_named_at_its_step(
    base_recording: Path, helper: ModuleType, mcap_edit: ModuleType, tmp_path: Path
) -> None:
    altered = _changed_input(mcap_edit, base_recording, tmp_path / "input.mcap", 151)
    report = verify(altered)
    assert not report.reproduced
    d = report.divergence
    assert d is not None
    assert d.step == 151
    assert d.sim_time_ns == 151 * round(float(helper.demo_robot().model.opt.timestep) * 1e9)
    assert d.last_matching_step == 150
    ctrl = [q for q in d.quantities if q.component == "ctrl"]
    assert [q.name for q in ctrl] == ["joint2"]
    assert ctrl[0].delta == pytest.approx(0.01)


def test_changed_state_is_named_at_its_step(
    base_recording: Path, helper: ModuleType, mcap_edit: ModuleType, tmp_path: Path
) -> None:
    def edit(topic: str, msg: Any) -> Any:
        if topic == "/harness/state" and msg.step == 77:
            msg.state = msg.state.copy()
            msg.state[1 + qpos3] += 1e-9  # qpos of joint3 (index 0 is time)
        return msg

    model = helper.demo_robot().model
    qpos3 = int(model.jnt_qposadr[model.joint("joint3").id])

    altered = mcap_edit.rewrite(base_recording, tmp_path / "state.mcap", edit=edit)
    report = verify(altered)
    d = report.divergence
    assert d is not None
    assert (d.step, d.last_matching_step) == (77, 76)
    assert [(q.component, q.name) for q in d.quantities] == [("qpos", "joint3")]
    assert d.quantities[0].delta == pytest.approx(-1e-9, rel=1e-3)
    moved = {b.name for b in d.bodies}
    assert {"link3", "link4", "link7"} <= moved  # joint3's body and everything below it
    assert not moved & {"link1", "link2", "box", "table"}
    # A tolerance above the change hides it.
    assert verify(altered, atol=1e-6).reproduced


def test_cli_exit_codes_and_json_report(
    base_recording: Path, mcap_edit: ModuleType, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["replay", str(base_recording)]) == 0
    assert "REPRODUCED" in capsys.readouterr().out
    altered = _changed_input(mcap_edit, base_recording, tmp_path / "cli.mcap", 1)
    report_path = tmp_path / "report.json"
    assert main(["replay", str(altered), "--report", str(report_path)]) == 1
    out = capsys.readouterr().out
    assert "DIVERGED at step 1 " in out
    assert "last matching step: 0;" in out
    assert "joint2" in out
    data = json.loads(report_path.read_text())
    assert data["reproduced"] is False
    assert data["divergence"]["step"] == 1
    assert any(
        q["component"] == "ctrl" and q["name"] == "joint2" for q in data["divergence"]["quantities"]
    )


def test_state_every_compares_recorded_steps_only(helper: ModuleType, tmp_path: Path) -> None:
    # Replay continues between recorded states; a recording of every step stays the reference.
    path = helper.record(tmp_path / "every.mcap", {0: {"joint1": 0.2}, 33: {"joint1": 0.0}}, 64)
    report = verify(path)
    assert report.reproduced
    assert report.last_step == 64
    assert np.isfinite(report.wall_seconds)
