"""``scenarios/mobile.yaml`` end to end, as a user runs it: the roslibpy client drives the
bundled robot around a square in its SDF room and back; the verdicts (client, no collision
with the walls, back within 0.15 m of the start) pass; the recording, floating base included,
replays bit for bit."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_mobile_scenario_drives_a_square_back_to_its_start(tmp_path: Path) -> None:
    out = tmp_path / "results"
    run = subprocess.run(
        [sys.executable, "-m", "harness", "run", str(ROOT / "scenarios" / "mobile.yaml"),
         "--out", str(out), "--workers", "1"],
        capture_output=True, text=True, timeout=300, check=False, cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    results = json.loads((out / "results.json").read_text())
    text = json.dumps(results)
    assert '"returns_to_start"' in text
    recordings = sorted(out.rglob("*.mcap"))
    assert recordings, sorted(p.name for p in out.rglob("*"))
    replay = subprocess.run(
        [sys.executable, "-m", "harness", "replay", str(recordings[0])],
        capture_output=True, text=True, timeout=300, check=False, cwd=tmp_path,
    )  # fmt: skip
    assert replay.returncode == 0, replay.stdout[-3000:] + replay.stderr[-3000:]
    assert "REPRODUCED" in replay.stdout
