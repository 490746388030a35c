"""The ``script:`` scenario key: in-process commands on a sim-time timeline, run by the
product's iteration runner (real Session, real recording), replayed bit for bit."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.replay import verify
from harness.scenario import IterationSpec, Scenario, ScenarioError, session_iteration_runner
from harness.scenario.script import ScriptCommand, run_script, script_steps
from tests.explore.conftest import DATA, write_variant


def _run(scenario: Scenario, out: Path):
    spec = IterationSpec(
        "s",
        1,
        scenario,
        None,
        scenario.duration,
        scenario.seed,
        "127.0.0.1",
        0,
        out,
        out / "recording.mcap",
    )
    return session_iteration_runner()(spec)


def test_script_loads_in_file_order() -> None:
    scenario = Scenario.load(DATA / "sweep.yaml")
    assert [c.at for c in scenario.script] == [0.0, 0.5, 1.0]
    assert scenario.script[0].positions == {"joint1": -1.2, "joint2": 0.2, "joint4": -1.6}
    assert scenario.explore is not None
    assert "parameters" in scenario.explore


def test_script_moves_the_arm_and_replays(tmp_path: Path) -> None:
    scenario = Scenario.load(DATA / "sweep.yaml")
    result = _run(scenario, tmp_path)
    assert result.passed, result.reason
    trace = {j.joint: j for j in result.traces.joints}["joint1"]
    # held at 0 before the first command; swept to +1.2 by the end (position control)
    assert trace.position[0] == 0.0
    assert min(trace.position) < -1.0
    assert trace.position[-1] > 0.9
    report = verify(result.recording)
    assert report.reproduced, report


def test_script_with_a_client_is_refused(tmp_path: Path) -> None:
    path = write_variant(tmp_path, "both.yaml", "sweep.yaml", {"client": {"command": "true"}})
    with pytest.raises(ScenarioError, match=r"both\.yaml: script: .*cannot be given with a client"):
        Scenario.load(path)


def test_script_unknown_joint_is_one_line(tmp_path: Path) -> None:
    path = write_variant(
        tmp_path, "bad.yaml", "sweep.yaml", {"script": [{"at": 0.1, "positions": {"joint9": 1}}]}
    )
    with pytest.raises(
        ScenarioError, match=r"bad\.yaml: script\[0\]: joint 'joint9' is not a joint"
    ):
        _run(Scenario.load(path), tmp_path / "out")


def test_script_bad_at_is_refused(tmp_path: Path) -> None:
    path = write_variant(tmp_path, "neg.yaml", "sweep.yaml", {"script": [{"at": -1}]})
    with pytest.raises(ScenarioError, match=r"neg\.yaml: script\[0\]\.at"):
        Scenario.load(path)


class _Stepper:
    """Records what a script does to its target (no simulation needed for the timeline)."""

    def __init__(self) -> None:
        self.step_index = 0
        self.log: list[tuple[int, str, object]] = []

    def step(self, n: int = 1) -> int:
        self.step_index += n
        return self.step_index

    def set_positions(self, positions):
        self.log.append((self.step_index, "positions", dict(positions)))

    def command(self, joint, *, position=None, velocity=None, effort=None):
        self.log.append((self.step_index, joint, velocity if effort is None else effort))


def test_script_timeline_applies_at_step_boundaries() -> None:
    dt_ns = 2_000_000
    script = (
        ScriptCommand(at=0.011, velocities={"w": 1.0}),
        ScriptCommand(at=0.0, positions={"a": 1.0}),
        ScriptCommand(at=0.010, efforts={"e": 2.0}),
    )
    assert script_steps(script, dt_ns) == [6, 0, 5]
    target = _Stepper()
    run_script(target, script, dt_ns, limit=40, chunk=7)
    assert target.log == [(0, "positions", {"a": 1.0}), (5, "e", 2.0), (6, "w", 1.0)]
    assert target.step_index == 40
