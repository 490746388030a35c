"""Examples that run the scenario's client program start it warm (a forked, pre-imported
interpreter per worker: harness.scenario.client_warm), and that is no shortcut: each kept
example's recording is byte-identical to a cold ``harness run`` of its concrete scenario
(``harness.explore.run_scenario``), the planted failure among them."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.explore import EpisodeRunner, SearchOptions, load_plan, run_scenario, search
from harness.explore.fast import FastRunner
from harness.scenario import warm_clients
from tests.explore.conftest import DATA

PAIRS = [("0.1", "slow"), ("0.3", "fast"), ("0.2", "fast"), ("0.3", "slow")]


def _cold(scenario: Path, out: Path) -> bytes:
    result = run_scenario(scenario, out)
    assert result.recording is not None
    return Path(result.recording).read_bytes()


def test_client_examples_start_warm_and_record_as_harness_run(tmp_path: Path) -> None:
    plan = load_plan(DATA / "reach.yaml")
    runner = EpisodeRunner(plan, tmp_path / "scratch", runner=FastRunner())
    with warm_clients() as pool:
        examples = [
            runner.run({"client.env.TARGET_X": x, "client.env.MODE": mode}, keep=tmp_path / f"k{i}")
            for i, (x, mode) in enumerate(PAIRS)
        ]
    assert pool.forked == len(PAIRS), pool.refusals
    assert [e.passed for e in examples] == [True, False, True, True]
    for i, example in enumerate(examples):
        kept = Path(example.kept or "")
        cold = _cold(kept / "scenario.yaml", tmp_path / f"cold{i}")
        assert (kept / "recording.mcap").read_bytes() == cold, f"example {i} differs"


@pytest.mark.slow
def test_explore_with_a_client_records_as_harness_run(tmp_path: Path) -> None:
    """Through ``search`` (the ``harness explore`` path): passing examples and the failure."""
    result = search(
        load_plan(DATA / "reach.yaml"),
        SearchOptions(work=tmp_path / "work", examples=12, keep_passing=4, seed=2),
    )
    assert result.failures, "the planted pair was not hit in 12 examples"
    kept = [Path(e.kept) for e in result.examples if e.kept and e.passed]
    kept += [Path(t.first.kept) for t in result.failures.values() if t.first.kept]
    assert len(kept) >= 2
    for i, folder in enumerate(kept):
        cold = _cold(folder / "scenario.yaml", tmp_path / f"cold-{i}")
        assert (folder / "recording.mcap").read_bytes() == cold, f"{folder} differs"
