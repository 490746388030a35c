"""``ChunkWriter``: the recorder's MCAP container writer (chunked, indexed, CRCs on).

It writes the bytes ``mcap.writer.Writer`` writes for the recorder's use (header, attachments,
metadata, schema and channel records in the chunks, chunks with message indexes, the summary
with statistics and every index, the footer with the summary CRC, the data-section CRC; with
``enable_crcs`` and ``enable_data_crcs``: ``tests/recording/test_writer.py`` compares the two),
with two differences that make recording cheap for the thread that steps the simulation:

- a message is appended to the open chunk's ``bytearray`` with one ``struct`` call for its
  record header, then its parts as they are (no record object per message, no copy of the
  arrays' bytes before the chunk buffer);
- a full chunk is compressed, CRC-checked and written by a thread of its own (one, so chunks
  land in order: the file's bytes do not depend on timing). Compression and CRCs release the
  GIL, so the stepping thread keeps going meanwhile. At most :data:`MAX_PENDING` chunks wait;
  beyond that the caller waits (nothing is dropped).

A channel whose messages all have one size (the per-step state) may be filled in place into a
:class:`RecordRing` by one thread and moved into the open chunk by the writer before anything
else is added (:meth:`ChunkWriter.settle`): the file's bytes are those of adding each message
in turn, at a lock and a few calls per ring instead of per message.

Chunks still close by size alone (byte-reproducible files). :meth:`drain` waits until every
closed chunk is on disk; :meth:`provisional` gives the open chunk as a complete chunk record
plus its message indexes for the crash-safety tail (:mod:`harness.recording.tail`), after
waiting for the chunks that settling the ring closed: one thread writes the file at a time.
A write error of the chunk thread (disk full) is raised by the next :meth:`add` that closes a
chunk, by :meth:`drain`, :meth:`flush` and :meth:`finish`.
"""

from __future__ import annotations

import io
import struct
import sys
import zlib
from array import array
from collections import deque
from collections.abc import Callable, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, TypeAlias

import numpy.typing as npt
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

from harness.recording._crc import crc32
from harness.recording.tail import TailFile

__all__ = ["COMPRESSIONS", "MAX_PENDING", "Buffer", "ChunkWriter", "RecordRing"]

Buffer: TypeAlias = bytes | bytearray | memoryview | npt.NDArray[Any]
"""What a message part may be (C-contiguous; an array's raw bytes are written)."""

MAGIC = b"\x89MCAP0\r\n"
MAX_PENDING = 4
"""Closed chunks that may wait for the chunk thread before :meth:`ChunkWriter.add` waits."""

# opcode MESSAGE (5), record length, channel id, sequence, log time, publish time
_MESSAGE = struct.Struct("<BQHIQQ")
# opcode CHUNK (6), record length, start, end, uncompressed size, uncompressed CRC
_CHUNK = struct.Struct("<BQQQQI")
# opcode MESSAGE_INDEX (7), record length, channel id, byte length of the (time, offset) pairs
_INDEX = struct.Struct("<BQHI")
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")


def _u64s(values: list[int]) -> bytes:
    """``values`` as little-endian uint64 (``array`` converts a list of ints in C, a third
    of numpy's cost; the chunk thread does this with the GIL held)."""
    packed = array("Q", values)
    if sys.byteorder == "big":
        packed.byteswap()
    return packed.tobytes()


def _lz4(data: bytes | bytearray | memoryview) -> bytes:
    import lz4.frame  # type: ignore[import-untyped]

    packed: bytes = lz4.frame.compress(data)
    return packed


COMPRESSIONS: dict[str, Callable[[bytes | bytearray | memoryview], bytes] | None] = {
    "zstd": zstandard.compress,
    "lz4": _lz4,
    "none": None,
}
"""Chunk compressions by their name in the recorder's options."""

_CHUNK_NAMES = {"zstd": b"zstd", "lz4": b"lz4", "none": b""}


class RecordRing:
    """Complete MCAP message records of one channel, each ``record_size`` bytes, laid out one
    after the other in :attr:`buffer` (``capacity`` of them; ``times[i]`` is record ``i``'s
    log time). The filling thread writes record ``count`` and then increments ``count``; the
    writer moves records ``moved`` up to ``count`` into the chunk (:meth:`ChunkWriter.settle`,
    under the caller's lock); the filler starts again at 0 only after a settle, under the
    same lock (:meth:`restart`)."""

    __slots__ = ("buffer", "capacity", "channel_id", "count", "moved", "record_size", "times")

    def __init__(self, channel_id: int, record_size: int, capacity: int) -> None:
        self.channel_id = channel_id
        self.record_size = record_size
        self.capacity = capacity
        self.buffer = bytearray(record_size * capacity)
        self.times = [0] * capacity
        self.count = 0
        self.moved = 0

    def restart(self) -> None:
        """Fill from record 0 again (every record has been moved)."""
        if self.moved != self.count:
            raise RuntimeError("RecordRing.restart: records not moved yet")
        self.count = self.moved = 0


class _Open:
    """The open chunk: its records (``out``, from position 0 to its position), its message
    indexes (flat ``[time, offset, ...]`` per channel, in first-message order) and its time
    range."""

    __slots__ = ("end", "indexes", "out", "start")

    def __init__(self, out: io.BytesIO) -> None:
        self.out = out
        self.indexes: dict[int, list[int]] = {}  # empty: no message yet
        self.start = 0
        self.end = 0


def _buffer(capacity: int) -> io.BytesIO:
    """A chunk buffer that holds ``capacity`` bytes without growing: a buffer grown by
    appending is copied at every reallocation (for a 1 MiB chunk that costs more than the
    copies of its messages)."""
    out = io.BytesIO()
    out.seek(capacity - 1)
    out.write(b"\0")
    out.seek(0)
    return out


class ChunkWriter:
    """Writes an MCAP file to ``stream`` (see the module docstring). ``compression`` is a key
    of :data:`COMPRESSIONS`; ``chunk_size`` the uncompressed size at which a chunk closes."""

    def __init__(
        self,
        stream: TailFile,
        *,
        profile: str,
        library: str,
        chunk_size: int = 1024 * 1024,
        compression: str = "zstd",
    ) -> None:
        if compression not in COMPRESSIONS:
            raise ValueError(f"compression must be one of {', '.join(COMPRESSIONS)}")
        self._stream = stream
        self._chunk_size = chunk_size
        self._compress = COMPRESSIONS[compression]
        self._compression = compression
        # chunk buffers the chunk thread is done with, for the next chunks
        self._spare: deque[io.BytesIO] = deque(maxlen=2)
        self._open = self._new_chunk()
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._chunk_indexes: list[ChunkIndex] = []
        self._attachment_indexes: list[AttachmentIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._counts: dict[int, int] = {}
        self._messages = 0
        self._start = 0
        self._end = 0
        self._data_crc = 0
        self._ring: RecordRing | None = None
        self._pool = ThreadPoolExecutor(1, thread_name_prefix="harness-chunks")
        self._pending: deque[Future[None]] = deque()
        self._commit(MAGIC)
        self._commit(_record(Header(profile=profile, library=library)))

    # -- records outside the chunks ----------------------------------------------------------

    def add_attachment(self, name: str, media_type: str, data: bytes) -> None:
        """An attachment record (log and create time 0) and its index."""
        self.drain()
        blob = bytes(data)
        record = Attachment(create_time=0, log_time=0, name=name, media_type=media_type, data=blob)
        raw = _record(record)
        offset = self._stream.tell()
        self._commit(raw)
        self._attachment_indexes.append(
            AttachmentIndex(
                offset=offset,
                length=len(raw),
                log_time=0,
                create_time=0,
                data_size=len(blob),
                name=name,
                media_type=media_type,
            )
        )

    def add_metadata(self, name: str, metadata: Mapping[str, str]) -> None:
        """A metadata record and its index (after every chunk closed so far)."""
        self.drain()
        raw = _record(Metadata(name=name, metadata=dict(metadata)))
        offset = self._stream.tell()
        self._commit(raw)
        self._metadata_indexes.append(MetadataIndex(offset=offset, length=len(raw), name=name))

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        """A schema (in the open chunk and the summary); its id."""
        self.settle()
        schema = Schema(id=len(self._schemas) + 1, data=data, encoding=encoding, name=name)
        self._schemas.append(schema)
        self._open.out.write(_record(schema))
        return schema.id

    def register_channel(
        self, topic: str, message_encoding: str, schema_id: int, metadata: Mapping[str, str]
    ) -> int:
        """A channel (in the open chunk and the summary); its id."""
        self.settle()
        channel = Channel(
            id=len(self._channels) + 1,
            topic=topic,
            message_encoding=message_encoding,
            metadata=dict(metadata),
            schema_id=schema_id,
        )
        self._channels.append(channel)
        self._open.out.write(_record(channel))
        return channel.id

    # -- messages ----------------------------------------------------------------------------

    def add(
        self,
        channel_id: int,
        time_ns: int,
        sequence: int,
        parts: tuple[Buffer, ...],
        size: int,
    ) -> None:
        """A message whose data is ``parts`` one after the other (``size`` bytes in all;
        C-contiguous buffers), ``log_time == publish_time == time_ns`` (times must not go
        backwards)."""
        ring = self._ring
        if ring is not None and ring.moved != ring.count:
            self.settle()
        chunk = self._open
        out = chunk.out
        offset = out.tell()
        index = chunk.indexes.get(channel_id)
        if index is None:
            if not chunk.indexes:
                chunk.start = time_ns
            index = chunk.indexes[channel_id] = []
        index += (time_ns, offset)
        chunk.end = time_ns
        write = out.write
        write(_MESSAGE.pack(5, 22 + size, channel_id, sequence, time_ns, time_ns))
        for part in parts:
            write(part)  # type: ignore[arg-type]  # numpy's stubs lack the buffer protocol
        if offset + 31 + size > self._chunk_size:
            self._close_chunk()

    def attach(self, ring: RecordRing) -> None:
        """Take ``ring``'s records into the file (one ring per writer)."""
        if self._ring is not None:
            raise RuntimeError("ChunkWriter.attach: a ring is attached already")
        self._ring = ring

    def settle(self) -> None:
        """Move the ring's complete records into the chunk, closing chunks where adding them
        one by one would (called by every method that adds to the chunk)."""
        ring = self._ring
        if ring is None:
            return
        first, count = ring.moved, ring.count
        size, cid = ring.record_size, ring.channel_id
        records = memoryview(ring.buffer)
        while first < count:
            chunk = self._open
            offset = chunk.out.tell()
            # a chunk closes after the record that takes it past chunk_size
            n = min(count - first, max(0, self._chunk_size - offset) // size + 1)
            times = ring.times[first : first + n]
            index = chunk.indexes.get(cid)
            if index is None:
                if not chunk.indexes:
                    chunk.start = times[0]
                index = chunk.indexes[cid] = []
            pairs = [0] * (2 * n)
            pairs[0::2] = times
            pairs[1::2] = range(offset, offset + n * size, size)
            index += pairs
            chunk.end = times[-1]
            chunk.out.write(records[first * size : (first + n) * size])
            first += n
            ring.moved = first
            if offset + n * size > self._chunk_size:
                self._close_chunk()

    def _close_chunk(self) -> None:
        chunk = self._open
        if not chunk.indexes:
            return
        if not self._messages:
            self._start = chunk.start
        self._end = chunk.end
        for channel_id, index in chunk.indexes.items():
            self._counts[channel_id] = self._counts.get(channel_id, 0) + len(index) // 2
            self._messages += len(index) // 2
        self._open = self._new_chunk()
        pending = self._pending
        while pending and pending[0].done():
            pending.popleft().result()  # a failed write raises here
        if len(pending) >= MAX_PENDING:
            pending.popleft().result()
        pending.append(self._pool.submit(self._write_chunk, chunk))

    def _new_chunk(self) -> _Open:
        try:
            out = self._spare.pop()
        except IndexError:
            out = _buffer(self._chunk_size + 65536)
        out.seek(0)
        return _Open(out)

    def _chunk_bytes(self, chunk: _Open, offset: int) -> tuple[bytes, ChunkIndex]:
        """The chunk record and its message indexes as they are written at ``offset``."""
        with chunk.out.getbuffer() as whole, whole[: chunk.out.tell()] as raw:
            return self._chunk_record(chunk, raw, offset)

    def _chunk_record(self, chunk: _Open, raw: memoryview, offset: int) -> tuple[bytes, ChunkIndex]:
        packed = raw if self._compress is None else self._compress(raw)
        name = _CHUNK_NAMES[self._compression]
        length = 8 + 8 + 8 + 4 + 4 + len(name) + 8 + len(packed)
        parts: list[bytes | bytearray | memoryview] = [
            _CHUNK.pack(6, length, chunk.start, chunk.end, len(raw), crc32(raw)),
            _U32.pack(len(name)),
            name,
            _U64.pack(len(packed)),
            packed,
        ]
        chunk_length = 1 + 8 + length
        index_start = offset + chunk_length
        offsets: dict[int, int] = {}
        at = index_start
        for channel_id, pairs in chunk.indexes.items():
            offsets[channel_id] = at
            body = _u64s(pairs)
            parts.append(_INDEX.pack(7, 6 + len(body), channel_id, len(body)))
            parts.append(body)
            at += 15 + len(body)
        entry = ChunkIndex(
            message_start_time=chunk.start,
            message_end_time=chunk.end,
            chunk_start_offset=offset,
            chunk_length=chunk_length,
            message_index_offsets=offsets,
            message_index_length=at - index_start,
            compression=name.decode(),
            compressed_size=len(packed),
            uncompressed_size=len(raw),
        )
        return b"".join(parts), entry

    def _write_chunk(self, chunk: _Open) -> None:
        """On the chunk thread: compress, CRC and write one closed chunk."""
        data, entry = self._chunk_bytes(chunk, self._stream.tell())
        self._spare.append(chunk.out)
        self._commit(data)
        self._chunk_indexes.append(entry)

    def _commit(self, data: bytes | bytearray) -> None:
        self._stream.write(data)
        self._data_crc = zlib.crc32(data, self._data_crc)

    # -- flushing ----------------------------------------------------------------------------

    def drain(self) -> None:
        """Wait until every closed chunk is written (raises a failed write)."""
        pending = self._pending
        while pending:
            pending.popleft().result()

    def flush(self) -> None:
        """Close the open chunk and wait until it is written."""
        self.settle()
        self._close_chunk()
        self.drain()

    def provisional(self) -> bytes | None:
        """The open chunk as the chunk record and message indexes it would be written as if it
        closed now (``None``: no message in it), once every closed chunk is written: the tail
        goes after them. Nothing may add to the writer until the tail is written."""
        self.settle()
        # Settling the ring may have closed chunks. The chunk thread writes them at the
        # committed end, where the tail goes too: written meanwhile, the tail would land on
        # top of a committed chunk (a damaged file) or be cut off by it (a flush not on disk).
        self.drain()
        if not self._open.indexes:
            return None
        data, _ = self._chunk_bytes(self._open, self._stream.tell())
        return data

    def finish(self) -> None:
        """Write the last chunk, the summary and the footer (the stream stays open)."""
        try:
            self.flush()
        finally:
            self._pool.shutdown(wait=True)
        self._commit(_record(DataEnd(data_section_crc=self._data_crc)))
        start = self._stream.tell()
        summary = RecordBuilder()
        offsets: list[SummaryOffset] = []
        statistics = Statistics(
            message_count=self._messages,
            schema_count=len(self._schemas),
            channel_count=len(self._channels),
            attachment_count=len(self._attachment_indexes),
            metadata_count=len(self._metadata_indexes),
            chunk_count=len(self._chunk_indexes),
            message_start_time=self._start,
            message_end_time=self._end,
            channel_message_counts=dict(self._counts),
        )
        groups: list[
            tuple[
                Opcode,
                list[Schema]
                | list[Channel]
                | list[Statistics]
                | list[ChunkIndex]
                | list[AttachmentIndex]
                | list[MetadataIndex],
            ]
        ] = [
            (Opcode.SCHEMA, self._schemas),
            (Opcode.CHANNEL, self._channels),
            (Opcode.STATISTICS, [statistics]),
            (Opcode.CHUNK_INDEX, self._chunk_indexes),
            (Opcode.ATTACHMENT_INDEX, self._attachment_indexes),
            (Opcode.METADATA_INDEX, self._metadata_indexes),
        ]
        for opcode, records in groups:
            group_start = summary.count
            for record in records:
                record.write(summary)
            offsets.append(
                SummaryOffset(
                    group_opcode=opcode,
                    group_start=start + group_start,
                    group_length=summary.count - group_start,
                )
            )
        offset_start = start + summary.count
        for offset in offsets:
            offset.write(summary)
        data: bytes = summary.end()  # type: ignore[no-untyped-call]
        crc = zlib.crc32(data)
        crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, 20, start, offset_start), crc)
        self._stream.write(data)
        self._stream.write(
            _record(Footer(summary_start=start, summary_offset_start=offset_start, summary_crc=crc))
        )
        self._stream.write(MAGIC)

    def abandon(self) -> None:
        """Stop the chunk thread without writing anything more (after a failed write)."""
        self._pool.shutdown(wait=True, cancel_futures=True)


def _record(record: Header | Attachment | Metadata | Schema | Channel | DataEnd | Footer) -> bytes:
    out = RecordBuilder()
    record.write(out)
    data: bytes = out.end()  # type: ignore[no-untyped-call]
    return data
