"""Closing a recording whose writes failed (disk full): a valid file over what was written.

When a write fails mid-run the writer's own state no longer matches the file (a chunk half
written, its index never added). :func:`close_prefix` therefore trusts only the bytes up to
the end of the last complete flush: it cuts the file there (which also gives back the space
the partial chunk took) and appends a data end and a summary computed from those bytes (the
schemas, channels, chunk and attachment and metadata indexes and statistics every reader
checks), then the footer. The result opens as a complete file, with the messages of every
chunk flushed before the failure. It needs a few kilobytes; when even that fails the file
stays cut at the flush (readable up to there with ``--allow-damaged``).
"""

from __future__ import annotations

import contextlib
import errno
import mmap
import os
import struct
import zlib
from io import BytesIO
from pathlib import Path
from typing import Protocol

from mcap.data_stream import ReadDataStream, RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    AttachmentIndex,
    ChunkIndex,
    DataEnd,
    Footer,
    Metadata,
    MetadataIndex,
    Statistics,
)

from harness.recording.chunks import MAGIC
from harness.recording.scan import scan
from harness.recording.tail import lock_for_writing

__all__ = ["close_prefix", "finish_after_failure"]

_RECORD = struct.Struct("<BQ")
_CHUNK_HEAD = struct.Struct("<QQQII")


def _summary(buf: memoryview, path: Path) -> tuple[bytes, int, int]:
    """The summary records (without footer) of the complete records in ``buf``, with the
    number of messages they hold and the last message time."""
    found = scan(buf, str(path))
    metadata: list[MetadataIndex] = []
    attachments: list[AttachmentIndex] = []
    chunks: list[ChunkIndex] = []
    pos = len(MAGIC)
    while pos + 9 <= len(buf):
        opcode, length = _RECORD.unpack_from(buf, pos)
        end = pos + 9 + int(length)
        if end > len(buf):
            break
        body = buf[pos + 9 : end]
        if opcode == Opcode.METADATA:
            record = Metadata.read(ReadDataStream(BytesIO(body)))
            metadata.append(MetadataIndex(pos, end - pos, record.name))
        elif opcode == Opcode.ATTACHMENT:
            a = Attachment.read(ReadDataStream(BytesIO(body)))
            attachments.append(
                AttachmentIndex(
                    pos, end - pos, a.log_time, a.create_time, len(a.data), a.name, a.media_type
                )
            )
        elif opcode == Opcode.CHUNK:
            start, stop, size, _crc, name_length = _CHUNK_HEAD.unpack_from(body, 0)
            at = _CHUNK_HEAD.size + name_length
            compression = str(body[_CHUNK_HEAD.size : at], "utf-8")
            (compressed,) = struct.unpack_from("<Q", body, at)
            chunks.append(
                ChunkIndex(
                    chunk_length=end - pos,
                    chunk_start_offset=pos,
                    compression=compression,
                    compressed_size=int(compressed),
                    message_end_time=int(stop),
                    message_index_length=0,
                    message_index_offsets={},
                    message_start_time=int(start),
                    uncompressed_size=int(size),
                )
            )
        elif opcode == Opcode.MESSAGE_INDEX and chunks:
            (channel_id,) = struct.unpack_from("<H", body, 0)
            chunks[-1].message_index_offsets[int(channel_id)] = pos
            chunks[-1].message_index_length += end - pos
        pos = end
    kept = {c.offset for c in found.chunks}
    chunks = [c for c in chunks if c.chunk_start_offset in kept]
    builder = RecordBuilder()
    for schema in found.schemas.values():
        schema.write(builder)
    for channel in found.channels.values():
        channel.write(builder)
    Statistics(
        attachment_count=len(attachments),
        channel_count=len(found.channels),
        channel_message_counts=dict(found.counts),
        chunk_count=len(chunks),
        message_count=found.message_count,
        message_end_time=max(found.end_time, 0),
        message_start_time=max(found.start_time, 0),
        metadata_count=len(metadata),
        schema_count=len(found.schemas),
    ).write(builder)
    for records in (metadata, attachments, chunks):
        for record in records:
            record.write(builder)
    summary = bytes(builder.end())  # type: ignore[no-untyped-call]
    return summary, found.message_count, max(found.end_time, 0)


def close_prefix(path: str | os.PathLike[str], good: int) -> tuple[int, int]:
    """Cut ``path`` at byte ``good`` (the end of its last complete write) and finish it there
    as a complete MCAP file; returns the messages kept and the last message time (ns).
    Raises :class:`OSError` when the file cannot be finished."""
    target = Path(path)
    with open(target, "r+b") as f:
        # The writer's descriptor (and its lock) is closed: another writer that took the path
        # since is refused here (RecordingBusyError) rather than cut.
        lock_for_writing(f.fileno(), target)
        f.truncate(good)
        with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mapped:
            buf = memoryview(mapped)
            try:
                data_crc = zlib.crc32(buf)
                summary, kept, end_time = _summary(buf, target)
            finally:
                buf.release()
        end = RecordBuilder()
        DataEnd(data_crc).write(end)
        data_end = bytes(end.end())  # type: ignore[no-untyped-call]
        summary_start = good + len(data_end)
        footer_head = struct.pack("<BQQQ", Opcode.FOOTER, 8 + 8 + 4, summary_start, 0)
        footer = RecordBuilder()
        Footer(summary_start, 0, zlib.crc32(footer_head, zlib.crc32(summary))).write(footer)
        f.seek(good)
        f.write(data_end + summary + bytes(footer.end()) + MAGIC)  # type: ignore[no-untyped-call]
        f.flush()
    return kept, end_time


def _last_chunk_start(path: Path, end: int) -> int | None:
    """The offset of the last chunk record wholly before byte ``end`` of ``path`` (None when
    there is none): cutting there drops that chunk and what follows it."""
    last = None
    pos = len(MAGIC)
    with open(path, "rb") as f:
        while pos + 9 <= end:
            f.seek(pos)
            opcode, length = _RECORD.unpack(f.read(9))
            stop = pos + 9 + int(length)
            if stop > end:
                break
            if opcode == Opcode.CHUNK:
                last = pos
            pos = stop
    return last


class _Closable(Protocol):
    def close(self) -> None: ...


def finish_after_failure(
    stream: _Closable,
    path: Path,
    error: OSError,
    good: int,
    written: int,
) -> str:
    """Close ``stream`` (whose write failed with ``error``) and finish ``path`` at byte
    ``good``, the end of its last complete write; returns the sentence that says what was
    kept and what was lost (``written``: messages accepted in all)."""
    with contextlib.suppress(OSError):
        stream.close()  # its buffer cannot be written: the descriptor is closed anyway
    cause = error.strerror or str(error)
    while True:
        try:
            kept, sim_time_ns = close_prefix(path, good)
            break
        except OSError as exc:
            # no room for the summary: give up the last chunk's space and try again
            earlier = _last_chunk_start(path, good) if exc.errno == errno.ENOSPC else None
            if earlier is None:
                return (
                    f"{path}: writing failed ({cause}) and the file could not be finished "
                    f"({exc.strerror or exc}): it ends at byte {good}, the last complete "
                    "write (open it with --allow-damaged); later messages were lost"
                )
            good = earlier
    return (
        f"{path}: writing failed ({cause}); the recording was closed as a valid file at its "
        f"last complete flush ({kept} messages up to sim time {sim_time_ns / 1e9:g} s); "
        f"{max(written - kept, 0)} later messages were lost"
    )
