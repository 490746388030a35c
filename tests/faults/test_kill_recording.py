"""kill -9 during a Session recording: the file still opens (everything up to the last
flushed chunk reads back) and ``harness inspect`` reports the truncation (exit status 1)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from harness.recording import Recording, RecordingDamagedWarning

CHILD = r"""
import sys
from pathlib import Path
from harness.session import Session

path = Path(sys.argv[1])
with Session("demo", clock="fast", record_to=path) as session:
    # run until the recorder has flushed chunks of messages (beyond the attachments written
    # at the start), then say so and keep going
    start = path.stat().st_size
    session.run_until(lambda: path.stat().st_size > start + 200_000, sim_timeout=600)
    print("recording", session.step_index, flush=True)
    session.run_until(lambda: False, sim_timeout=1e6)
"""


@pytest.mark.timeout(120)
@pytest.mark.slow
def test_kill_9_mid_recording(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(path)], stdout=subprocess.PIPE, text=True
    )
    assert child.stdout is not None
    line = child.stdout.readline()
    assert line.startswith("recording"), line
    child.send_signal(signal.SIGKILL)
    child.wait(30)
    assert child.returncode == -signal.SIGKILL

    with pytest.warns(RecordingDamagedWarning):
        rec = Recording(path)
    with rec:
        assert not rec.complete
        assert rec.metadata["model_sha256"]
        states = list(rec.physics_states())
        assert len(states) > 100
        steps = [s.step for s in states]
        assert steps == list(range(steps[0], steps[0] + len(steps)))  # no holes before the cut

    proc = subprocess.run(
        [sys.executable, "-m", "harness", "inspect", str(path), "--json"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 1, proc.stderr
    report = json.loads(proc.stdout)
    text = json.dumps(report).lower()
    assert "truncat" in text
