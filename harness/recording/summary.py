"""The summary section of an MCAP file: read for its chunk indexes, checked against the data.

The opening pass through the indexes starts from :func:`summary_chunk_indexes`; the full walk
of :mod:`harness.recording.scan` resynchronises on damaged framing at the chunks
:func:`summary_chunk_offsets` lists, and :func:`check_summary` checks the footer, the summary
CRC and every count and index of the summary against what the data section held, naming each
disagreement as a :class:`~harness.recording.scanned.Problem`.
"""

from __future__ import annotations

import struct

from mcap.opcode import Opcode
from mcap.records import Channel, ChunkIndex, MetadataIndex, Statistics

from harness.recording._crc import crc32
from harness.recording.chunks import (
    MAGIC,
    U64,
    RecordDamage,
    parse_record,
    record_spans,
    take_definition,
)
from harness.recording.scanned import Problem, Scan

__all__ = [
    "FOOTER_SIZE",
    "check_summary",
    "summary_chunk_indexes",
    "summary_chunk_offsets",
    "summary_metadata_names",
]

FOOTER_SIZE = 1 + 8 + 20
"""A footer record: opcode, length, summary start, summary offset start, summary CRC."""


def summary_chunk_indexes(section: memoryview, result: Scan) -> dict[int, ChunkIndex]:
    """Schemas and channels into ``result``; the chunk indexes by chunk offset."""
    indexes: dict[int, ChunkIndex] = {}
    for opcode, start, end in record_spans(section):
        if opcode == Opcode.CHUNK_INDEX:
            index: ChunkIndex = parse_record(ChunkIndex, section[start:end])
            indexes[index.chunk_start_offset] = index
        else:
            take_definition(result, opcode, section[start:end])
    return indexes


def _summary_section(buf: memoryview) -> memoryview | None:
    """The summary section (without the footer), when the file ends in a footer that points
    at one whose CRC checks out."""
    size = len(buf)
    footer_pos = size - 8 - FOOTER_SIZE
    if footer_pos < 8 or bytes(buf[size - 8 :]) != MAGIC or buf[footer_pos] != Opcode.FOOTER:
        return None
    summary_start, _, summary_crc = struct.unpack_from("<QQI", buf, footer_pos + 9)
    if not summary_start or not 8 <= summary_start < footer_pos:
        return None
    if summary_crc and crc32(buf[summary_start : size - 12]) != summary_crc:
        return None
    return buf[summary_start:footer_pos]


def summary_metadata_names(buf: memoryview) -> frozenset[str] | None:
    """The names of the metadata records the summary's metadata indexes list; ``None``
    without a summary whose CRC checks out (or one that cannot be read)."""
    section = _summary_section(buf)
    if section is None:
        return None
    names: set[str] = set()
    try:
        for opcode, start, end in record_spans(section):
            if opcode == Opcode.METADATA_INDEX:
                names.add(parse_record(MetadataIndex, section[start:end]).name)
    except Exception:
        return None
    return frozenset(names)


def summary_chunk_offsets(buf: memoryview, result: Scan) -> list[int]:
    """The chunk offsets the summary's chunk indexes list (ascending; empty without a summary
    whose CRC checks out); its schemas and channels go into ``result`` (chunks after a
    damaged one may use channels defined in it)."""
    section = _summary_section(buf)
    if section is None:
        return []
    hint = Scan(size=len(buf), header=result.header)
    try:
        indexes = summary_chunk_indexes(section, hint)
    except Exception:
        return []
    for key, schema in hint.schemas.items():
        result.schemas.setdefault(key, schema)
    for key, channel in hint.channels.items():
        result.channels.setdefault(key, channel)
    return sorted(indexes)


def check_summary(buf: memoryview, data_end: int, result: Scan) -> None:
    size = len(buf)
    footer_pos = size - 8 - FOOTER_SIZE
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
        _compare_summary(buf[summary_start:footer_pos], summary_start, result)
    except (RecordDamage, Exception) as exc:
        result.problems.append(Problem(summary_start, f"corrupt summary section ({exc})"))


def _compare_summary(section: memoryview, base: int, result: Scan) -> None:
    stats: Statistics | None = None
    chunk_offsets: set[tuple[int, int]] = set()
    channels: dict[int, Channel] = {}
    attachment_offsets: set[int] = set()
    metadata_offsets: set[int] = set()
    for opcode, start, end in record_spans(section):
        body = section[start:end]
        if opcode == Opcode.STATISTICS:
            stats = parse_record(Statistics, body)
        elif opcode == Opcode.CHUNK_INDEX:
            index: ChunkIndex = parse_record(ChunkIndex, body)
            chunk_offsets.add((index.chunk_start_offset, index.chunk_length))
        elif opcode == Opcode.CHANNEL:
            channel = parse_record(Channel, body)
            channels[channel.id] = channel
        elif opcode == Opcode.ATTACHMENT_INDEX:
            (offset,) = U64.unpack_from(body, 0)
            attachment_offsets.add(offset)
        elif opcode == Opcode.METADATA_INDEX:
            (offset,) = U64.unpack_from(body, 0)
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
