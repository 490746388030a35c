"""The recorder's physics state slot: states filled in place, moved into the chunk a ring at a
time, give the file ``write_physics_state`` gives; crash safety and errors unchanged."""

from __future__ import annotations

import re
import shutil
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from harness.recording import (
    PhysicsState,
    Recorder,
    Recording,
    RecordingDamagedWarning,
    RecordingWriteError,
    recorder,
)
from harness.recording.recorder import STATE_RING, FlushInfo
from harness.recording.stateslot import StateRecords, forwarding_slot
from harness.recording.tail import TailFile
from harness.recording.templates import clock_cdr
from harness.recording.writer import ChunkWriter

METADATA = {
    "timestep": "0.001",
    "integrator": "IMPLICITFAST",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}
SPEC = 8191
Run = tuple[int, slice, slice, list[str], int, int, int]


def _spans(draw: st.DrawFn, size: int) -> slice:
    start = draw(st.integers(0, size))
    return slice(start, draw(st.integers(start, size)))


@st.composite
def _runs(draw: st.DrawFn) -> Run:
    size = draw(st.integers(1, 40))
    events = draw(st.lists(st.sampled_from(["state", "clock", "checkpoint"]), max_size=120))
    return (
        size,
        _spans(draw, size),
        _spans(draw, size),
        events,
        draw(st.integers(200, 4000)),  # chunk size: boundaries fall inside rings
        draw(st.sampled_from([1, 3])),  # state_every
        draw(st.integers(0, 2**32)),
    )


def _record(path: Path, run: Run, slot: bool) -> bytes:
    size, qpos, qvel, events, chunk_size, every, seed = run
    rng = np.random.default_rng(seed)
    opts = {"metadata": METADATA, "library": "test", "chunk_size": chunk_size}
    with Recorder(path, state_every=every, **opts) as rec:
        writer = rec.physics_state_slot(SPEC, size, qpos, qvel) if slot else None
        step = 0
        for event in events:
            t = step * 1000
            if event == "state":
                step += 1
                t = step * 1000
                values = rng.standard_normal(size)
                if writer is not None:
                    writer.state[:] = values
                    writer.write(step, t)
                else:
                    rec.write_physics_state(
                        PhysicsState(step, t, SPEC, values, values[qpos], values[qvel])
                    )
            elif event == "clock":
                rec.write_message("/clock", "rosgraph_msgs/msg/Clock", clock_cdr(t), sim_time_ns=t)
            else:
                rec.checkpoint()
    return path.read_bytes()


@settings(max_examples=40, deadline=None)
@given(run=_runs())
def test_a_slot_writes_the_file_write_physics_state_writes(
    tmp_path_factory: pytest.TempPathFactory, run: Run
) -> None:
    folder = tmp_path_factory.mktemp("slot")
    assert _record(folder / "slot.mcap", run, True) == _record(folder / "records.mcap", run, False)


def test_the_states_read_back_with_their_qpos_and_qvel(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    with Recorder(path, metadata=METADATA, library="test", chunk_size=5000) as rec:
        slot = rec.physics_state_slot(SPEC, 9, slice(1, 4), slice(4, 6))
        for k in range(1, 3 * STATE_RING + 5):
            slot.state[:] = np.arange(9.0) + k
            slot.write(k, k * 1000)
    with Recording(path) as recording:
        states = list(recording.physics_states())
    assert [s.step for s in states] == list(range(1, 3 * STATE_RING + 5))
    last = states[-1]
    np.testing.assert_array_equal(last.state, np.arange(9.0) + last.step)
    np.testing.assert_array_equal(last.qpos, last.state[1:4])
    np.testing.assert_array_equal(last.qvel, last.state[4:6])


def test_a_checkpoint_puts_the_states_of_an_unfinished_ring_on_disk(tmp_path: Path) -> None:
    """Crash safety: what the flush thread writes includes states the ring has not moved yet
    (a copy of the file taken then is what a killed process leaves)."""
    path = tmp_path / "run.mcap"
    with Recorder(path, metadata=METADATA, library="test") as rec:
        slot = rec.physics_state_slot(SPEC, 5, slice(1, 3), slice(3, 5))
        for k in range(1, STATE_RING // 2):
            slot.state[:] = k
            slot.write(k, k * 1000)
        rec.checkpoint()
        shutil.copy(path, tmp_path / "killed.mcap")
    with Recording(tmp_path / "killed.mcap") as recording:
        assert [s.step for s in recording.physics_states()] == list(range(1, STATE_RING // 2))


class _HeldChunks(TailFile):
    """A recording file whose chunk writes (the writer's chunk thread) wait until the writer
    waits for them (:meth:`ChunkWriter.drain`) or a tail has been written since they began:
    the order a busy machine may give, every time."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self.owner = threading.current_thread()
        self.changed = threading.Condition()
        self.tails = 0
        self.draining = False

    def write(self, data: bytes | bytearray | memoryview) -> int:
        if threading.current_thread() is not self.owner:
            with self.changed:
                tails = self.tails
                if not self.changed.wait_for(lambda: self.draining or self.tails > tails, 60):
                    raise AssertionError("a chunk write was never waited for")  # hang guard
        return super().write(data)

    def write_tail(self, data: bytes) -> None:
        super().write_tail(data)
        with self.changed:
            self.tails += 1
            self.changed.notify_all()


class _DrainingWriter(ChunkWriter):
    def __init__(self, stream: _HeldChunks, **options: Any) -> None:
        super().__init__(stream, **options)
        self.held = stream

    def drain(self) -> None:
        with self.held.changed:
            self.held.draining = True
            self.held.changed.notify_all()
        try:
            super().drain()
        finally:
            self.held.draining = False


def test_a_checkpoint_writes_its_tail_after_the_chunks_it_closed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Settling the ring at a checkpoint closes chunks, which the chunk thread writes; the
    tail goes after them. Written before them (issue 35: on a busy machine), the tail was cut
    off by them, and the file a killed process left lacked states; written while they were
    (two identical runs then differed at byte 4497), over one of them."""
    monkeypatch.setattr(recorder, "TailFile", _HeldChunks)
    monkeypatch.setattr(recorder, "ChunkWriter", _DrainingWriter)
    path = tmp_path / "run.mcap"
    record = StateRecords(1, 0, SPEC, 5, slice(1, 3), slice(3, 5)).ring.record_size
    steps = list(range(1, STATE_RING))
    options = {"metadata": METADATA, "library": "test", "flush_interval_s": 3600.0}
    with Recorder(path, chunk_size=10 * record, **options) as rec:  # type: ignore[arg-type]
        slot = rec.physics_state_slot(SPEC, 5, slice(1, 3), slice(3, 5))
        for k in steps:  # one fewer than a ring: only the checkpoint settles them
            slot.state[:] = k
            slot.write(k, k * 1000)
        rec.checkpoint()
        shutil.copy(path, tmp_path / "killed.mcap")
    truncated = "truncated: the file ends before its summary"
    with pytest.warns(RecordingDamagedWarning, match=truncated):
        killed = Recording(tmp_path / "killed.mcap")
    with killed as recording:
        assert [s.step for s in recording.physics_states()] == steps
        assert not recording.scan.skipped  # nothing written over
        ends = [c.end_time for c in recording.scan.chunks if c.messages]
        assert len(ends) > 1  # chunks the checkpoint closed, then its tail
        assert ends[-1] == steps[-1] * 1000
    with Recording(path) as recording:
        assert [s.step for s in recording.physics_states()] == steps


class _WriteDuringSettle(ChunkWriter):
    """A writer that calls :attr:`during` (once) right after its next settle."""

    during: Callable[[], None] | None = None

    def settle(self) -> None:
        super().settle()
        during = type(self).during
        type(self).during = None
        if during is not None:
            during()


def test_a_state_written_while_a_flush_settles_goes_in_the_next_flush(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The slot writes without the recorder's lock: a state written while the flush thread
    is flushing (after it settled the ring) is not in that flush; the flush neither claims
    it nor marks the recorder clean, so the next flush puts it on disk."""
    monkeypatch.setattr(recorder, "ChunkWriter", _WriteDuringSettle)
    path = tmp_path / "run.mcap"
    flushed: list[FlushInfo] = []
    options = {"metadata": METADATA, "library": "test", "flush_interval_s": 3600.0}
    with Recorder(path, on_flush=flushed.append, **options) as rec:  # type: ignore[arg-type]
        slot = rec.physics_state_slot(SPEC, 5, slice(1, 3), slice(3, 5))
        for k in (1, 2):
            slot.write(k, k * 1000)
        monkeypatch.setattr(_WriteDuringSettle, "during", lambda: slot.write(3, 3000))
        rec.checkpoint()
        rec.checkpoint()
        shutil.copy(path, tmp_path / "killed.mcap")
    assert [info.sim_time_ns for info in flushed] == [2000, 3000]
    with pytest.warns(RecordingDamagedWarning, match="truncated"):
        killed = Recording(tmp_path / "killed.mcap")
    with killed as recording:
        assert [s.step for s in recording.physics_states()] == [1, 2, 3]


def test_bad_writes_are_refused_in_one_line(tmp_path: Path) -> None:
    with Recorder(tmp_path / "run.mcap", metadata=METADATA, library="test") as rec:
        slot = rec.physics_state_slot(SPEC, 5, slice(1, 3), slice(3, 5))
        slot.write(2, 2000)
        with pytest.raises(RecordingWriteError, match=r"^/harness/state step -1: cannot serial"):
            slot.write(-1, 3000)
        with pytest.raises(RecordingWriteError, match=r"^/harness/state: sim_time_ns 1000 is bef"):
            slot.write(3, 1000)
        with pytest.raises(RecordingWriteError, match="has one physics state slot"):
            rec.physics_state_slot(SPEC, 5, slice(1, 3), slice(3, 5))
        slot.write(3, 3000)
    with pytest.raises(RecordingWriteError, match="recorder is closed"):
        slot.write(4, 4000)
    with Recording(tmp_path / "run.mcap") as recording:
        assert [s.step for s in recording.physics_states()] == [2, 3]


@pytest.mark.parametrize(
    ("size", "qpos", "qvel", "what"),
    [
        (0, slice(0, 0), slice(0, 0), "state_size must be an integer >= 1"),
        (5, slice(1, 7), slice(3, 5), "qpos slice(1, 7, None) is not a contiguous part"),
        (5, slice(1, 3), slice(4, 0, -1), "qvel slice(4, 0, -1) is not a contiguous part"),
    ],
)
def test_a_slot_that_does_not_fit_the_state_is_refused(
    tmp_path: Path, size: int, qpos: slice, qvel: slice, what: str
) -> None:
    with (
        Recorder(tmp_path / "run.mcap", metadata=METADATA, library="test") as rec,
        pytest.raises(RecordingWriteError, match=f"^physics state slot: {re.escape(what)}"),
    ):
        rec.physics_state_slot(SPEC, size, qpos, qvel)
    with pytest.raises(RecordingWriteError, match=f"^physics state slot: {re.escape(what)}"):
        forwarding_slot(lambda record: None, SPEC, size, qpos, qvel)


def test_a_forwarding_slot_passes_records_with_views_of_the_state() -> None:
    got: list[PhysicsState] = []
    slot = forwarding_slot(got.append, SPEC, 6, slice(1, 3), slice(3, 6))
    slot.state[:] = np.arange(6.0)
    slot.write(4, 4000)
    (record,) = got
    assert (record.step, record.sim_time_ns, record.state_spec) == (4, 4000, SPEC)
    np.testing.assert_array_equal(record.qpos, [1.0, 2.0])
    np.testing.assert_array_equal(record.qvel, [3.0, 4.0, 5.0])
