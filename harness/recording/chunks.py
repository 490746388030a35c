"""MCAP records at the byte level, and the chunks of a recording decoded and checked.

Records in a buffer (:func:`record_spans`), a chunk record's head (:func:`chunk_head`), its
records decompressed within the limits of :mod:`harness.recording.inflate` and CRC-checked
(:func:`decode_chunk`, :func:`read_chunk_data`), its message index entries checked against
them (:func:`chunk_index_entries`, :func:`entries_match`) and its messages read out
(:func:`chunk_messages`, :func:`message_offsets`, :func:`gather`). A record that cannot be
read raises :class:`RecordDamage`, which the passes of :mod:`harness.recording.scan` name
and pass over.
"""

from __future__ import annotations

import struct
from array import array
from collections.abc import Iterator
from io import BytesIO
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, ChunkIndex, Schema

from harness.recording import inflate
from harness.recording._crc import crc32
from harness.recording.errors import RecordingDamagedError, RecordingLimitError
from harness.recording.scanned import I64, ChunkInfo, IndexEntries, Scan

__all__ = [
    "MAGIC",
    "MESSAGE_HEAD",
    "MESSAGE_HEADER_SIZE",
    "RECORD_HEAD",
    "U64",
    "ChunkHead",
    "RecordCounter",
    "RecordDamage",
    "charge_declared",
    "charge_records",
    "chunk_head",
    "chunk_index_entries",
    "chunk_messages",
    "decode_chunk",
    "entries_match",
    "gather",
    "message_offsets",
    "offsets_by_channel",
    "parse_record",
    "read_chunk_data",
    "record_spans",
    "take_definition",
]

MAGIC = b"\x89MCAP0\r\n"
RECORD_HEAD = struct.Struct("<BQ")
"""A record's opcode and body length."""
U64 = struct.Struct("<Q")
"""A little-endian unsigned 64-bit field."""
MESSAGE_HEAD = struct.Struct("<HIQQ")
"""A message record's channel, sequence, log time and publish time."""
_MESSAGE_INDEX_HEAD = struct.Struct("<HI")
_HEAD_BYTES = np.arange(23)
# A message record: opcode (1) + length (8) + channel (2) + sequence (4) + log and publish time.
MESSAGE_HEADER_SIZE = 9 + 22


class RecordDamage(Exception):
    """A record (or the records of a container) that cannot be read; the message says why.
    The passes of :mod:`harness.recording.scan` name it with the byte offset where it is."""


def parse_record(cls: Any, body: bytes | memoryview) -> Any:
    """The ``mcap.records`` record ``cls`` read from its ``body``."""
    return cls.read(ReadDataStream(BytesIO(body)))


def take_definition(result: Scan, opcode: int, body: bytes | memoryview) -> bool:
    """A schema or channel record into ``result`` (True); False for any other record."""
    if opcode == Opcode.SCHEMA:
        schema = parse_record(Schema, body)
        result.schemas[schema.id] = schema
    elif opcode == Opcode.CHANNEL:
        channel = parse_record(Channel, body)
        result.channels[channel.id] = channel
    else:
        return False
    return True


class ChunkHead(NamedTuple):
    """A chunk record's fields, its compressed records as a view (no copy)."""

    message_start_time: int
    message_end_time: int
    uncompressed_size: int
    uncompressed_crc: int
    compression: str
    data: memoryview


_CHUNK_HEAD = struct.Struct("<QQQII")


def chunk_head(body: memoryview) -> ChunkHead:
    """The fields of the chunk record ``body`` (its records not decompressed); raises
    :class:`RecordDamage` when they overrun it."""
    start, end, size, crc, name_length = _CHUNK_HEAD.unpack_from(body, 0)
    at = _CHUNK_HEAD.size + name_length
    compression = str(body[_CHUNK_HEAD.size : at], "utf-8")
    (records_length,) = U64.unpack_from(body, at)
    if at + 8 + records_length > len(body):
        raise RecordDamage(f"chunk records ({records_length} bytes) overrun the chunk record")
    return ChunkHead(start, end, size, crc, compression, body[at + 8 : at + 8 + records_length])


def _decompress(chunk: ChunkHead, counter: RecordCounter | None = None) -> bytes:
    try:
        return inflate.decompress(
            chunk.compression, chunk.data, chunk.uncompressed_size, watch=counter
        )
    except inflate.InflateError as exc:
        raise RecordDamage(str(exc)) from None


def _over_limit(limits: inflate.InflateLimits, before: int, count: int) -> str:
    """What a chunk of ``count`` records, after ``before`` records of its file, is over."""
    if count > limits.chunk_records:
        return (
            f"holds more than {limits.chunk_records} records, over the limit per chunk "
            f"({inflate.CHUNK_RECORDS_ENV})"
        )
    return (
        f"takes the file past {limits.file_records} records, over the limit per file "
        f"({inflate.FILE_RECORDS_ENV})"
    )


class RecordCounter:
    """Counts the records of one chunk as its decompressed bytes come out of the
    decompressor (the ``watch`` of :func:`harness.recording.inflate.decompress`), by their
    framing alone; raises :class:`~harness.recording.errors.RecordingLimitError` at the first
    record over the chunk's limit or over the file's (``before``: the records of the file so
    far), so a chunk of millions of records costs no more than the limit to refuse.

    :attr:`starts` is where each record starts in the decompressed chunk (the walk of the
    chunk's records needs no second pass); :meth:`check_end` says whether the last one ends
    with the chunk."""

    def __init__(self, limits: inflate.InflateLimits, before: int) -> None:
        self.count = 0
        self.starts = array("q")
        self._limits = limits
        self._before = before
        self._stop = min(limits.chunk_records, limits.file_records - before)
        self._base = 0  # where the current piece starts in the decompressed chunk
        self._skip = 0  # bytes of the current record's body still to come
        self._head = bytearray()  # a record header split between two pieces

    def __call__(self, piece: bytes | memoryview) -> None:
        size = len(piece)
        base = self._base
        self._base += size
        pos = self._skip
        count = self.count
        if self._head:
            need = 9 - len(self._head)
            self._head += piece[:need]
            if len(self._head) < 9:
                return
            (length,) = U64.unpack_from(self._head, 1)
            self._head.clear()
            pos = need + length
        unpack = RECORD_HEAD.unpack_from
        add = self.starts.append
        stop = self._stop
        while pos + 9 <= size and count < stop:
            _, length = unpack(piece, pos)
            add(base + pos)
            pos += 9 + length
            count += 1
        if pos + 9 <= size:  # one more record: over the limit
            self.count = count + 1
            raise RecordingLimitError(_over_limit(self._limits, self._before, count + 1))
        self.count = count
        if pos < size:
            self.starts.append(base + pos)
            self.count += 1
            self._head += piece[pos:]
            self._skip = 0
            if self.count > stop:
                raise RecordingLimitError(_over_limit(self._limits, self._before, self.count))
        else:
            self._skip = pos - size

    def check_end(self) -> None:
        """Raise :class:`RecordDamage` when the last record overruns the chunk."""
        if self._skip or self._head:
            raise RecordDamage(f"record at {self.starts[-1]} overruns its container")


def charge_records(result: Scan, count: int, limits: inflate.InflateLimits) -> None:
    """Add ``count`` records (of one chunk, or one record of the data section) to
    ``result.records``; raise :class:`~harness.recording.errors.RecordingLimitError` when
    they are over the chunk's limit or take the file over its limit."""
    before = result.records
    result.records += count
    if count > limits.chunk_records or result.records > limits.file_records:
        raise RecordingLimitError(_over_limit(limits, before, count))


def charge_declared(result: Scan, chunk: ChunkHead) -> None:
    """Add what ``chunk`` declares it decompresses to to ``result.declared_bytes``; raise
    :class:`RecordDamage` when the file's chunks declare more than the limit allows."""
    result.declared_bytes += chunk.uncompressed_size
    try:
        inflate.current_limits().charge_file(result.declared_bytes)
    except inflate.InflateError as exc:
        raise RecordDamage(str(exc)) from None


def decode_chunk(body: memoryview, counter: RecordCounter | None = None) -> tuple[ChunkHead, bytes]:
    """The chunk record ``body``'s fields and its records decompressed, their size and CRC
    checked against the chunk's header; raises :class:`RecordDamage` naming what failed.
    ``counter`` counts the records as they are decompressed (and stops it at a limit)."""
    chunk = chunk_head(body)
    data = _decompress(chunk, counter)
    if len(data) != chunk.uncompressed_size:
        raise RecordDamage(
            f"chunk decompresses to {len(data)} bytes, its header says {chunk.uncompressed_size}"
        )
    if chunk.uncompressed_crc and crc32(data) != chunk.uncompressed_crc:
        raise RecordDamage("chunk CRC mismatch")
    return chunk, data


def record_spans(data: bytes | memoryview, start: int = 0) -> Iterator[tuple[int, int, int]]:
    """``(opcode, body_start, body_end)`` of each record in ``data``; raises on overrun."""
    pos, size = start, len(data)
    while pos < size:
        if pos + 9 > size:
            raise RecordDamage(f"record header at {pos} overruns its container")
        opcode, length = RECORD_HEAD.unpack_from(data, pos)
        end = pos + 9 + length
        if end > size:
            raise RecordDamage(f"record at {pos} (opcode {opcode:#x}) overruns its container")
        yield opcode, pos + 9, end
        pos = end


def read_chunk_data(buf: memoryview, chunk: ChunkInfo, opened: Scan | None = None) -> bytes:
    """The decompressed records of ``chunk``. A chunk the opening pass (``opened``) checked
    is not checked again (the file is mapped read-only); one it left in
    :attr:`Scan.unchecked` is checked now (CRC, index entries) and taken off that list; it
    raises :class:`RecordingDamagedError` naming the byte offset when a check fails."""
    body = buf[chunk.offset + 9 : chunk.offset + chunk.length]
    entries = opened.unchecked.get(chunk.offset) if opened is not None else None
    try:
        if entries is None:
            head = chunk_head(body)
            data = _decompress(head)
            if len(data) != head.uncompressed_size:
                raise RecordDamage("chunk decompresses to another size than when opened")
            return data
        _, data = decode_chunk(body)
        if not entries_match(data, entries):
            raise RecordDamage("the chunk's message index disagrees with its records")
    except RecordDamage as exc:
        raise RecordingDamagedError(f"chunk at byte {chunk.offset}: {exc}") from None
    assert opened is not None
    del opened.unchecked[chunk.offset]
    return data


def chunk_messages(
    data: bytes, offsets: I64 | None = None
) -> Iterator[tuple[int, int, int, memoryview]]:
    """``(channel_id, sequence, log_time, data)`` of each message in decompressed chunk
    ``data``: all of them (a walk over every record), or those whose records start at
    ``offsets`` (from :func:`message_offsets`), in that order."""
    view = memoryview(data)
    if offsets is None:
        for opcode, start, end in record_spans(view):
            if opcode == Opcode.MESSAGE:
                channel_id, sequence, log_time, _ = MESSAGE_HEAD.unpack_from(view, start)
                yield channel_id, sequence, log_time, view[start + 22 : end]
        return
    for at in offsets.tolist():
        (length,) = U64.unpack_from(view, at + 1)
        channel_id, sequence, log_time, _ = MESSAGE_HEAD.unpack_from(view, at + 9)
        yield channel_id, sequence, log_time, view[at + MESSAGE_HEADER_SIZE : at + 9 + length]


def message_offsets(data: bytes, channels: set[int] | frozenset[int]) -> dict[int, I64]:
    """Byte offsets of the message records of ``channels`` in decompressed chunk ``data``, by
    channel, found by walking its records (for chunks without a checked message index)."""
    found: dict[int, list[int]] = {c: [] for c in channels}
    view = memoryview(data)
    for opcode, start, _ in record_spans(view):
        if opcode == Opcode.MESSAGE:
            (channel_id,) = struct.unpack_from("<H", view, start)
            if channel_id in found:
                found[channel_id].append(start - 9)
    return {c: np.array(v, dtype=np.int64) for c, v in found.items() if v}


def chunk_index_entries(
    buf: memoryview, limit: int, size: int, index: ChunkIndex, result: Scan
) -> IndexEntries | None:
    """The chunk's message index entries, checked as far as the indexes alone allow (records
    inside the ``size`` bytes of the chunk, distinct, log times never going back); ``None``
    when they are not right."""
    channels: list[int] = []
    tables: list[npt.NDArray[np.uint64]] = []
    for channel_id, at in index.message_index_offsets.items():
        if channel_id not in result.channels or at + 15 > limit:
            return None
        opcode, length = RECORD_HEAD.unpack_from(buf, at)
        channel_in_record, table_size = _MESSAGE_INDEX_HEAD.unpack_from(buf, at + 9)
        if (
            opcode != Opcode.MESSAGE_INDEX
            or at + 9 + length > limit
            or channel_in_record != channel_id
            or table_size % 16
            or 6 + table_size != length
        ):
            return None
        if table_size:
            channels.append(channel_id)
            tables.append(np.frombuffer(buf, dtype="<u8", count=table_size // 8, offset=at + 15))
    if not tables:
        empty = np.empty(0, dtype=np.int64)
        return IndexEntries(empty, empty, np.empty(0, dtype=np.uint16))
    pairs = np.concatenate(tables).reshape(-1, 2)
    if int(pairs[:, 1].max()) + MESSAGE_HEADER_SIZE > size:
        return None
    order = np.argsort(pairs[:, 1], kind="stable")
    where = pairs[order, 1].astype(np.int64)
    times = pairs[order, 0].astype(np.int64)
    sizes = [t.size // 2 for t in tables]
    channel_of = np.repeat(np.array(channels, dtype=np.uint16), sizes)[order]
    if np.any(np.diff(where) <= 0) or np.any(np.diff(times) < 0):
        return None
    return IndexEntries(where, times, channel_of)


def entries_match(data: bytes, entries: IndexEntries) -> bool:
    """Is every index entry a message record of its channel with its log time in ``data``
    (the decompressed chunk), the records inside it?"""
    if entries.where.size == 0:
        return True
    # Each entry's record head: opcode, length, channel, sequence, log time.
    head = np.frombuffer(data, dtype=np.uint8)[entries.where[:, None] + _HEAD_BYTES]
    lengths = np.ascontiguousarray(head[:, 1:9]).view("<u8")[:, 0]
    return not (
        np.any(head[:, 0] != Opcode.MESSAGE)
        or np.any(lengths < 22)
        or np.any(lengths > len(data))
        or np.any(entries.where + 9 + lengths.astype(np.int64) > len(data))
        or np.any(np.ascontiguousarray(head[:, 9:11]).view("<u2")[:, 0] != entries.channels)
        or np.any(np.ascontiguousarray(head[:, 15:23]).view("<i8")[:, 0] != entries.times)
    )


def offsets_by_channel(entries: IndexEntries, result: Scan) -> dict[int, I64]:
    """Record offsets by channel; each channel's time range into ``result``."""
    offsets: dict[int, I64] = {}
    for channel_id in np.unique(entries.channels).tolist():
        mine = entries.channels == channel_id
        offsets[channel_id] = entries.where[mine]
        times = entries.times[mine]
        first = result.time_ranges.get(channel_id, (int(times[0]), 0))[0]
        result.time_ranges[channel_id] = (first, int(times[-1]))
    return offsets


def gather(chunk_bytes: npt.NDArray[np.uint8], at: I64, dtype: str) -> npt.NDArray[Any]:
    """The little-endian values of ``dtype`` starting at byte offsets ``at``."""
    width = np.dtype(dtype).itemsize
    picked = chunk_bytes[at[:, None] + np.arange(width)]
    values: npt.NDArray[Any] = picked.view(dtype)[:, 0]
    return values
