"""What ``harness explore`` hands back in ``--out``.

- ``minimal.yaml``: the scenario with the minimal failure's concrete values and no ``explore``
  section (runnable by ``harness run`` from any folder);
- ``minimal.mcap``: its recording, from a cold run of ``minimal.yaml`` exactly as ``harness
  run`` runs it, run twice (the two recordings must be byte-identical) and replay-verified;
- ``test_minimal.py``: a pytest regression that runs ``minimal.yaml`` through the plugin's
  marker (``@pytest.mark.harness(scenario="minimal.yaml")`` and the ``harness_scenario``
  fixture) and fails while the bug is there;
- ``summary.json``: examples run, failures found, distinct signatures, the minimal
  parameters and the shrink path; ``report.html`` (:mod:`harness.explore.report`).
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from harness.explore.engine import FailureTrack
from harness.explore.episode import EpisodeRunner, Example
from harness.explore.search import SearchResult

__all__ = ["MinimalCase", "regression_test", "run_scenario", "write_minimal", "write_summary"]


@dataclass(frozen=True)
class MinimalCase:
    """The minimal failure written out: its files, whether the two cold runs gave identical
    recordings, whether the replay reproduced, and the cold run's verdict."""

    scenario: Path
    recording: Path | None
    test: Path
    identical: bool
    reproduced: bool
    fails: bool
    reason: str
    replay_detail: str


def run_scenario(path: str | Path, out: Path) -> Any:
    """Run a scenario file once as ``harness run`` does (its first iteration) with the
    recording in ``out``; returns the :class:`harness.scenario.IterationResult`."""
    from harness.scenario import (
        iteration_specs,
        load_run_file,
        session_iteration_runner,
    )

    config = load_run_file(path)
    spec = iteration_specs(config, out)[0]
    return session_iteration_runner()(spec)


_TEST = '''"""Regression test written by `harness explore` from {source}.

The scenario minimal.yaml beside this file is the smallest failing case the search found:
{signature}
The harness pytest plugin runs it as `harness run` does (the `harness_scenario` fixture); the
test fails while the bug is there, its recording kept (`--harness-keep-recordings`, default:
failed tests) and replayable with `harness replay`.
"""

import pytest


@pytest.mark.harness(scenario="minimal.yaml")
def test_minimal_case(harness_scenario):
    assert harness_scenario.passed, harness_scenario.reason
'''


def regression_test(source: str | Path, signature: str) -> str:
    """The text of ``test_minimal.py``: the marker's ``scenario="minimal.yaml"`` (the file
    beside it) run by the ``harness_scenario`` fixture, failing while its verdicts fail."""
    return _TEST.format(source=source, signature=signature)


def write_minimal(result: SearchResult, track: FailureTrack, out: Path) -> MinimalCase:
    """Write ``minimal.yaml``, ``minimal.mcap`` (cold run, twice, replay-verified) and
    ``test_minimal.py`` for ``track``'s minimal example."""
    from harness.replay import verify

    minimal = track.minimal or (track.path[-1] if track.path else track.first)
    scenario = out / "minimal.yaml"
    scenario.write_text(result.plan.text(minimal.values), encoding="utf-8")
    cold = EpisodeRunner(result.plan, out / ".work" / "cold")
    runs: list[Example] = []
    recordings: list[bytes] = []
    for i in range(2):
        example = cold.run(minimal.values, keep=out / ".work" / f"cold-{i}")
        runs.append(example)
        kept = Path(example.kept or "") / "recording.mcap"
        recordings.append(kept.read_bytes() if kept.is_file() else b"")
    identical = bool(recordings[0]) and recordings[0] == recordings[1]
    recording: Path | None = None
    reproduced = False
    detail = "no recording (recording.enabled is false)"
    if recordings[0]:
        recording = out / "minimal.mcap"
        shutil.copyfile(Path(runs[0].kept or "") / "recording.mcap", recording)
        report = verify(recording)
        reproduced = bool(report.reproduced)
        detail = "REPRODUCED" if reproduced else f"DIVERGED: {report}"
    test = out / "test_minimal.py"
    test.write_text(regression_test(result.plan.source, track.signature), encoding="utf-8")
    return MinimalCase(
        scenario,
        recording,
        test,
        identical,
        reproduced,
        not runs[0].passed,
        runs[0].reason,
        detail,
    )


def _example(e: Example) -> dict[str, Any]:
    out = asdict(e)
    out["values"] = dict(e.values)
    out["margins"] = dict(e.margins)
    return out


def write_summary(
    result: SearchResult, minimal: MinimalCase | None, out: Path, extra: Mapping[str, Any]
) -> Path:
    """``summary.json``: the search in numbers and the minimal case (see the module docstring)."""
    examples = result.examples
    primary = result.primary()
    doc: dict[str, Any] = {
        "scenario": str(result.plan.source),
        "parameters": {
            p.path: {"kind": p.kind, "nominal": p.nominal, "low": p.low, "high": p.high}
            | ({"choices": list(p.choices)} if p.choices else {})
            for p in result.plan.parameters
        },
        "target": result.plan.target,
        "examples_run": len(examples),
        "examples_generated": result.generated,
        "examples_failed": sum(1 for e in examples if not e.passed),
        "failures_found": len(result.failures),
        "signatures": {
            sig: {
                "first": dict(t.first.values),
                "minimal": dict(t.minimal.values) if t.minimal else None,
                "shrink_steps": len(t.path),
                "deterministic": t.deterministic,
                "note": t.note,
            }
            for sig, t in result.failures.items()
        },
        "minimal": None
        if primary is None
        else {
            "signature": primary.signature,
            "parameters": dict((primary.minimal or primary.first).values),
            "nominal": result.plan.nominal(),
            "shrink_path": [dict(e.values) for e in primary.path],
            "scenario": str(minimal.scenario) if minimal else None,
            "recording": str(minimal.recording) if minimal and minimal.recording else None,
            "recordings_identical": minimal.identical if minimal else None,
            "replay": minimal.replay_detail if minimal else None,
            "fails_under_harness_run": minimal.fails if minimal else None,
        },
        "engines": [
            {
                "worker": o.worker,
                "seed": o.seed,
                "examples": len(o.examples),
                "stopped": o.stopped,
                "wall_seconds": round(o.wall_seconds, 3),
            }
            for o in result.outcomes
        ],
        "wall_seconds": round(result.wall_seconds, 3),
        **extra,
    }
    path = out / "summary.json"
    path.write_text(json.dumps(doc, indent=2, default=str) + "\n", encoding="utf-8")
    (out / "examples.jsonl").write_text(
        "".join(json.dumps(_example(e), default=str) + "\n" for e in examples), encoding="utf-8"
    )
    return path
