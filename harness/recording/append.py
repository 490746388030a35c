"""Appending a pre-serialised message to an ``mcap.Writer``'s open chunk, fast.

``Writer.add_message`` builds a ``Message`` record object and writes it field by field
through ``RecordBuilder`` (a seek back to patch the length): about three quarters of the
recorder's time per message. :class:`MessageAppender` writes the same record with one
``struct`` call into the open chunk's buffer and keeps the same statistics, chunk times and
message indexes, then lets the writer close the chunk by size exactly as it would: the file's
bytes are those ``add_message`` gives (``tests/recording/test_append.py``). It reads the
writer's private state, like :func:`harness.recording.tail.provisional_chunk` (mcap 1.6,
pinned in constraints.txt); log times must not go backwards (the recorder checks that).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

import numpy as np
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import MessageIndex
from mcap.writer import Writer

__all__ = ["MessageAppender"]

# opcode MESSAGE (5), record length, channel id, sequence, log time, publish time
_MESSAGE = struct.Struct("<BQHIQQ")


class _MessageIndex(MessageIndex):
    """A ``MessageIndex`` that writes its (time, offset) pairs with one numpy call."""

    def write(self, stream: RecordBuilder) -> None:
        stream.start_record(Opcode.MESSAGE_INDEX)
        stream.write2(self.channel_id)
        stream.write4(16 * len(self.records))
        stream.write(np.array(self.records, dtype="<u8").tobytes())
        stream.finish_record()  # type: ignore[no-untyped-call]


class MessageAppender:
    """``append(channel_id, time_ns, data, sequence)``: ``writer.add_message`` with
    ``log_time == publish_time == time_ns``, for a chunked writer (``chunk_size`` > 0)."""

    def __init__(self, writer: Writer) -> None:
        self._stats: Any = writer._Writer__statistics  # type: ignore[attr-defined]
        self._counts: dict[int, int] = self._stats.channel_message_counts
        self._builder: Any = writer._Writer__chunk_builder  # type: ignore[attr-defined]
        if self._builder is None:
            raise ValueError("MessageAppender needs a chunked mcap writer")
        self._indices: dict[int, MessageIndex] = self._builder.message_indices
        self._chunk_size: int = writer._Writer__chunk_size  # type: ignore[attr-defined]
        self._finalize: Callable[[], None] = writer._Writer__maybe_finalize_chunk  # type: ignore[attr-defined]

    def append(
        self, channel_id: int, time_ns: int, data: bytes | memoryview, sequence: int
    ) -> None:
        """Add one message record to the open chunk (closing it when full)."""
        stats = self._stats
        if stats.message_count == 0:
            stats.message_start_time = time_ns
        stats.message_end_time = time_ns
        self._counts[channel_id] += 1
        stats.message_count += 1
        builder = self._builder
        if builder.num_messages == 0:
            builder.message_start_time = time_ns
        builder.message_end_time = time_ns
        buffer = builder.record_writer._buffer
        offset = buffer.tell()
        index = self._indices.get(channel_id)
        if index is None:
            index = self._indices[channel_id] = _MessageIndex(channel_id, [])
        index.records.append((time_ns, offset))
        builder.num_messages += 1
        buffer.write(_MESSAGE.pack(5, 22 + len(data), channel_id, sequence, time_ns, time_ns))
        buffer.write(data)
        if offset + 31 + len(data) > self._chunk_size:
            self._finalize()
