"""A disk filling up mid-run: the recorder closes a valid file at its last complete flush
(a summary over what is written, no ``--allow-damaged`` needed) and says what was lost.

Two ways to run out of room, each in a child process so nothing else is limited: a file size
limit (RLIMIT_FSIZE, EFBIG, works for any user) and, as root, a real 1 MiB tmpfs (ENOSPC)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from harness.recording import Recording

ROOT = Path(__file__).resolve().parents[2]

CHILD = """
import resource, signal, sys
import numpy as np
from harness.recording import PhysicsState, Recorder
from harness.recording.errors import RecordingWriteError

path, limit = sys.argv[1], int(sys.argv[2])
if limit:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # EFBIG instead of being killed
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
metadata = {"timestep": "0.002", "integrator": "IMPLICITFAST", "seed": "0",
            "model_sha256": "0" * 64, "control_modes": "{}"}
rec = Recorder(path, metadata=metadata, chunk_size=32 * 1024, flush_interval_s=3600)
state = np.random.default_rng(0).random(2000)  # incompressible: 16 kB a message
written = 0
try:
    for k in range(100_000):
        rec.write_physics_state(PhysicsState(step=k, sim_time_ns=k * 2_000_000, state_spec=1,
                                             state=state, qpos=state[:3], qvel=state[:3]))
        written += 1
        if k % 4 == 3:
            rec.flush()
except RecordingWriteError as exc:
    print("write failed:", exc, file=sys.stderr)
try:
    rec.close()
except RecordingWriteError as exc:
    print("CLOSE:", exc)
print("WRITTEN:", written)
"""


def _record_until_full(path: Path, limit: int = 0) -> tuple[str, int]:
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(path), str(limit)],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    close = next(line for line in done.stdout.splitlines() if line.startswith("CLOSE:"))
    written = int(done.stdout.split("WRITTEN:")[1])
    return close, written


def _check_valid(path: Path, close: str, written: int) -> None:
    assert "closed as a valid file at its last complete flush" in close, close
    match = re.search(r"\((\d+) messages up to sim time [\d.e+-]+ s\); (\d+) later", close)
    assert match is not None, close
    kept, lost = int(match.group(1)), int(match.group(2))
    assert kept > 0
    assert kept + lost >= written  # every accepted message is either kept or counted lost
    with Recording(path, strict=True) as rec:  # strict: any damage would raise
        assert rec.complete
        steps = [s.step for s in rec.physics_states()]
    assert len(steps) == kept
    assert steps == list(range(kept))


def test_file_size_limit_mid_run_leaves_a_valid_file(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    close, written = _record_until_full(path, limit=600_000)
    _check_valid(path, close, written)
    assert path.stat().st_size <= 600_000


@pytest.mark.skipif(os.geteuid() != 0, reason="mounting a small tmpfs needs root")
def test_disk_full_mid_run_leaves_a_valid_file(tmp_path: Path) -> None:
    mount = tmp_path / "small"
    mount.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mount)],
        capture_output=True,
        check=False,
    )
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {mounted.stderr.decode().strip()}")
    try:
        path = mount / "run.mcap"
        close, written = _record_until_full(path)
        assert "No space left on device" in close
        _check_valid(path, close, written)
    finally:
        subprocess.run(["umount", str(mount)], check=True)
