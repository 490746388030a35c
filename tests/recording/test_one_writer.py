"""One writer per recording path (issue 31, break 3): a second writer, in this process (another
session, another thread) or in another process, fails before touching a byte of the file,
with one line naming the path and the holder's pid; the first writer's file stays whole.

Before the fix the second writer opened the file ``O_TRUNC`` and both wrote into it: the file
kept a fraction of the run, with corrupt chunks."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from harness.recording import PhysicsState, Recorder, Recording
from harness.recording.errors import RecordingBusyError, RecordingWriteError
from harness.session import Session

ROOT = Path(__file__).resolve().parents[2]
METADATA = {
    "timestep": "0.002",
    "integrator": "IMPLICITFAST",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}


def _state(k: int) -> PhysicsState:
    q = np.full(3, float(k))
    return PhysicsState(step=k, sim_time_ns=k * 2_000_000, state_spec=1, state=q, qpos=q, qvel=q)


def _record(rec: Recorder, steps: range) -> None:
    for k in steps:
        rec.write_physics_state(_state(k))
    rec.flush()


def _steps(path: Path) -> list[int]:
    with Recording(path, strict=True) as rec:
        assert rec.complete
        return [s.step for s in rec.physics_states()]


def _refused(path: Path, pid: int, *, here: bool) -> RecordingBusyError:
    with pytest.raises(RecordingBusyError) as refused:
        Recorder(path, metadata=METADATA)
    exc = refused.value
    line = str(exc)
    assert "\n" not in line
    assert line.startswith(f"{path}: another session is recording to this file (pid {pid}")
    assert line.endswith("record to another path")
    assert ("this process" in line) == here
    assert (exc.path, exc.pid) == (str(path), pid)
    assert isinstance(exc, RecordingWriteError)  # the CLI's one-line error path
    return exc


def test_a_second_writer_in_the_same_process_fails_before_touching_a_byte(tmp_path):
    path = tmp_path / "same.mcap"
    with Recorder(path, metadata=METADATA, flush_interval_s=3600) as first:
        _record(first, range(0, 500))
        before = path.read_bytes()
        _refused(path, os.getpid(), here=True)
        # ... from another thread too (classic POSIX locks would not conflict at all here)
        errors: list[BaseException] = []

        def second() -> None:
            try:
                Recorder(path, metadata=METADATA)
            except BaseException as exc:
                errors.append(exc)

        thread = threading.Thread(target=second)
        thread.start()
        thread.join(30)
        assert [type(e) for e in errors] == [RecordingBusyError]
        assert path.read_bytes() == before  # not truncated, not written
        _record(first, range(500, 1000))
    assert _steps(path) == list(range(1000))
    # The lock went with the first writer: the path can be recorded to again.
    with Recorder(path, metadata=METADATA) as third:
        _record(third, range(0, 10))
    assert _steps(path) == list(range(10))


HOLDER = """
import sys
import numpy as np
from harness.recording import PhysicsState, Recorder

def state(k):
    q = np.full(3, float(k))
    return PhysicsState(step=k, sim_time_ns=k * 2_000_000, state_spec=1, state=q, qpos=q, qvel=q)

metadata = {"timestep": "0.002", "integrator": "IMPLICITFAST", "seed": "0",
            "model_sha256": "0" * 64, "control_modes": "{}"}
with Recorder(sys.argv[1], metadata=metadata, flush_interval_s=3600) as rec:
    for k in range(500):
        rec.write_physics_state(state(k))
    rec.flush()
    print("holding", flush=True)
    sys.stdin.readline()  # until the test has tried its second writer
    for k in range(500, 1000):
        rec.write_physics_state(state(k))
print("closed", flush=True)
"""


@pytest.mark.timeout(120)
def test_a_second_writer_in_another_process_fails_naming_the_holders_pid(tmp_path):
    path = tmp_path / "same.mcap"
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(path)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert holder.stdin is not None
    assert holder.stdout is not None
    try:
        assert holder.stdout.readline() == "holding\n"
        before = path.read_bytes()
        _refused(path, holder.pid, here=False)
        assert path.read_bytes() == before
        holder.stdin.write("go\n")
        holder.stdin.flush()
        assert holder.stdout.readline() == "closed\n"
    finally:
        holder.stdin.close()
        assert holder.wait(60) == 0
    assert _steps(path) == list(range(1000))


def test_a_second_session_recording_to_the_same_path_is_refused(tmp_path):
    path = tmp_path / "same.mcap"
    with Session("demo", clock="lockstep", record_to=path) as first:
        first.step(100)
        with pytest.raises(RecordingBusyError, match=rf"^{path}: another session .*this process"):
            Session("demo", clock="lockstep", record_to=path)
        first.step(100)
    with Recording(path, strict=True) as rec:
        assert rec.complete
        steps = [s.step for s in rec.physics_states()]
    assert steps == list(range(201))  # step 0 and every step of the first session


def test_finishing_a_file_after_a_failed_write_refuses_a_path_another_writer_took(tmp_path):
    # After a full disk the recorder closes its descriptor, then finishes the file at its last
    # complete write; a writer that took the path in between must not be cut.
    from harness.recording.salvage import close_prefix

    path = tmp_path / "same.mcap"
    with Recorder(path, metadata=METADATA, flush_interval_s=3600) as other:
        _record(other, range(0, 100))
        before = path.read_bytes()
        with pytest.raises(RecordingBusyError, match=r"this process"):
            close_prefix(path, 8)
        assert path.read_bytes() == before
    assert _steps(path) == list(range(100))
