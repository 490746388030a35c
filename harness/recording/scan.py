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
names damage (the framing of a chunk's records is walked once, as it decompresses, by the
counter of the record limits; its messages are then taken in all at once, with numpy).
Both decompress and CRC-check every chunk (and keep none of it: reading decompresses again,
which costs less than holding a whole file's chunks in fresh memory);
``index_scan(check_chunks=False)`` leaves that to the first :func:`read_chunk_data` of each
chunk, for readers that read everything once anyway.

Neither pass costs more than the file's limits allow (:mod:`harness.recording.inflate`): bytes
decompressed, and records walked, per chunk and per file; a file over a record limit is
refused (:class:`~harness.recording.errors.RecordingLimitError`) at the first record over
it. A reader that wants only some files (:class:`Expected`: a profile, a metadata record) has
the others refused before their first chunk is decompressed.

This module holds the two passes; what they find is in :mod:`harness.recording.scanned`, the
chunks are decoded and checked in :mod:`harness.recording.chunks` and the summary section is
read and checked against the data in :mod:`harness.recording.summary`.
"""

from __future__ import annotations

import struct
from io import BytesIO
from typing import NamedTuple

import numpy as np
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import ChunkIndex, Header, Metadata

from harness.recording import inflate
from harness.recording._crc import crc32
from harness.recording.chunks import (
    MAGIC,
    MESSAGE_HEADER_SIZE,
    RECORD_HEAD,
    U64,
    RecordCounter,
    RecordDamage,
    charge_declared,
    charge_records,
    chunk_head,
    chunk_index_entries,
    chunk_messages,
    decode_chunk,
    entries_match,
    gather,
    message_offsets,
    offsets_by_channel,
    parse_record,
    read_chunk_data,
    take_definition,
)
from harness.recording.errors import RecordingFormatError, RecordingLimitError
from harness.recording.scanned import (
    I64,
    AttachmentInfo,
    ChunkInfo,
    IndexEntries,
    Problem,
    Scan,
    Skipped,
)
from harness.recording.summary import (
    FOOTER_SIZE,
    check_summary,
    summary_chunk_indexes,
    summary_chunk_offsets,
    summary_metadata_names,
)

# The two passes, and (from scanned, chunks) the names readers have imported from here.
__all__ = [
    "MAGIC",
    "MESSAGE_HEADER_SIZE",
    "ChunkInfo",
    "Expected",
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

_KNOWN = {int(op) for op in Opcode}


class Expected(NamedTuple):
    """What a file must be for a pass to walk it: the profile its header names, and a
    metadata record of this name: listed by the summary's metadata indexes, or (a file
    without a summary, e.g. a killed recorder's) before its first chunk, where the recorder
    writes it. Anything else raises :class:`RecordingFormatError` before a chunk is
    decompressed. (A summary that indexes no metadata at all decides nothing: such a file is
    walked, within the limits, and judged after.)"""

    profile: str
    metadata: str

    def check_header(self, header: Header, where: str) -> None:
        """Raise when ``header`` names another profile."""
        if header.profile != self.profile:
            raise RecordingFormatError(
                f"{where}: MCAP profile is {header.profile!r}, not {self.profile!r}: "
                "not a harness recording"
            )

    def metadata_first(self, buf: memoryview, where: str) -> bool:
        """Must the metadata record come before the first chunk? Raises when the summary
        lists metadata records, none of this name."""
        names = summary_metadata_names(buf)
        if names is None:
            return True
        if names and self.metadata not in names:
            raise RecordingFormatError(
                f"{where}: no {self.metadata!r} metadata record (the summary indexes "
                f"{', '.join(repr(n) for n in sorted(names)[:5])}): not a harness recording"
            )
        return False

    def check_metadata(self, result: Scan, pos: int, where: str) -> None:
        """Raise when no metadata record of :attr:`metadata` came before byte ``pos``, the
        first chunk (or message) of the file."""
        if not any(m.name == self.metadata for m in result.metadata):
            raise RecordingFormatError(
                f"{where}: no {self.metadata!r} metadata record before the first chunk "
                f"(byte {pos}): not a harness recording"
            )


class _Walk(NamedTuple):
    """What a pass needs besides the file: its name, the limits, what it must be, and
    whether ``expect``'s metadata record must come before the first chunk."""

    where: str
    limits: inflate.InflateLimits
    expect: Expected | None
    metadata_first: bool


def _walk(buf: memoryview, where: str, header: Header, expect: Expected | None) -> _Walk:
    """What a pass of ``buf`` needs; raises when it is not what ``expect`` says, as far as
    its header and summary tell."""
    if expect is None:
        return _Walk(where, _limits(where), None, False)
    expect.check_header(header, where)
    return _Walk(where, _limits(where), expect, expect.metadata_first(buf, where))


def _header(buf: memoryview, where: str) -> tuple[Header, int]:
    size = len(buf)
    if size == 0:
        raise RecordingFormatError(f"{where}: empty file (0 bytes), not a recording")
    if size < 8 or bytes(buf[:8]) != MAGIC:
        raise RecordingFormatError(f"{where}: not an MCAP file (no MCAP magic at byte 0)")
    if size < 17 or buf[8] != Opcode.HEADER:
        raise RecordingFormatError(f"{where}: not a readable MCAP file (no header at byte 8)")
    (length,) = U64.unpack_from(buf, 9)
    if 17 + length > size:
        raise RecordingFormatError(f"{where}: truncated inside the MCAP header (byte 8)")
    try:
        header = parse_record(Header, buf[17 : 17 + length])
    except Exception:
        raise RecordingFormatError(f"{where}: corrupt MCAP header at byte 8") from None
    return header, 17 + length


def _limits(where: str) -> inflate.InflateLimits:
    try:
        return inflate.current_limits()
    except inflate.InflateError as exc:
        raise RecordingFormatError(f"{where}: {exc}") from None


def scan(buf: memoryview, where: str, *, expect: Expected | None = None) -> Scan:
    """Walk ``buf`` (a whole MCAP file); raise :class:`RecordingFormatError` only when nothing
    can be read (empty, not MCAP, no header), when the file is not what ``expect`` says
    (checked before the first chunk), and (:class:`RecordingLimitError`) at the first
    record over a limit of :mod:`harness.recording.inflate`. ``where`` names the file in
    messages."""
    header, pos = _header(buf, where)
    walk = _walk(buf, where, header, expect)
    result = Scan(size=len(buf), header=header)
    data_end = _scan_data(buf, pos, result, walk)
    if result.time_back > 1:
        first = result.problems[result.time_back_problem]
        result.problems[result.time_back_problem] = Problem(
            first.offset,
            f"{first.message}, and {result.time_back - 1} more messages go back in time",
        )
    if data_end is not None:
        check_summary(buf, data_end, result)
    return result


def index_scan(
    buf: memoryview, where: str, *, check_chunks: bool = True, expect: Expected | None = None
) -> Scan | None:
    """The opening pass of a complete file, through its summary and message indexes; ``None``
    when the file is not complete and consistent (then :func:`scan` names what is wrong).

    Checks as much as :func:`scan`: every chunk decompressed and CRC-checked, the data-section
    and summary CRCs (both required here), the summary against the data; and each message
    index against its chunk: every entry is a message record of that channel with that log
    time, and log times never go back. Raises like :func:`scan` when nothing can be read.

    ``check_chunks=False`` leaves what needs a chunk's decompressed bytes (its CRC, its index
    entries against its records) to :func:`read_chunk_data`, the first time the chunk is
    read: :attr:`Scan.unchecked` lists them. The data-section CRC, checked here, already
    covers the compressed bytes and the indexes.

    Refuses like :func:`scan`: a file that is not what ``expect`` says, before its first
    chunk; a chunk whose message index lists more messages than a limit allows."""
    header, pos = _header(buf, where)
    walk = _walk(buf, where, header, expect)
    size = len(buf)
    footer_pos = size - 8 - FOOTER_SIZE
    if footer_pos < pos or bytes(buf[size - 8 :]) != MAGIC or buf[footer_pos] != Opcode.FOOTER:
        return None
    summary_start, _, summary_crc = struct.unpack_from("<QQI", buf, footer_pos + 9)
    if not summary_crc or not pos <= summary_start < footer_pos:
        return None
    if crc32(buf[summary_start : size - 12]) != summary_crc:
        return None
    result = Scan(size=size, header=header)
    try:
        indexes = summary_chunk_indexes(buf[summary_start:footer_pos], result)
        data_end = _index_data(buf, pos, summary_start, indexes, result, check_chunks, walk)
    except RecordingFormatError:  # a refusal, not an inconsistency
        raise
    except Exception:  # any inconsistency at all: the full walk finds it and names it
        return None
    if data_end is None:
        return None
    check_summary(buf, data_end, result)
    if result.problems or not result.has_summary:
        return None
    result.indexed = True
    return result


def _index_data(
    buf: memoryview,
    pos: int,
    limit: int,
    indexes: dict[int, ChunkIndex],
    result: Scan,
    check_chunks: bool,
    walk: _Walk,
) -> int | None:
    """Walk the data section's top-level records (chunks, not their contents) up to
    ``limit``; return the end of the DataEnd record, or ``None`` on anything irregular."""
    last_time = -1
    admitted = not walk.metadata_first
    while True:
        if pos + 9 > limit:
            return None
        opcode, length = RECORD_HEAD.unpack_from(buf, pos)
        end = pos + 9 + int(length)
        if end > limit or (opcode not in _KNOWN and opcode < 0x80):
            return None
        body = buf[pos + 9 : end]
        if not admitted and opcode in (Opcode.CHUNK, Opcode.MESSAGE):
            assert walk.expect is not None
            walk.expect.check_metadata(result, pos, walk.where)
            admitted = True
        _charge(result, 1, walk, pos, "record")
        if opcode == Opcode.CHUNK:
            index = indexes.get(pos)
            if index is None or index.chunk_length != end - pos:
                return None
            chunk = chunk_head(body)
            charge_declared(result, chunk)
            if (index.message_start_time, index.message_end_time, index.uncompressed_size) != (
                chunk.message_start_time,
                chunk.message_end_time,
                chunk.uncompressed_size,
            ):
                return None
            entries = chunk_index_entries(buf, limit, chunk.uncompressed_size, index, result)
            if entries is None:
                return None
            _charge(result, int(entries.where.size), walk, pos, "chunk")
            if check_chunks:
                _, data = decode_chunk(body)
                if not entries_match(data, entries):
                    return None
            else:
                result.unchecked[pos] = entries
            offsets, times = offsets_by_channel(entries, result), entries.times
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
            _data_record(opcode, pos, body, result, last_time, walk.limits)
        elif opcode == Opcode.MESSAGE:
            return None
        pos = end


def _charge(result: Scan, count: int, walk: _Walk, pos: int, what: str) -> None:
    """:func:`charge_records`, its refusal naming the file and the record at ``pos``."""
    try:
        charge_records(result, count, walk.limits)
    except RecordingLimitError as exc:
        raise RecordingLimitError(f"{walk.where}: {what} at byte {pos} {exc}") from None


def _scan_data(buf: memoryview, pos: int, result: Scan, walk: _Walk) -> int | None:
    """Scan the data section from ``pos``; return the end of the DataEnd record, or ``None``.

    A damaged record whose framing is intact (a chunk whose CRC or compression fails, an
    attachment whose CRC fails) costs only itself: it is named and passed over. Damaged
    framing (an invalid opcode, a length past the end) is passed over up to the next chunk
    the summary's chunk index lists, when the file has a summary; otherwise reading stops."""
    size = len(buf)
    last_time = -1
    end: int
    resync: list[int] | None = None  # chunk offsets from the summary, read on first need
    admitted = not walk.metadata_first
    while True:
        if pos >= size:
            result.problems.append(Problem(pos, "truncated: the file ends before its summary"))
            result.truncated_at = pos
            return None
        if pos + 9 > size:
            result.problems.append(Problem(pos, "truncated inside a record header"))
            result.truncated_at = pos
            return None
        opcode, length = RECORD_HEAD.unpack_from(buf, pos)
        end = pos + 9 + int(length)
        framing = ""
        if opcode not in _KNOWN and opcode < 0x80:
            framing = f"corrupt: invalid record opcode {opcode:#x}"
        elif end > size:
            name = Opcode(opcode).name.lower() if opcode in _KNOWN else f"{opcode:#x}"
            framing = f"truncated: {name} record of {length} bytes overruns the file"
        if framing:
            if resync is None:
                resync = summary_chunk_offsets(buf, result)
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
        if not admitted and opcode in (Opcode.CHUNK, Opcode.MESSAGE):
            assert walk.expect is not None
            walk.expect.check_metadata(result, pos, walk.where)
            admitted = True
        _charge(result, 1, walk, pos, "record")
        try:
            last_time = _data_record(opcode, pos, body, result, last_time, walk.limits)
        except RecordingLimitError as exc:
            raise RecordingLimitError(f"{walk.where}: chunk at byte {pos} {exc}") from None
        except RecordDamage as exc:
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


def _data_record(
    opcode: int,
    pos: int,
    body: memoryview,
    result: Scan,
    last_time: int,
    limits: inflate.InflateLimits,
) -> int:
    """Take in one data-section record; return the log time of the last message seen."""
    if opcode == Opcode.CHUNK:
        charge_declared(result, chunk_head(body))
        counter = RecordCounter(limits, result.records)
        try:
            chunk, data = decode_chunk(body, counter)
        finally:
            result.records += counter.count
        counter.check_end()
        starts = np.frombuffer(counter.starts, dtype=np.int64)
        channels, messages, last_time = _chunk_records(result, pos, data, starts, last_time)
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
        result.metadata.append(parse_record(Metadata, body))
    elif opcode == Opcode.ATTACHMENT:
        attachment = _attachment(pos, body)
        result.attachments.append(attachment)
        if attachment.damaged:
            result.problems.append(Problem(pos, f"corrupt: {attachment.damaged}"))
    elif opcode == Opcode.MESSAGE:
        raise RecordDamage("unchunked message records are not written by the harness")
    else:
        take_definition(result, opcode, body)
    return last_time


def _chunk_records(
    result: Scan, pos: int, data: bytes, starts: I64, last_time: int
) -> tuple[set[int], int, int]:
    """Take in the records of the chunk at ``pos`` (decompressed ``data``, its records
    starting at ``starts``): definitions in order, then its messages all at once (numpy);
    return the channels of its messages, how many there are and the last one's log time.
    Raises :class:`RecordDamage` for a message on a channel not defined before it, or one
    shorter than a message's header."""
    if not starts.size:
        return set(), 0, last_time
    view = np.frombuffer(data, dtype=np.uint8)
    opcodes = view[starts]
    lengths = gather(view, starts + 1, "<u8")
    known = set(result.channels)
    saved = dict(result.schemas), dict(result.channels)
    definitions = np.flatnonzero((opcodes == Opcode.SCHEMA) | (opcodes == Opcode.CHANNEL))
    defined_at: dict[int, int] = {}
    for i in definitions.tolist():
        start = int(starts[i]) + 9
        before = set(result.channels)
        take_definition(result, int(opcodes[i]), data[start : start + int(lengths[i])])
        for channel_id in result.channels.keys() - before:
            defined_at.setdefault(channel_id, start)

    def damaged(at: int, why: str) -> RecordDamage:
        # As a walk in record order would leave it: the definitions before ``at`` taken in.
        result.schemas, result.channels = saved
        for i in definitions[starts[definitions] < at].tolist():
            start = int(starts[i]) + 9
            take_definition(result, int(opcodes[i]), data[start : start + int(lengths[i])])
        return RecordDamage(why)

    is_message = opcodes == Opcode.MESSAGE
    at = starts[is_message]
    if not at.size:
        return set(), 0, last_time
    short = np.flatnonzero(lengths[is_message] < MESSAGE_HEADER_SIZE - 9)
    if short.size:
        where = int(at[short[0]])
        raise damaged(where, f"message record at {where} is shorter than its header")
    channel_ids = gather(view, at + 9, "<u2").astype(np.int64)
    times = gather(view, at + 15, "<u8")
    found, first, count = np.unique(channel_ids, return_index=True, return_counts=True)
    unknown = [
        (i, channel_id)
        for channel_id, i in zip(found.tolist(), first.tolist(), strict=True)
        if channel_id not in known and defined_at.get(channel_id, len(data)) > int(at[i])
    ]
    if unknown:  # the first in the chunk (a later definition does not make it known)
        i, channel_id = min(unknown)
        raise damaged(int(at[i]), f"message on unknown channel {channel_id}")
    previous = np.empty_like(times)
    previous[0] = max(last_time, 0)
    previous[1:] = times[:-1]
    back = np.flatnonzero(times < previous)
    if back.size:
        if not result.time_back:  # the first only: scan() adds how many in all
            i = int(back[0])
            after = last_time if i == 0 else int(times[i - 1])
            result.time_back_problem = len(result.problems)
            result.problems.append(
                Problem(pos, f"log time {int(times[i])} goes back (after {after})")
            )
        result.time_back += int(back.size)
    last = channel_ids.size - 1 - np.unique(channel_ids[::-1], return_index=True)[1]
    for channel_id, i, j, n in zip(
        found.tolist(), first.tolist(), last.tolist(), count.tolist(), strict=True
    ):
        result.counts[channel_id] = result.counts.get(channel_id, 0) + n
        start = result.time_ranges.get(channel_id, (int(times[i]), 0))[0]
        result.time_ranges[channel_id] = (start, int(times[j]))
    return set(found.tolist()), int(at.size), int(times[-1])


def _attachment(pos: int, body: memoryview) -> AttachmentInfo:
    stream = ReadDataStream(BytesIO(body))
    stream.read8()  # log_time
    stream.read8()  # create_time
    name = stream.read_prefixed_string()
    media_type = stream.read_prefixed_string()
    data_length = stream.read8()
    data_offset = stream.count
    if data_offset + data_length + 4 != len(body):
        raise RecordDamage(f"attachment {name!r} has an inconsistent length")
    (crc,) = struct.unpack_from("<I", body, data_offset + data_length)
    damaged = ""
    if crc and crc32(body[: data_offset + data_length]) != crc:
        damaged = f"attachment {name!r} CRC mismatch"
    return AttachmentInfo(pos, name, media_type, pos + 9 + data_offset, data_length, damaged)
