"""One sequential pass over an MCAP file: what it holds, where it is damaged, whether its
summary agrees with its data.

mcap's own readers either trust the summary (and raise on the first bad chunk without an
offset) or stop at the first error without saying where; a recording must open up to its last
good chunk and name the byte offset of the damage. So this module walks the records itself,
parsing each with ``mcap.records`` and checking every CRC (chunk, attachment, data section,
summary).
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from io import BytesIO
from typing import Any

import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    Header,
    Metadata,
    Schema,
    Statistics,
)

from harness.recording.errors import RecordingFormatError

__all__ = ["MAGIC", "ChunkInfo", "Problem", "Scan", "chunk_messages", "scan"]

MAGIC = b"\x89MCAP0\r\n"
_FOOTER_SIZE = 1 + 8 + 20
_RECORD = struct.Struct("<BQ")
_U64 = struct.Struct("<Q")
_MESSAGE = struct.Struct("<HIQQ")
_KNOWN = {int(op) for op in Opcode}


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
    """An attachment record (its data is read on demand)."""

    offset: int
    name: str
    media_type: str
    data_offset: int
    data_length: int


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
    data_crc_checked: bool = False
    has_summary: bool = False
    summary_crc_checked: bool = False
    summary_checks: int = 0

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())


class _Damage(Exception):
    pass


def _parse(cls: Any, body: bytes | memoryview) -> Any:
    return cls.read(ReadDataStream(BytesIO(body)))


def _decompress(chunk: Chunk) -> bytes:
    if chunk.compression == "zstd":
        try:
            return zstandard.ZstdDecompressor().decompress(
                chunk.data, max_output_size=chunk.uncompressed_size
            )
        except zstandard.ZstdError as exc:
            raise _Damage(f"zstd chunk does not decompress ({exc})") from None
    if chunk.compression == "lz4":
        import lz4.frame  # type: ignore[import-untyped]

        try:
            return bytes(lz4.frame.decompress(chunk.data))
        except RuntimeError as exc:
            raise _Damage(f"lz4 chunk does not decompress ({exc})") from None
    if chunk.compression == "":
        return bytes(chunk.data)
    raise _Damage(f"unsupported chunk compression {chunk.compression!r}")


def _read_chunk(body: memoryview) -> tuple[Chunk, bytes]:
    chunk = _parse(Chunk, body)
    data = _decompress(chunk)
    if len(data) != chunk.uncompressed_size:
        raise _Damage(
            f"chunk decompresses to {len(data)} bytes, its header says {chunk.uncompressed_size}"
        )
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
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


def chunk_messages(buf: memoryview, chunk: ChunkInfo) -> Iterator[tuple[int, int, int, memoryview]]:
    """``(channel_id, sequence, log_time, data)`` of each message in a (verified) chunk."""
    _, data = _read_chunk(buf[chunk.offset + 9 : chunk.offset + chunk.length])
    view = memoryview(data)
    for opcode, start, end in _records(view):
        if opcode == Opcode.MESSAGE:
            channel_id, sequence, log_time, _ = _MESSAGE.unpack_from(view, start)
            yield channel_id, sequence, log_time, view[start + 22 : end]


def scan(buf: memoryview, where: str) -> Scan:
    """Walk ``buf`` (a whole MCAP file); raise :class:`RecordingFormatError` only when nothing
    can be read (empty, not MCAP, no header). ``where`` names the file in messages."""
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
    result = Scan(size=size, header=header)
    pos = 17 + length
    data_end = _scan_data(buf, pos, result)
    if data_end is not None:
        _scan_summary(buf, data_end, result)
    return result


def _scan_data(buf: memoryview, pos: int, result: Scan) -> int | None:
    """Scan the data section from ``pos``; return the end of the DataEnd record, or ``None``."""
    size = len(buf)
    last_time = -1
    end: int
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
        if opcode not in _KNOWN and opcode < 0x80:
            result.problems.append(Problem(pos, f"corrupt: invalid record opcode {opcode:#x}"))
            result.truncated_at = pos
            return None
        if end > size:
            name = Opcode(opcode).name.lower() if opcode in _KNOWN else f"{opcode:#x}"
            result.problems.append(
                Problem(pos, f"truncated: {name} record of {length} bytes overruns the file")
            )
            result.truncated_at = pos
            return None
        body = buf[pos + 9 : end]
        try:
            last_time = _data_record(opcode, pos, body, result, last_time)
        except _Damage as exc:
            result.problems.append(Problem(pos, f"corrupt: {exc}"))
            result.truncated_at = pos
            return None
        except Exception as exc:
            name = Opcode(opcode).name.lower()
            result.problems.append(Problem(pos, f"corrupt {name} record ({exc})"))
            result.truncated_at = pos
            return None
        if opcode == Opcode.DATA_END:
            (crc,) = struct.unpack_from("<I", body, 0)
            if crc:
                result.data_crc_checked = True
                if zlib.crc32(buf[:pos]) != crc:
                    result.problems.append(Problem(pos, "data section CRC mismatch"))
            return end
        pos = end


def _data_record(opcode: int, pos: int, body: memoryview, result: Scan, last_time: int) -> int:
    """Take in one data-section record; return the log time of the last message seen."""
    if opcode == Opcode.CHUNK:
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
        if messages:
            if result.start_time < 0:
                result.start_time = chunk.message_start_time
            result.end_time = max(result.end_time, chunk.message_end_time)
        result.chunks.append(
            ChunkInfo(
                pos,
                9 + len(body),
                chunk.message_start_time,
                chunk.message_end_time,
                frozenset(channels),
                messages,
            )
        )
    elif opcode == Opcode.METADATA:
        result.metadata.append(_parse(Metadata, body))
    elif opcode == Opcode.ATTACHMENT:
        result.attachments.append(_attachment(pos, body))
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
    if crc and zlib.crc32(body[: data_offset + data_length]) != crc:
        raise _Damage(f"attachment {name!r} CRC mismatch")
    return AttachmentInfo(pos, name, media_type, pos + 9 + data_offset, data_length)


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
        if zlib.crc32(buf[region_start : size - 12]) != summary_crc:
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
