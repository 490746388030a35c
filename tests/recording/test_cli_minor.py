"""The small things the attack review found around the commands that read recordings: output
into a closed pipe, and the advice a damaged recording's refusal gives."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

HARNESS = [sys.executable, "-m", "harness.cli"]
# Run from elsewhere: the harness imported is the installed one (or $PYTHONPATH's).
ELSEWHERE = {"cwd": "/"}


def test_output_into_a_closed_pipe_ends_quietly(run_recording: Path) -> None:
    # The reader is gone before the command writes a byte (it takes a while to start).
    child = subprocess.Popen(
        [*HARNESS, "inspect", str(run_recording), "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **ELSEWHERE,
    )
    assert child.stdout is not None
    child.stdout.close()
    _, err = child.communicate(timeout=120)
    assert "Traceback" not in err
    assert "BrokenPipeError" not in err
    assert child.returncode == 141  # 128 + SIGPIPE, what a shell reports


def test_a_damaged_recording_refused_by_diff_names_commands_that_take_it(
    run_recording: Path, tmp_path: Path
) -> None:
    from harness.recording import Recording

    with Recording(run_recording) as rec:
        chunk = rec.scan.chunks[len(rec.scan.chunks) // 2]
    raw = bytearray(run_recording.read_bytes())
    raw[chunk.offset + chunk.length // 2] ^= 0x10
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(raw))
    for command in (["diff", str(bad), str(run_recording)], ["play", str(bad)]):
        result = subprocess.run(
            [*HARNESS, *command], capture_output=True, text=True, **ELSEWHERE, timeout=120
        )
        assert result.returncode == 2
        assert result.stderr.count("\n") == 1
        # diff and play have no --allow-damaged: the advice names the commands that help.
        assert "pass --allow-damaged" not in result.stderr
        assert "harness replay --allow-damaged" in result.stderr
        assert "harness repair IN OUT" in result.stderr
        flagged = subprocess.run(
            [*HARNESS, *command, "--allow-damaged"],
            capture_output=True,
            text=True,
            **ELSEWHERE,
            timeout=120,
        )
        assert "unrecognized arguments: --allow-damaged" in flagged.stderr
