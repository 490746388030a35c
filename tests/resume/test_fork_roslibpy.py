"""A resumed session driven by a real roslibpy client (in a process of its own): it finds the
run at the fork, the recorded client's goal in flight finishes as it steps, and its own goal
is served by the controller the resumed core carried over."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from harness import Session
from harness.cli import main
from harness.recording import Recording

from .conftest import ARM_FORK, JOINTS, TARGET

HERE = Path(__file__).resolve().parent
HOME = [0.0, 0.0, 0.0, -1.57079, 0.0, 1.57079, -0.7853]


@pytest.mark.slow
def test_roslibpy_drives_a_resumed_session(arm_parent: Path, tmp_path: Path) -> None:
    child = tmp_path / "roslibpy.mcap"
    with Session.resume(arm_parent, step=ARM_FORK, record_to=child) as session:
        port = session.url.rsplit(":", 1)[1].split("/")[0]
        done = subprocess.run(
            [sys.executable, str(HERE / "roslibpy_resumed.py"), port],
            capture_output=True, text=True, timeout=120,
        )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.splitlines()
    assert lines[-1] == "OK", done.stdout[-2000:]
    run = json.loads(lines[-2])
    assert run["start"] == ARM_FORK
    for joint, target in zip(JOINTS, TARGET, strict=True):
        assert run["reached"][joint] == pytest.approx(target, abs=0.01)  # the ghost's goal
    assert run["result"]["status"] == 4, run["result"]  # SUCCEEDED
    for joint, home in zip(JOINTS, HOME, strict=True):
        assert run["home"][joint] == pytest.approx(home, abs=0.02)
    with Recording(child) as rec:
        results = [
            (f.connection, json.loads(f.text)["status"])
            for f in rec.bridge_frames(ARM_FORK)
            if f.direction == 1 and f.op == "action_result"
        ]
    assert results == [(1, 4), (2, 4)]  # the ghost's (recorded, not sent), then roslibpy's
    assert main(["replay", str(child), "--level", "full"]) == 0
