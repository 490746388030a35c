"""``harness serve --from RUN.mcap --at STEP`` end to end: the command prints the URL on its
first line, a client steps the resumed run, SIGINT stops it with the child recording complete
(naming its parent and the step) and the command saying how to diff it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

from harness.recording import Recording
from harness.resume import META_PARENT, META_STEP
from harness.testing import connect

from .conftest import ARM_FORK


def test_serve_from_a_recording(arm_parent: Path, tmp_path: Path) -> None:
    child = tmp_path / "child.mcap"
    command = [sys.executable, "-m", "harness", "serve", "--from", str(arm_parent), "--at",
               str(ARM_FORK), "--port", "0", "--record", str(child)]  # fmt: skip
    server = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert server.stdout is not None
        first = server.stdout.readline()
        assert first.startswith("harness serve: ws://127.0.0.1:"), first + server.stderr.read()
        assert f"resumed {arm_parent} at step {ARM_FORK} (0.6 s)" in first
        assert "clock lockstep, ghost peers: connection 1" in first
        url = first.split()[2]
        with connect(url) as client:
            assert client.step(0) == ARM_FORK * 2_000_000
            client.step(100)
        os.kill(server.pid, signal.SIGINT)
        out, err = server.communicate(timeout=60)
    finally:
        if server.poll() is None:
            server.kill()
            server.communicate()
    assert server.returncode == 0, err
    assert f"stopped at step {ARM_FORK + 100}, recording {child} closed" in out
    assert f"harness diff {arm_parent} {child}" in out
    with Recording(child) as rec:
        assert rec.complete
        assert rec.metadata[META_PARENT] == arm_parent.name
        assert rec.metadata[META_STEP] == str(ARM_FORK)
        assert rec.last_step == ARM_FORK + 100
