"""Two ``harness serve --record same.mcap`` (issue 31, break 3): the second exits non-zero
with one line naming the path and the first's pid, before touching the file; the first
records on and leaves a complete file holding every step it ran.

Before the fix both exited 0 and printed "recording same.mcap closed"; the file kept the
second's 1.6 s of the first's 5.7 s, and replay refused it as damaged."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from harness.recording import Recording


def _serve(path: Path) -> list[str]:
    return [sys.executable, "-m", "harness", "serve", "--port", "0", "--record", str(path)]


@pytest.mark.timeout(180)
def test_a_second_serve_recording_to_the_same_path_exits_with_one_line(tmp_path: Path) -> None:
    path = tmp_path / "same.mcap"
    first = subprocess.Popen(_serve(path), stdout=subprocess.PIPE, text=True, cwd=tmp_path)
    assert first.stdout is not None
    try:
        banner = first.stdout.readline()
        assert banner.startswith("harness serve: ws://127.0.0.1:"), banner  # recording open

        second = subprocess.run(
            _serve(path), capture_output=True, text=True, timeout=60, cwd=tmp_path
        )

        assert second.returncode == 2
        assert second.stdout == ""  # it never served
        assert second.stderr.splitlines() == [
            f"harness serve: error: {path}: another session is recording to this file "
            f"(pid {first.pid}): refused before writing to it; record to another path"
        ]
    finally:
        first.send_signal(signal.SIGINT)
        out, _ = first.communicate(timeout=60)
    assert first.returncode == 0
    match = re.search(r"stopped at step (\d+), recording .* closed", out)
    assert match is not None, out
    last = int(match.group(1))
    with Recording(path, strict=True) as rec:  # strict: any damage raises
        assert rec.complete
        steps = [s.step for s in rec.physics_states()]
    # Every step the first serve ran (it may take one more after printing its step), no hole.
    assert steps == list(range(len(steps)))
    assert len(steps) >= last + 1
