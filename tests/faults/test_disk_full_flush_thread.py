"""The disk fills up during the recorder's background flush (the provisional tail written every
``flush_interval_s``), not during a committed write: the recording must still close as a valid
file at its last complete flush and say what was lost (issue 31, minor; seen as a damaged
file from ``harness serve`` on a loaded machine).

Deterministic: the child commits one batch, then records more than the file size limit allows
without committing; the flush thread's tail write fails (EFBIG) and the thread ends, which
the child waits for (a join, no sleep); then it closes the recorder."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from harness.recording import Recording

ROOT = Path(__file__).resolve().parents[2]

CHILD = """
import resource, sys
import numpy as np
from harness.recording import PhysicsState, Recorder
from harness.recording.errors import RecordingWriteError

path = sys.argv[1]
metadata = {"timestep": "0.002", "integrator": "IMPLICITFAST", "seed": "0",
            "model_sha256": "0" * 64, "control_modes": "{}"}
rec = Recorder(path, metadata=metadata, chunk_size=64 * 1024 * 1024, flush_interval_s=0.01)
rng = np.random.default_rng(0)

def write(k):
    state = rng.random(2000)  # incompressible: 16 kB a message
    rec.write_physics_state(PhysicsState(step=k, sim_time_ns=k * 2_000_000, state_spec=1,
                                         state=state, qpos=state[:3], qvel=state[:3]))

for k in range(10):
    write(k)
rec.flush()  # committed: 10 messages
limit = rec.stats.file_bytes + 100_000
resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))  # Python ignores SIGXFSZ: EFBIG
for k in range(10, 30):  # 320 kB more, never committed by this thread
    write(k)
rec._thread.join(60)  # the flush thread ends when its tail write fails
print("THREAD:", "ended" if not rec._thread.is_alive() else "alive")
try:
    write(30)
except RecordingWriteError as exc:
    print("WRITE:", exc)
try:
    rec.close()
except RecordingWriteError as exc:
    print("CLOSE:", exc)
"""


def test_a_full_disk_during_the_background_flush_leaves_a_valid_file(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(path)],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "THREAD: ended" in done.stdout, done.stdout
    # one cause, said once (not "recording failed: <path>: recording failed: ...")
    assert f"WRITE: {path}: recording failed: [Errno 27] File too large\n" in done.stdout
    close = next(line for line in done.stdout.splitlines() if line.startswith("CLOSE:"))
    assert "File too large" in close, close
    assert "closed as a valid file at its last complete flush" in close, close
    match = re.search(r"\((\d+) messages up to sim time [\d.e+-]+ s\); (\d+) later", close)
    assert match is not None, close
    assert (int(match.group(1)), int(match.group(2))) == (10, 20)
    with Recording(path, strict=True) as rec:  # strict: any damage raises
        assert rec.complete
        assert [s.step for s in rec.physics_states()] == list(range(10))


PARTIAL = """
import resource, sys
from harness.recording.tail import TailFile

tail = TailFile(sys.argv[1])
tail.write(b"a" * 1000)
resource.setrlimit(resource.RLIMIT_FSIZE, (1500, 1500))  # Python ignores SIGXFSZ: EFBIG
try:
    tail.write_tail(b"b" * 2000)  # 500 bytes reach the file, then EFBIG
except OSError as exc:
    print("TAIL:", exc.strerror)
tail.write(b"c" * 100)  # a smaller committed write that fits
tail.close()
"""


def test_a_tail_write_cut_short_by_a_full_disk_leaves_no_bytes_behind(tmp_path: Path) -> None:
    path = tmp_path / "tail.bin"
    done = subprocess.run(
        [sys.executable, "-c", PARTIAL, str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout == "TAIL: File too large\n"
    assert path.read_bytes() == b"a" * 1000 + b"c" * 100  # not the tail's 400 bytes after it
