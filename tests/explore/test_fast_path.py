"""No shortcut in the fast path: for every failure found and 20 random passing examples, the
recording an explore example made is byte-identical to a cold ``harness run`` of its concrete
scenario (``harness.explore.run_scenario``: the loader, specs and runner ``harness run`` uses,
stepping 10 steps per request as ``harness run`` does)."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.explore import SearchOptions, load_plan, run_scenario, search
from tests.explore.conftest import DATA


def _cold_bytes(scenario: Path, out: Path) -> bytes:
    result = run_scenario(scenario, out)
    assert result.recording is not None
    return Path(result.recording).read_bytes()


@pytest.mark.slow
def test_explore_recordings_equal_cold_harness_run(tmp_path: Path) -> None:
    passing = search(
        load_plan(DATA / "clear.yaml"),
        SearchOptions(work=tmp_path / "clear", examples=40, keep_passing=20, seed=3),
    )
    kept = [Path(e.kept) for e in passing.examples if e.kept and e.passed]
    assert len(kept) == 20
    assert len({(k / "scenario.yaml").read_text() for k in kept}) == 20  # 20 distinct examples
    failing = search(
        load_plan(DATA / "sweep.yaml"),
        SearchOptions(work=tmp_path / "sweep", examples=40, seed=1),
    )
    assert failing.failures, "the planted obstacle region was not hit in 40 examples"
    kept += [Path(t.first.kept) for t in failing.failures.values() if t.first.kept]
    assert len(kept) == 20 + len(failing.failures)
    for i, folder in enumerate(kept):
        explored = (folder / "recording.mcap").read_bytes()
        cold = _cold_bytes(folder / "scenario.yaml", tmp_path / f"cold-{i}")
        assert explored == cold, f"{folder}: the explore recording differs from harness run's"
