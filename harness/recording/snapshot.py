"""A complete MCAP file from the flushed prefix of a recording still being written.

A :class:`~harness.recording.Recorder` flushes whole chunks; the bytes up to a flush are a
valid MCAP that lacks only its data end, summary and footer. :func:`complete_prefix` re-writes
those records through :mod:`mcap`'s own reader and writer into a file that every reader opens
as complete (same records in the same order; chunk boundaries and compression may differ).
"""

from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path

from mcap.exceptions import EndOfFile
from mcap.records import Attachment, Channel, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from harness.recording.errors import RecordingWriteError

__all__ = ["complete_prefix"]

_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}


def complete_prefix(prefix: bytes, target: str | os.PathLike[str], compression: str) -> None:
    """Write the records of ``prefix`` (an MCAP cut after a flush) to ``target`` as a complete
    MCAP file (written to a temporary file, then renamed)."""
    target = Path(target)
    tmp = target.with_name(f".{target.name}.tmp")
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    try:
        with open(tmp, "wb") as out:
            writer = Writer(
                out,
                compression=_COMPRESSION.get(compression, CompressionType.ZSTD),
                enable_crcs=True,
                enable_data_crcs=True,
            )
            reader = StreamReader(io.BytesIO(prefix), validate_crcs=True)
            started = False
            records = reader.records
            while True:
                try:
                    record = next(records)
                except StopIteration:
                    break
                except EndOfFile:
                    break  # the cut: no data end, summary or footer after the last flush
                if isinstance(record, Header):
                    writer.start(profile=record.profile, library=record.library)
                    started = True
                elif not started:
                    raise RecordingWriteError(f"{target}: the recording prefix has no MCAP header")
                elif isinstance(record, Schema):
                    schema_ids[record.id] = writer.register_schema(
                        record.name, record.encoding, record.data
                    )
                elif isinstance(record, Channel):
                    channel_ids[record.id] = writer.register_channel(
                        record.topic,
                        record.message_encoding,
                        schema_ids.get(record.schema_id, 0),
                        dict(record.metadata),
                    )
                elif isinstance(record, Message):
                    writer.add_message(
                        channel_ids[record.channel_id],
                        record.log_time,
                        record.data,
                        record.publish_time,
                        record.sequence,
                    )
                elif isinstance(record, Attachment):
                    writer.add_attachment(
                        record.create_time,
                        record.log_time,
                        record.name,
                        record.media_type,
                        record.data,
                    )
                elif isinstance(record, Metadata):
                    writer.add_metadata(record.name, dict(record.metadata))
            if not started:
                raise RecordingWriteError(f"{target}: the recording prefix has no MCAP header")
            writer.finish()  # type: ignore[no-untyped-call]
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
