"""One sequential pass over an MCAP file: what it holds, where it is damaged, whether its
summary agrees with its data.

mcap's own readers either trust the summary (and raise on the first bad chunk without an
offset) or stop at the first error without saying where; a recording must open up to its last
good chunk and name the byte offset of the damage. So this module walks the records itself,
parsing each with ``mcap.records`` and checking every CRC (chunk, attachment, data section,
summary).

Two passes give the same :class:`Scan`: :func:`index_scan`, for a complete file (footer,
summary and data-section CRC present and right), takes the messages of each chunk from the
chunk's message indexes (numpy over the decompressed chunk, checked against it) instead of
walking every record in Python; :func:`scan` walks everything and is the one that finds and
names damage. Both decompress and CRC-check every chunk (and keep none of it: reading
decompresses again, which costs less than holding a whole file's chunks in fresh memory);
``index_scan(check_chunks=False)`` leaves that to the first :func:`read_chunk_data` of each
chunk, for readers that read everything once anyway.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from io import BytesIO
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    ChunkIndex,
    Header,
    Metadata,
    Schema,
    Statistics,
)

from harness.recording import inflate
from harness.recording._crc import crc32
from harness.recording.errors import RecordingDamagedError, RecordingFormatError

__all__ = [
    "MAGIC",
    "MESSAGE_HEADER_SIZE",
    "ChunkInfo",
    "IndexEntries",
    "Problem",
    "Scan",
    "Skipped",
    "chunk_messages",
    "entries_match",
    "gather",
    "index_scan",
    "message_offsets",
    "read_chunk_data",
    "scan",
]

MAGIC = b"\x89MCAP0\r\n"
_FOOTER_SIZE = 1 + 8 + 20
_RECORD = struct.Struct("<BQ")
_U64 = struct.Struct("<Q")
_MESSAGE = struct.Struct("<HIQQ")
_MESSAGE_INDEX_HEAD = struct.Struct("<HI")
_HEAD_BYTES = np.arange(23)
_KNOWN = {int(op) for op in Opcode}
# A message record: opcode (1) + length (8) + channel (2) + sequence (4) + log and publish time.
MESSAGE_HEADER_SIZE = 9 + 22

I64 = npt.NDArray[np.int64]


@dataclass(frozen=True, slots=True)
class Problem:
    """Something wrong in the file, at byte ``offset``."""

    offset: int
    message: str

    def __str__(self) -> str:
        return f"byte {self.offset}: {self.message}"


@dataclass(frozen=True, slots=True)
class ChunkInfo:
    """A chunk whose CRC checked out: where it is and what it holds."""

    offset: int
    length: int
    start_time: int
    end_time: int
    channels: frozenset[int]
    messages: int


@dataclass(frozen=True, slots=True)
class AttachmentInfo:
    """An attachment record (its data is read on demand); ``damaged`` says why its bytes
    cannot be trusted ("" when its CRC checked out)."""

    offset: int
    name: str
    media_type: str
    data_offset: int
    data_length: int
    damaged: str = ""


@dataclass(frozen=True, slots=True)
class Skipped:
    """A damaged stretch of the data section passed over, ``[offset, end)``: the messages
    in it are lost; reading went on after it."""

    offset: int
    end: int
    what: str


@dataclass
class Scan:
    """Everything one pass found. ``truncated_at`` is where reading stopped because of damage
    (``None``: the whole data section was readable); ``problems`` lists every defect found."""

    size: int
    header: Header
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    chunks: list[ChunkInfo] = field(default_factory=list)
    counts: dict[int, int] = field(default_factory=dict)
    metadata: list[Metadata] = field(default_factory=list)
    attachments: list[AttachmentInfo] = field(default_factory=list)
    start_time: int = -1
    end_time: int = -1
    problems: list[Problem] = field(default_factory=list)
    truncated_at: int | None = None
    # Damaged chunks (or stretches) passed over: their messages are lost, the rest is read.
    skipped: list[Skipped] = field(default_factory=list)
    data_crc_checked: bool = False
    has_summary: bool = False
    summary_crc_checked: bool = False
    summary_checks: int = 0
    # Chunk offset -> channel id -> byte offsets (ascending) of that channel's message records
    # in the decompressed chunk; filled by index_scan only.
    message_index: dict[int, dict[int, I64]] = field(default_factory=dict)
    indexed: bool = False
    # Channel id -> log time of its first and of its last message.
    time_ranges: dict[int, tuple[int, int]] = field(default_factory=dict)
    # Chunk offset -> index entries of chunks whose contents are still to be checked (CRC,
    # entries against records): index_scan(check_chunks=False) leaves that to the first read.
    unchecked: dict[int, IndexEntries] = field(default_factory=dict)
    # What the chunks read so far declare they decompress to (bounded: harness.recording.inflate).
    declared_bytes: int = 0

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())


class _Damage(Exception):
    pass


def _parse(cls: Any, body: bytes | memoryview) -> Any:
    return cls.read(ReadDataStream(BytesIO(body)))


class _ChunkHead(NamedTuple):
    """A chunk record's fields, its compressed records as a view (no copy)."""

    message_start_time: int
    message_end_time: int
    uncompressed_size: int
    uncompressed_crc: int
    compression: str
    data: memoryview


_CHUNK_HEAD = struct.Struct("<QQQII")


def _chunk_head(body: memoryview) -> _ChunkHead:
    start, end, size, crc, name_length = _CHUNK_HEAD.unpack_from(body, 0)
    at = _CHUNK_HEAD.size + name_length
    compression = str(body[_CHUNK_HEAD.size : at], "utf-8")
    (records_length,) = _U64.unpack_from(body, at)
    if at + 8 + records_length > len(body):
        raise _Damage(f"chunk records ({records_length} bytes) overrun the chunk record")
    return _ChunkHead(start, end, size, crc, compression, body[at + 8 : at + 8 + records_length])


def _decompress(chunk: _ChunkHead) -> bytes:
    try:
        return inflate.decompress(chunk.compression, chunk.data, chunk.uncompressed_size)
    except inflate.InflateError as exc:
        raise _Damage(str(exc)) from None


def _charge(result: Scan, chunk: _ChunkHead) -> None:
    result.declared_bytes += chunk.uncompressed_size
    try:
        inflate.current_limits().charge_file(result.declared_bytes)
    except inflate.InflateError as exc:
        raise _Damage(str(exc)) from None


def _read_chunk(body: memoryview) -> tuple[_ChunkHead, bytes]:
    chunk = _chunk_head(body)
    data = _decompress(chunk)
    if len(data) != chunk.uncompressed_size:
        raise _Damage(
            f"chunk decompresses to {len(data)} bytes, its header says {chunk.uncompressed_size}"
        )
    if chunk.uncompressed_crc and crc32(data) != chunk.uncompressed_crc:
        raise _Damage("chunk CRC mismatch")
    return chunk, data


def _records(data: bytes | memoryview, start: int = 0) -> Iterator[tuple[int, int, int]]:
    """``(opcode, body_start, body_end)`` of each record in ``data``; raises on overrun."""
    pos, size = start, len(data)
    while pos < size:
        if pos + 9 > size:
            raise _Damage(f"record header at {pos} overruns its container")
        opcode, length = _RECORD.unpack_from(data, pos)
        end = pos + 9 + length
        if end > size:
            raise _Damage(f"record at {pos} (opcode {opcode:#x}) overruns its container")
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
            head = _chunk_head(body)
            data = _decompress(head)
            if len(data) != head.uncompressed_size:
                raise _Damage("chunk decompresses to another size than when opened")
            return data
        _, data = _read_chunk(body)
        if not entries_match(data, entries):
            raise _Damage("the chunk's message index disagrees with its records")
    except _Damage as exc:
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
        for opcode, start, end in _records(view):
            if opcode == Opcode.MESSAGE:
                channel_id, sequence, log_time, _ = _MESSAGE.unpack_from(view, start)
                yield channel_id, sequence, log_time, view[start + 22 : end]
        return
    for at in offsets.tolist():
        (length,) = _U64.unpack_from(view, at + 1)
        channel_id, sequence, log_time, _ = _MESSAGE.unpack_from(view, at + 9)
        yield channel_id, sequence, log_time, view[at + MESSAGE_HEADER_SIZE : at + 9 + length]


def message_offsets(data: bytes, channels: set[int] | frozenset[int]) -> dict[int, I64]:
    """Byte offsets of the message records of ``channels`` in decompressed chunk ``data``, by
    channel, found by walking its records (for chunks without a checked message index)."""
    found: dict[int, list[int]] = {c: [] for c in channels}
    view = memoryview(data)
    for opcode, start, _ in _records(view):
        if opcode == Opcode.MESSAGE:
            (channel_id,) = struct.unpack_from("<H", view, start)
            if channel_id in found:
                found[channel_id].append(start - 9)
    return {c: np.array(v, dtype=np.int64) for c, v in found.items() if v}


def _header(buf: memoryview, where: str) -> tuple[Header, int]:
    size = len(buf)
    if size == 0:
        raise RecordingFormatError(f"{where}: empty file (0 bytes), not a recording")
    if size < 8 or bytes(buf[:8]) != MAGIC:
        raise RecordingFormatError(f"{where}: not an MCAP file (no MCAP magic at byte 0)")
    if size < 17 or buf[8] != Opcode.HEADER:
        raise RecordingFormatError(f"{where}: not a readable MCAP file (no header at byte 8)")
    (length,) = _U64.unpack_from(buf, 9)
    if 17 + length > size:
        raise RecordingFormatError(f"{where}: truncated inside the MCAP header (byte 8)")
    try:
        header = _parse(Header, buf[17 : 17 + length])
    except Exception:
        raise RecordingFormatError(f"{where}: corrupt MCAP header at byte 8") from None
    return header, 17 + length


def scan(buf: memoryview, where: str) -> Scan:
    """Walk ``buf`` (a whole MCAP file); raise :class:`RecordingFormatError` only when nothing
    can be read (empty, not MCAP, no header). ``where`` names the file in messages."""
    header, pos = _header(buf, where)
    result = Scan(size=len(buf), header=header)
    data_end = _scan_data(buf, pos, result)
    if data_end is not None:
        _scan_summary(buf, data_end, result)
    return result


def index_scan(buf: memoryview, where: str, *, check_chunks: bool = True) -> Scan | None:
    """The opening pass of a complete file, through its summary and message indexes; ``None``
    when the file is not complete and consistent (then :func:`scan` names what is wrong).

    Checks as much as :func:`scan`: every chunk decompressed and CRC-checked, the data-section
    and summary CRCs (both required here), the summary against the data; and each message
    index against its chunk: every entry is a message record of that channel with that log
    time, and log times never go back. Raises like :func:`scan` when nothing can be read.

    ``check_chunks=False`` leaves what needs a chunk's decompressed bytes (its CRC, its index
    entries against its records) to :func:`read_chunk_data`, the first time the chunk is
    read: :attr:`Scan.unchecked` lists them. The data-section CRC, checked here, already
    covers the compressed bytes and the indexes."""
    header, pos = _header(buf, where)
    size = len(buf)
    footer_pos = size - 8 - _FOOTER_SIZE
    if footer_pos < pos or bytes(buf[size - 8 :]) != MAGIC or buf[footer_pos] != Opcode.FOOTER:
        return None
    summary_start, _, summary_crc = struct.unpack_from("<QQI", buf, footer_pos + 9)
    if not summary_crc or not pos <= summary_start < footer_pos:
        return None
    if crc32(buf[summary_start : size - 12]) != summary_crc:
        return None
    result = Scan(size=size, header=header)
    try:
        indexes = _summary_chunk_indexes(buf[summary_start:footer_pos], result)
        data_end = _index_data(buf, pos, summary_start, indexes, result, check_chunks)
    except Exception:  # any inconsistency at all: the full walk finds it and names it
        return None
    if data_end is None:
        return None
    _scan_summary(buf, data_end, result)
    if result.problems or not result.has_summary:
        return None
    result.indexed = True
    return result


def _summary_chunk_indexes(section: memoryview, result: Scan) -> dict[int, ChunkIndex]:
    """Schemas and channels into ``result``; the chunk indexes by chunk offset."""
    indexes: dict[int, ChunkIndex] = {}
    for opcode, start, end in _records(section):
        if opcode == Opcode.SCHEMA:
            schema = _parse(Schema, section[start:end])
            result.schemas[schema.id] = schema
        elif opcode == Opcode.CHANNEL:
            channel = _parse(Channel, section[start:end])
            result.channels[channel.id] = channel
        elif opcode == Opcode.CHUNK_INDEX:
            index: ChunkIndex = _parse(ChunkIndex, section[start:end])
            indexes[index.chunk_start_offset] = index
    return indexes


def _index_data(
    buf: memoryview,
    pos: int,
    limit: int,
    indexes: dict[int, ChunkIndex],
    result: Scan,
    check_chunks: bool,
) -> int | None:
    """Walk the data section's top-level records (chunks, not their contents) up to
    ``limit``; return the end of the DataEnd record, or ``None`` on anything irregular."""
    last_time = -1
    while True:
        if pos + 9 > limit:
            return None
        opcode, length = _RECORD.unpack_from(buf, pos)
        end = pos + 9 + int(length)
        if end > limit or (opcode not in _KNOWN and opcode < 0x80):
            return None
        body = buf[pos + 9 : end]
        if opcode == Opcode.CHUNK:
            index = indexes.get(pos)
            if index is None or index.chunk_length != end - pos:
                return None
            chunk = _chunk_head(body)
            _charge(result, chunk)
            if (index.message_start_time, index.message_end_time, index.uncompressed_size) != (
                chunk.message_start_time,
                chunk.message_end_time,
                chunk.uncompressed_size,
            ):
                return None
            entries = _chunk_message_index(buf, limit, chunk.uncompressed_size, index, result)
            if entries is None:
                return None
            if check_chunks:
                _, data = _read_chunk(body)
                if not entries_match(data, entries):
                    return None
            else:
                result.unchecked[pos] = entries
            offsets, times = _by_channel(entries, result), entries.times
            messages = sum(o.size for o in offsets.values())
            if messages:
                if (
                    int(times[0]) < last_time
                    or int(times[0]) != chunk.message_start_time
                    or int(times[-1]) != chunk.message_end_time
                ):
                    return None
                last_time = int(times[-1])
                if result.start_time < 0:
                    result.start_time = chunk.message_start_time
                result.end_time = max(result.end_time, chunk.message_end_time)
            for channel_id, o in offsets.items():
                result.counts[channel_id] = result.counts.get(channel_id, 0) + o.size
            info = ChunkInfo(
                pos,
                end - pos,
                chunk.message_start_time,
                chunk.message_end_time,
                frozenset(offsets),
                messages,
            )
            result.chunks.append(info)
            result.message_index[pos] = offsets
        elif opcode == Opcode.DATA_END:
            (crc,) = struct.unpack_from("<I", body, 0)
            if not crc or crc32(buf[:pos]) != crc:
                return None
            result.data_crc_checked = True
            return end
        elif opcode in (Opcode.METADATA, Opcode.ATTACHMENT, Opcode.SCHEMA, Opcode.CHANNEL):
            _data_record(opcode, pos, body, result, last_time)
        elif opcode == Opcode.MESSAGE:
            return None
        pos = end


class IndexEntries(NamedTuple):
    """A chunk's message index entries, in record order: where each record starts in the
    decompressed chunk, its log time, its channel."""

    where: I64
    times: I64
    channels: npt.NDArray[np.uint16]


def _chunk_message_index(
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
        opcode, length = _RECORD.unpack_from(buf, at)
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


def _by_channel(entries: IndexEntries, result: Scan) -> dict[int, I64]:
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


def _scan_data(buf: memoryview, pos: int, result: Scan) -> int | None:
    """Scan the data section from ``pos``; return the end of the DataEnd record, or ``None``.

    A damaged record whose framing is intact (a chunk whose CRC or compression fails, an
    attachment whose CRC fails) costs only itself: it is named and passed over. Damaged
    framing (an invalid opcode, a length past the end) is passed over up to the next chunk
    the summary's chunk index lists, when the file has a summary; otherwise reading stops."""
    size = len(buf)
    last_time = -1
    end: int
    resync: list[int] | None = None  # chunk offsets from the summary, read on first need
    while True:
        if pos >= size:
            result.problems.append(Problem(pos, "truncated: the file ends before its summary"))
            result.truncated_at = pos
            return None
        if pos + 9 > size:
            result.problems.append(Problem(pos, "truncated inside a record header"))
            result.truncated_at = pos
            return None
        opcode, length = _RECORD.unpack_from(buf, pos)
        end = pos + 9 + int(length)
        framing = ""
        if opcode not in _KNOWN and opcode < 0x80:
            framing = f"corrupt: invalid record opcode {opcode:#x}"
        elif end > size:
            name = Opcode(opcode).name.lower() if opcode in _KNOWN else f"{opcode:#x}"
            framing = f"truncated: {name} record of {length} bytes overruns the file"
        if framing:
            if resync is None:
                resync = _summary_chunk_offsets(buf, result)
            following = [o for o in resync if o > pos]
            if not following:
                result.problems.append(Problem(pos, framing))
                result.truncated_at = pos
                return None
            result.problems.append(
                Problem(pos, f"{framing}; skipped to the next indexed chunk at byte {following[0]}")
            )
            result.skipped.append(Skipped(pos, following[0], "damaged records"))
            pos = following[0]
            continue
        body = buf[pos + 9 : end]
        try:
            last_time = _data_record(opcode, pos, body, result, last_time)
        except _Damage as exc:
            what = Opcode(opcode).name.lower()
            result.problems.append(Problem(pos, f"corrupt: {exc}; {what} record skipped"))
            result.skipped.append(Skipped(pos, end, f"{what}: {exc}"))
        except Exception as exc:
            what = Opcode(opcode).name.lower()
            result.problems.append(Problem(pos, f"corrupt {what} record ({exc}); skipped"))
            result.skipped.append(Skipped(pos, end, f"{what}: {exc}"))
        if opcode == Opcode.DATA_END:
            (crc,) = struct.unpack_from("<I", body, 0)
            if crc:
                result.data_crc_checked = True
                if crc32(buf[:pos]) != crc and not result.problems:
                    result.problems.append(Problem(pos, "data section CRC mismatch"))
            return end
        pos = end


def _summary_chunk_offsets(buf: memoryview, result: Scan) -> list[int]:
    """The chunk offsets the summary's chunk indexes list (ascending; empty without a summary
    whose CRC checks out); its schemas and channels go into ``result`` (chunks after a
    damaged one may use channels defined in it)."""
    size = len(buf)
    footer_pos = size - 8 - _FOOTER_SIZE
    if footer_pos < 8 or bytes(buf[size - 8 :]) != MAGIC or buf[footer_pos] != Opcode.FOOTER:
        return []
    summary_start, _, summary_crc = struct.unpack_from("<QQI", buf, footer_pos + 9)
    if not summary_start or not 8 <= summary_start < footer_pos:
        return []
    if summary_crc and crc32(buf[summary_start : size - 12]) != summary_crc:
        return []
    hint = Scan(size=size, header=result.header)
    try:
        indexes = _summary_chunk_indexes(buf[summary_start:footer_pos], hint)
    except Exception:
        return []
    for key, schema in hint.schemas.items():
        result.schemas.setdefault(key, schema)
    for key, channel in hint.channels.items():
        result.channels.setdefault(key, channel)
    return sorted(indexes)


def _data_record(opcode: int, pos: int, body: memoryview, result: Scan, last_time: int) -> int:
    """Take in one data-section record; return the log time of the last message seen."""
    if opcode == Opcode.CHUNK:
        _charge(result, _chunk_head(body))
        chunk, data = _read_chunk(body)
        channels: set[int] = set()
        messages = 0
        view = memoryview(data)
        for inner, start, end in _records(view):
            if inner == Opcode.SCHEMA:
                schema = _parse(Schema, view[start:end])
                result.schemas[schema.id] = schema
            elif inner == Opcode.CHANNEL:
                channel = _parse(Channel, view[start:end])
                result.channels[channel.id] = channel
            elif inner == Opcode.MESSAGE:
                channel_id, _, log_time, _ = _MESSAGE.unpack_from(view, start)
                log_time = int(log_time)
                if channel_id not in result.channels:
                    raise _Damage(f"message on unknown channel {channel_id}")
                if log_time < last_time:
                    result.problems.append(
                        Problem(pos, f"log time {log_time} goes back (after {last_time})")
                    )
                last_time = log_time
                channels.add(channel_id)
                messages += 1
                result.counts[channel_id] = result.counts.get(channel_id, 0) + 1
                first = result.time_ranges.get(channel_id, (log_time, 0))[0]
                result.time_ranges[channel_id] = (first, log_time)
        if messages:
            if result.start_time < 0:
                result.start_time = chunk.message_start_time
            result.end_time = max(result.end_time, chunk.message_end_time)
        info = ChunkInfo(
            pos,
            9 + len(body),
            chunk.message_start_time,
            chunk.message_end_time,
            frozenset(channels),
            messages,
        )
        result.chunks.append(info)
    elif opcode == Opcode.METADATA:
        result.metadata.append(_parse(Metadata, body))
    elif opcode == Opcode.ATTACHMENT:
        attachment = _attachment(pos, body)
        result.attachments.append(attachment)
        if attachment.damaged:
            result.problems.append(Problem(pos, f"corrupt: {attachment.damaged}"))
    elif opcode == Opcode.SCHEMA:
        schema = _parse(Schema, body)
        result.schemas[schema.id] = schema
    elif opcode == Opcode.CHANNEL:
        channel = _parse(Channel, body)
        result.channels[channel.id] = channel
    elif opcode == Opcode.MESSAGE:
        raise _Damage("unchunked message records are not written by the harness")
    return last_time


def _attachment(pos: int, body: memoryview) -> AttachmentInfo:
    stream = ReadDataStream(BytesIO(body))
    stream.read8()  # log_time
    stream.read8()  # create_time
    name = stream.read_prefixed_string()
    media_type = stream.read_prefixed_string()
    data_length = stream.read8()
    data_offset = stream.count
    if data_offset + data_length + 4 != len(body):
        raise _Damage(f"attachment {name!r} has an inconsistent length")
    (crc,) = struct.unpack_from("<I", body, data_offset + data_length)
    damaged = ""
    if crc and crc32(body[: data_offset + data_length]) != crc:
        damaged = f"attachment {name!r} CRC mismatch"
    return AttachmentInfo(pos, name, media_type, pos + 9 + data_offset, data_length, damaged)


def _scan_summary(buf: memoryview, data_end: int, result: Scan) -> None:
    size = len(buf)
    footer_pos = size - 8 - _FOOTER_SIZE
    if footer_pos < data_end or bytes(buf[size - 8 :]) != MAGIC or buf[footer_pos] != Opcode.FOOTER:
        result.problems.append(
            Problem(
                data_end, "truncated after the data section: no valid footer (all messages intact)"
            )
        )
        return
    summary_start, _summary_offset_start, summary_crc = struct.unpack_from(
        "<QQI", buf, footer_pos + 9
    )
    region_start = summary_start or footer_pos
    if not data_end <= region_start <= footer_pos:
        result.problems.append(Problem(footer_pos, "footer points outside the summary section"))
        return
    if summary_crc:
        result.summary_crc_checked = True
        if crc32(buf[region_start : size - 12]) != summary_crc:
            result.problems.append(Problem(region_start, "summary CRC mismatch"))
            return
    if not summary_start:
        return
    result.has_summary = True
    try:
        _check_summary(buf[summary_start:footer_pos], summary_start, result)
    except (_Damage, Exception) as exc:
        result.problems.append(Problem(summary_start, f"corrupt summary section ({exc})"))


def _check_summary(section: memoryview, base: int, result: Scan) -> None:
    stats: Statistics | None = None
    chunk_offsets: set[tuple[int, int]] = set()
    channels: dict[int, Channel] = {}
    attachment_offsets: set[int] = set()
    metadata_offsets: set[int] = set()
    for opcode, start, end in _records(section):
        body = section[start:end]
        if opcode == Opcode.STATISTICS:
            stats = _parse(Statistics, body)
        elif opcode == Opcode.CHUNK_INDEX:
            index: ChunkIndex = _parse(ChunkIndex, body)
            chunk_offsets.add((index.chunk_start_offset, index.chunk_length))
        elif opcode == Opcode.CHANNEL:
            channel = _parse(Channel, body)
            channels[channel.id] = channel
        elif opcode == Opcode.ATTACHMENT_INDEX:
            (offset,) = _U64.unpack_from(body, 0)
            attachment_offsets.add(offset)
        elif opcode == Opcode.METADATA_INDEX:
            (offset,) = _U64.unpack_from(body, 0)
            metadata_offsets.add(offset)

    def check(ok: bool, what: str) -> None:
        result.summary_checks += 1
        if not ok:
            result.problems.append(Problem(base, f"summary disagrees with the data: {what}"))

    scanned_chunks = {(c.offset, c.length) for c in result.chunks}
    if result.skipped:
        # Damaged chunks were passed over: what was read must be indexed; the counts of the
        # whole file cannot match what is left.
        check(scanned_chunks <= chunk_offsets, "chunk indexes")
        return
    check(chunk_offsets == scanned_chunks, "chunk indexes")
    check(
        {k: (c.topic, c.schema_id) for k, c in channels.items()}
        == {k: (c.topic, c.schema_id) for k, c in result.channels.items()},
        "channels",
    )
    check(attachment_offsets == {a.offset for a in result.attachments}, "attachment indexes")
    check(len(metadata_offsets) == len(result.metadata), "metadata indexes")
    if stats is None:
        check(False, "statistics record missing")
        return
    check(stats.message_count == result.message_count, "message count")
    check(dict(stats.channel_message_counts) == result.counts, "per-channel message counts")
    check(stats.chunk_count == len(result.chunks), "chunk count")
    check(stats.attachment_count == len(result.attachments), "attachment count")
    check(stats.metadata_count == len(result.metadata), "metadata count")
    if result.message_count:
        check(
            (stats.message_start_time, stats.message_end_time)
            == (result.start_time, result.end_time),
            "message time range",
        )
