"""MessageAppender writes the bytes mcap.Writer.add_message writes (chunks, indexes, summary)."""

from __future__ import annotations

import io

import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from harness.recording.append import MessageAppender


def _file(use_appender: bool, chunk_size: int) -> bytes:
    out = io.BytesIO()
    writer = Writer(out, chunk_size=chunk_size, compression=CompressionType.NONE)
    writer.start(profile="ros2", library="test")
    schema = writer.register_schema("s", "ros2msg", b"int32 x")
    channels = [writer.register_channel(f"/c{i}", "cdr", schema) for i in range(3)]
    append = MessageAppender(writer).append
    for k in range(400):
        channel = channels[k % 3 if k % 7 else 2]
        payload = bytes([k % 251]) * (k % 37)
        if use_appender:
            append(channel, 1000 + k // 2, payload, k)
        else:
            writer.add_message(channel, 1000 + k // 2, payload, 1000 + k // 2, k)
        if k == 150:
            writer.flush()  # type: ignore[no-untyped-call]
    writer.finish()  # type: ignore[no-untyped-call]
    return out.getvalue()


@pytest.mark.parametrize("chunk_size", [64, 1024, 1 << 20])
def test_same_bytes_as_add_message(chunk_size: int) -> None:
    ours = _file(True, chunk_size)
    assert ours == _file(False, chunk_size)
    messages = list(make_reader(io.BytesIO(ours)).iter_messages())
    assert len(messages) == 400
    assert [m.sequence for _, _, m in messages] == list(range(400))


def test_unchunked_writer_is_refused() -> None:
    writer = Writer(io.BytesIO(), chunk_size=0, use_chunking=False)
    with pytest.raises(ValueError, match="chunked"):
        MessageAppender(writer)
