"""The scenario key ``resume``: an iteration continues a scenario's recording from a step
(its world and options the recording's), runs to the end of ``duration`` and records a child;
with no client and the same inputs it is the parent's run from the step, bit for bit."""

from __future__ import annotations

from pathlib import Path

from harness.recording import Recording
from harness.resume import META_STEP
from harness.scenario import IterationSpec, Scenario
from harness.scenario.session_runner import SessionIterationRunner

from .conftest import states

SCENARIO = """
name: cell
environment: {map: empty}
duration: 0.5
clock: {mode: lockstep}
robots:
  - robot: demo
"""


def _iterate(file: Path, out: Path) -> tuple[Path, int]:
    scenario = Scenario.load(file)
    spec = IterationSpec(
        simulation=scenario.name, iteration=0, scenario=scenario, client=None,
        sim_time_limit=scenario.duration, seed=scenario.seed, host="127.0.0.1", port=0,
        out_dir=out, recording_path=out / "run.mcap",
    )  # fmt: skip
    result = SessionIterationRunner()(spec)
    assert all(v.passed for v in result.verdicts), result.verdicts
    return out / "run.mcap", result.steps


def test_a_scenario_resumes_its_recording(tmp_path: Path) -> None:
    first = tmp_path / "cell.yaml"
    first.write_text(SCENARIO)
    parent, steps = _iterate(first, tmp_path / "parent")
    assert steps == 250
    resumed = tmp_path / "resumed.yaml"
    resumed.write_text(SCENARIO + "resume: {from: parent/run.mcap, at: 100}\n")
    child, steps = _iterate(resumed, tmp_path / "child")
    assert steps == 250  # duration counts from step 0: the rest of the run
    with Recording(child) as rec:
        assert rec.metadata[META_STEP] == "100"
    assert states(child, 100) == states(parent, 100)
