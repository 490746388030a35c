"""Bulk reading of physics states and the indexed opening pass, checked against the
message-by-message path and the full walk on real recordings (complete, damaged, irregular)."""

from __future__ import annotations

import mmap
import shutil
import struct
import warnings
import zlib
from pathlib import Path
from types import ModuleType

import mujoco
import numpy as np
import pytest
from mcap.reader import make_reader

from harness.recording import (
    PhysicsState,
    PhysicsStateArrays,
    Recorder,
    Recording,
    RecordingDamagedError,
    RecordingDamagedWarning,
    RecordingFormatError,
    RosoutRecord,
)
from harness.recording import bulk as bulk_module
from harness.recording.scan import index_scan, message_offsets, read_chunk_data, scan

METADATA = {
    "timestep": "0.001",
    "integrator": "EULER",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}


@pytest.fixture(scope="module")
def many_chunks(record_run: ModuleType, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real run (every kind of record, a kinematic input, contacts) in ~40 chunks."""
    path = tmp_path_factory.mktemp("bulk") / "chunks.mcap"
    record_run.record(path, 500, chunk_size=24 * 1024)
    return path


def _one_by_one(
    rec: Recording, start: int | None = None, stop: int | None = None
) -> list[PhysicsState]:
    return list(rec.physics_states(start, stop))


def _assert_same(arrays: PhysicsStateArrays, states: list[PhysicsState]) -> None:
    """Bit for bit: every field of every state."""
    assert arrays.steps.tolist() == [s.step for s in states]
    assert arrays.sim_time_ns.tolist() == [s.sim_time_ns for s in states]
    if not states:
        assert arrays.state.shape[0] == 0
        return
    assert arrays.state_spec == states[0].state_spec
    for name in ("state", "qpos", "qvel"):
        got = getattr(arrays, name)
        want = np.stack([np.asarray(getattr(s, name), dtype=np.float64) for s in states])
        assert got.dtype == np.float64
        assert got.shape == want.shape
        assert got.tobytes() == want.tobytes(), name


def test_arrays_equal_the_message_by_message_path(many_chunks: Path) -> None:
    with Recording(many_chunks) as rec:
        assert rec.scan.indexed
        assert len(rec.scan.chunks) > 10
        states = _one_by_one(rec)
        assert len(states) == 501
        _assert_same(rec.physics_state_arrays(), states)
        for start, stop in ((0, 1), (37, 415), (499, 10_000), (600, 700), (None, 3)):
            _assert_same(rec.physics_state_arrays(start, stop), _one_by_one(rec, start, stop))


def test_blocks_are_the_arrays_in_pieces(many_chunks: Path) -> None:
    with Recording(many_chunks) as rec:
        whole = rec.physics_state_arrays()
        blocks = list(rec.physics_state_blocks(rows=64))
        assert len(blocks) > 3
        assert all(b.steps.size >= 64 for b in blocks[:-1])
        for name in ("steps", "sim_time_ns", "state", "qpos", "qvel"):
            joined = np.concatenate([getattr(b, name) for b in blocks])
            assert joined.tobytes() == getattr(whole, name).tobytes(), name
        windowed = list(rec.physics_state_blocks(100, 200, rows=1))
        assert np.concatenate([b.steps for b in windowed]).tolist() == list(range(100, 200))


def test_the_two_packing_paths_agree(many_chunks: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Strided runs of equally spaced records, or rows copied out one by one."""
    with Recording(many_chunks) as rec:
        runs = rec.physics_state_arrays()
        monkeypatch.setattr(bulk_module, "_MAX_RUNS_PER_CHUNK", 0)
        packed = rec.physics_state_arrays()
    for name in ("steps", "state", "qpos", "qvel"):
        assert getattr(runs, name).tobytes() == getattr(packed, name).tobytes()


def test_index_scan_finds_what_the_full_walk_finds(many_chunks: Path) -> None:
    with open(many_chunks, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        buf = memoryview(mm)
        try:
            fast = index_scan(buf, str(many_chunks))
            walked = scan(buf, str(many_chunks))
            assert fast is not None
            assert fast.indexed
            assert not walked.indexed
            assert not fast.problems
            assert not walked.problems
            assert fast.chunks == walked.chunks
            assert fast.counts == walked.counts
            assert fast.time_ranges == walked.time_ranges
            assert (fast.start_time, fast.end_time) == (walked.start_time, walked.end_time)
            assert [m.name for m in fast.metadata] == [m.name for m in walked.metadata]
            assert fast.attachments == walked.attachments
            assert {k: c.topic for k, c in fast.channels.items()} == {
                k: c.topic for k, c in walked.channels.items()
            }
            assert fast.data_crc_checked
            assert fast.summary_crc_checked
            assert fast.summary_checks == walked.summary_checks
            for chunk in fast.chunks:
                data = read_chunk_data(buf, chunk)
                by_walk = message_offsets(data, set(chunk.channels))
                index = fast.message_index[chunk.offset]
                assert index.keys() == by_walk.keys()
                for channel, offsets in index.items():
                    assert offsets.tolist() == by_walk[channel].tolist()
        finally:
            buf.release()


@pytest.mark.parametrize("damage", ["truncated", "flipped"])
def test_damaged_files_fall_back_to_the_walk(
    many_chunks: Path, tmp_path: Path, damage: str
) -> None:
    path = tmp_path / f"{damage}.mcap"
    shutil.copy(many_chunks, path)
    blob = bytearray(path.read_bytes())
    if damage == "truncated":
        del blob[int(len(blob) * 0.6) :]
    else:
        with Recording(many_chunks) as rec:
            chunk = rec.scan.chunks[len(rec.scan.chunks) // 2]
        blob[chunk.offset + chunk.length // 2] ^= 0xFF
    path.write_bytes(bytes(blob))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = Recording(path)
    with rec:
        assert any(issubclass(w.category, RecordingDamagedWarning) for w in caught)
        assert not rec.scan.indexed
        assert rec.problems
        states = _one_by_one(rec)
        assert 0 < len(states) < 501
        _assert_same(rec.physics_state_arrays(), states)
        blocks = list(rec.physics_state_blocks(rows=50))
        assert np.concatenate([b.steps for b in blocks]).tolist() == [s.step for s in states]


def test_irregularly_interleaved_records(tmp_path: Path) -> None:
    """States between records of other topics of every size: no two gaps alike."""
    path = tmp_path / "irregular.mcap"
    rng = np.random.default_rng(3)
    with Recorder(path, metadata=METADATA, chunk_size=8192) as rec:
        for step in range(300):
            now = step * 1_000_000
            for _ in range(int(rng.integers(0, 3))):
                text = "x" * int(rng.integers(0, 200))
                rec.write_rosout(RosoutRecord(sim_time_ns=now, level=20, name="noise", msg=text))
            rec.write_physics_state(PhysicsState(
                step=step, sim_time_ns=now, state_spec=int(mujoco.mjtState.mjSTATE_FULLPHYSICS),
                state=rng.normal(size=13), qpos=rng.normal(size=4), qvel=rng.normal(size=3),
            ))  # fmt: skip
    with Recording(path) as r:
        assert r.scan.indexed
        _assert_same(r.physics_state_arrays(), _one_by_one(r))
        _assert_same(r.physics_state_arrays(150, 151), _one_by_one(r, 150, 151))


def test_states_that_change_layout_are_refused_by_step(tmp_path: Path) -> None:
    path = tmp_path / "layout.mcap"
    with Recorder(path, metadata=METADATA, chunk_size=4096) as rec:
        for step in range(120):
            size = 10 if step < 77 else 11
            rec.write_physics_state(PhysicsState(
                step=step, sim_time_ns=step * 1_000_000, state_spec=1,
                state=[float(step)] * size, qpos=[0.5], qvel=[0.25],
            ))  # fmt: skip
    with Recording(path) as r:
        with pytest.raises(RecordingFormatError, match=r"step 77 has 11 state.*change layout"):
            r.physics_state_arrays()
        _assert_same(r.physics_state_arrays(0, 77), _one_by_one(r, 0, 77))
        _assert_same(r.physics_state_arrays(77, None), _one_by_one(r, 77, None))


def test_no_states_gives_empty_arrays(tmp_path: Path) -> None:
    path = tmp_path / "nostates.mcap"
    with Recorder(path, metadata=METADATA) as rec:
        rec.write_rosout(RosoutRecord(sim_time_ns=0, level=20, name="only", msg="a log line"))
    with Recording(path) as r:
        arrays = r.physics_state_arrays()
        assert arrays.steps.size == 0
        assert arrays.state.shape[0] == 0
        assert list(r.physics_state_blocks()) == []
        assert r.time_range("/harness/state") == (-1, -1)
        assert r.time_range("/rosout") == (0, 0)


def _fix_data_crc(blob: bytearray) -> None:
    """Make the data-section CRC right again after an edit (only chunk CRCs and indexes can
    then tell)."""
    summary_start = struct.unpack_from("<Q", blob, len(blob) - 8 - 20)[0]
    data_end = summary_start - 13
    assert blob[data_end] == 0x0F
    struct.pack_into("<I", blob, data_end + 9, zlib.crc32(blob[:data_end]))


def _lying_index(src: Path, dst: Path, lie: str) -> Path:
    """``src`` with one message index entry naming the wrong log time or record."""
    blob = bytearray(src.read_bytes())
    with open(src, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    state_channel = next(c.id for c in summary.channels.values() if c.topic == "/harness/state")
    at = summary.chunk_indexes[3].message_index_offsets[state_channel]
    first_entry = at + 9 + 2 + 4
    field = first_entry if lie == "log_time" else first_entry + 8
    value = struct.unpack_from("<Q", blob, field)[0]
    struct.pack_into("<Q", blob, field, value + (1 if lie == "log_time" else 31))
    _fix_data_crc(blob)
    dst.write_bytes(bytes(blob))
    return dst


def corrupt_chunk(src: Path, dst: Path, which: int) -> tuple[Path, int]:
    """``src`` with chunk ``which``'s CRC of its records wrong, the data-section CRC made
    right: only the chunk's own check finds it. Returns the chunk's offset."""
    blob = bytearray(src.read_bytes())
    with Recording(src) as rec:
        chunk = rec.scan.chunks[which]
    blob[chunk.offset + 9 + 24] ^= 0x5A  # the chunk's uncompressed_crc field
    _fix_data_crc(blob)
    dst.write_bytes(bytes(blob))
    return dst, chunk.offset


@pytest.mark.parametrize("lie", ["log_time", "offset"])
def test_a_message_index_that_disagrees_with_its_chunk_is_not_trusted(
    many_chunks: Path, tmp_path: Path, lie: str
) -> None:
    """An index entry naming the wrong time or record (CRCs made right again) sends the
    opening pass to the full walk, and reading still gives every state; with deferred
    checks, the read of that chunk refuses it."""
    path = _lying_index(many_chunks, tmp_path / f"lying-{lie}.mcap", lie)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rec = Recording(path)
    with rec:
        assert not rec.scan.indexed
        assert not rec.problems
        _assert_same(rec.physics_state_arrays(), _one_by_one(rec))
        assert rec.physics_state_arrays().steps.size == 501
    with Recording(path, defer_chunk_checks=True) as rec:
        # A time out of order shows in the indexes alone; a wrong record only in the chunk.
        assert rec.scan.indexed == (lie == "offset")
        if lie == "offset":
            with pytest.raises(RecordingDamagedError, match=r"chunk at byte \d+: .*index"):
                rec.physics_state_arrays()


def test_deferred_checks_read_the_same_and_check_every_chunk_read(many_chunks: Path) -> None:
    with Recording(many_chunks) as eager, Recording(many_chunks, defer_chunk_checks=True) as lazy:
        assert eager.scan.indexed
        assert lazy.scan.indexed
        assert not eager.scan.unchecked
        assert set(lazy.scan.unchecked) == {c.offset for c in lazy.scan.chunks}
        assert lazy.scan.chunks == eager.scan.chunks
        assert lazy.scan.time_ranges == eager.scan.time_ranges
        part = lazy.physics_state_arrays(0, 50)
        assert 0 < len(lazy.scan.unchecked) < len(lazy.scan.chunks)
        _assert_same(part, _one_by_one(eager, 0, 50))
        _assert_same(lazy.physics_state_arrays(), _one_by_one(eager))
        assert not lazy.scan.unchecked


def test_deferred_checks_find_a_bad_chunk_when_reading_it(
    many_chunks: Path, tmp_path: Path
) -> None:
    path, offset = corrupt_chunk(many_chunks, tmp_path / "bad-chunk.mcap", 5)
    with Recording(path, defer_chunk_checks=True) as lazy:
        assert lazy.scan.indexed
        assert not lazy.problems
        assert lazy.physics_state_arrays(0, 5).steps.size == 5  # chunks before it read fine
        with pytest.raises(RecordingDamagedError, match=f"chunk at byte {offset}: "):
            lazy.physics_state_arrays()
    with pytest.warns(RecordingDamagedWarning, match=f"byte {offset}: corrupt"):
        eager = Recording(path)
    with eager:
        assert not eager.scan.indexed
        assert len(eager.scan.chunks) == len(lazy.scan.chunks) - 1  # only the bad one is lost
        assert [s.offset for s in eager.scan.skipped] == [offset]


def test_check_chunks_checks_what_reading_skipped(tmp_path: Path) -> None:
    """Deferred checks: chunks no read touched (here: logs only) are checked on demand."""
    path = tmp_path / "logs-at-the-end.mcap"
    with Recorder(path, metadata=METADATA, chunk_size=4096) as rec:
        for step in range(100):
            rec.write_physics_state(PhysicsState(
                step=step, sim_time_ns=step * 1_000_000, state_spec=1,
                state=[float(step)] * 10, qpos=[0.5], qvel=[0.25],
            ))  # fmt: skip
        for i in range(200):
            rec.write_rosout(
                RosoutRecord(sim_time_ns=99_000_000, level=20, name="tail", msg=f"line {i}" * 9)
            )
    with Recording(path) as r:
        logs_only = [c for c in r.scan.chunks if len(c.channels) == 1 and c.messages > 1]
        states = {cid for cid, c in r.scan.channels.items() if c.topic == "/harness/state"}
        last = logs_only[-1]
        assert states.isdisjoint(last.channels)
    damaged, offset = corrupt_chunk(path, tmp_path / "damaged.mcap", r.scan.chunks.index(last))
    with Recording(damaged, defer_chunk_checks=True) as lazy:
        assert lazy.physics_state_arrays().steps.tolist() == list(range(100))
        assert offset in lazy.scan.unchecked
        with pytest.raises(RecordingDamagedError, match=f"chunk at byte {offset}: chunk CRC"):
            lazy.check_chunks()
    with Recording(path, defer_chunk_checks=True) as sound:
        sound.check_chunks()
        assert not sound.scan.unchecked
