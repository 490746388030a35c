"""ChunkWriter (the recorder's MCAP writer, chunks compressed on a thread of their own) writes
the bytes mcap.Writer writes for the same records, and its files pass the CRC-checking reader."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from harness.recording.tail import TailFile
from harness.recording.writer import MAX_PENDING, ChunkWriter

MODES = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}


def _messages() -> list[tuple[int, int, bytes]]:
    """(channel index, time, payload): three channels, payload sizes 0..1999 bytes."""
    rng = np.random.default_rng(3)
    out = []
    for k in range(3000):
        size = int(rng.integers(0, 2000))
        payload = rng.integers(0, 4, size, dtype=np.uint8).tobytes()  # compressible
        out.append((k % 3 if k % 7 else 2, 1000 + k // 2, payload))
    return out


def _reference(path: Path, compression: str, chunk_size: int) -> bytes:
    with open(path, "wb") as f:
        writer = Writer(
            f,
            chunk_size=chunk_size,
            compression=MODES[compression],
            enable_crcs=True,
            enable_data_crcs=True,
        )
        writer.start(profile="ros2", library="test")
        writer.add_metadata("harness", {"a": "1"})
        writer.add_attachment(0, 0, "model.xml", "application/xml", b"<mujoco/>")
        schema = writer.register_schema("s", "ros2msg", b"uint8[] data")
        channels = [
            writer.register_channel(f"/c{i}", "cdr", schema, {"offered_qos_profiles": ""})
            for i in range(3)
        ]
        seq = [0, 0, 0]
        for k, (c, t, payload) in enumerate(_messages()):
            writer.add_message(channels[c], t, payload, t, seq[c])
            seq[c] += 1
            if k == 1500:
                writer.flush()  # type: ignore[no-untyped-call]
                writer.add_metadata("later", {"b": "2"})
        writer.finish()  # type: ignore[no-untyped-call]
    return path.read_bytes()


def _ours(path: Path, compression: str, chunk_size: int) -> bytes:
    stream = TailFile(path)
    writer = ChunkWriter(
        stream, profile="ros2", library="test", chunk_size=chunk_size, compression=compression
    )
    writer.add_metadata("harness", {"a": "1"})
    writer.add_attachment("model.xml", "application/xml", b"<mujoco/>")
    schema = writer.register_schema("s", "ros2msg", b"uint8[] data")
    channels = [
        writer.register_channel(f"/c{i}", "cdr", schema, {"offered_qos_profiles": ""})
        for i in range(3)
    ]
    seq = [0, 0, 0]
    for k, (c, t, payload) in enumerate(_messages()):
        # the payload in two parts: the writer joins them
        writer.add(channels[c], t, seq[c], (payload[:5], memoryview(payload)[5:]), len(payload))
        seq[c] += 1
        if k == 1500:
            writer.flush()
            writer.add_metadata("later", {"b": "2"})
    writer.finish()
    stream.close()
    return path.read_bytes()


@pytest.mark.parametrize(
    ("compression", "chunk_size"),
    [("zstd", 1 << 20), ("zstd", 8192), ("lz4", 65536), ("none", 4096)],
)
def test_same_bytes_as_mcap_writer(tmp_path: Path, compression: str, chunk_size: int) -> None:
    ours = _ours(tmp_path / "ours.mcap", compression, chunk_size)
    assert ours == _reference(tmp_path / "ref.mcap", compression, chunk_size)
    # every CRC (chunks, data section) checks; the summary reads back
    records = list(StreamReader(io.BytesIO(ours), validate_crcs=True).records)
    assert records
    reader = make_reader(io.BytesIO(ours), validate_crcs=True)
    summary = reader.get_summary()
    assert summary is not None
    assert summary.statistics is not None
    assert summary.statistics.message_count == 3000
    assert len(list(reader.iter_messages())) == 3000


def test_many_small_chunks_land_in_order(tmp_path: Path) -> None:
    """Far more closed chunks than may wait at once: the caller waits, nothing is lost."""
    stream = TailFile(tmp_path / "r.mcap")
    writer = ChunkWriter(stream, profile="ros2", library="test", chunk_size=64)
    schema = writer.register_schema("s", "ros2msg", b"uint8[] data")
    channel = writer.register_channel("/c", "cdr", schema, {})
    for k in range(50 * MAX_PENDING):
        writer.add(channel, k, k, (bytes(100),), 100)
    writer.finish()
    stream.close()
    reader = make_reader(io.BytesIO((tmp_path / "r.mcap").read_bytes()), validate_crcs=True)
    assert [m.sequence for _, _, m in reader.iter_messages()] == list(range(50 * MAX_PENDING))


def test_a_failed_chunk_write_is_raised(tmp_path: Path) -> None:
    """The chunk thread's write error reaches the caller (at the latest at flush)."""
    stream = TailFile(tmp_path / "r.mcap")
    writer = ChunkWriter(stream, profile="ros2", library="test", chunk_size=64)
    schema = writer.register_schema("s", "ros2msg", b"uint8[] data")
    channel = writer.register_channel("/c", "cdr", schema, {})
    stream.close()  # the descriptor is gone: every later write fails

    def fill() -> None:
        for k in range(10 * MAX_PENDING):
            writer.add(channel, k, k, (bytes(100),), 100)
        writer.flush()

    with pytest.raises(OSError, match="Bad file descriptor"):
        fill()
    writer.abandon()
