"""``repair``: rewrite what is intact of a damaged or truncated recording as a complete file.

A killed recorder leaves a file without its summary and footer; a flipped byte leaves a chunk
or an attachment that fails its CRC. :func:`repair` reads the file as
:class:`~harness.recording.Recording` does (every intact chunk, past damaged ones) and writes
every intact chunk (same boundaries, same records), attachment and metadata record with a
data end, a summary and a footer, so that every MCAP reader opens it (rosbags, ``ros2 bag``,
Foxglove's ``@mcap/core``). What was lost stays lost and is named in the report.
"""

from __future__ import annotations

import contextlib
import os
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path

from mcap.opcode import Opcode
from mcap.writer import CompressionType, Writer

from harness.recording.errors import RecordingDamagedWarning, RecordingWriteError
from harness.recording.recording import LostRange, Recording
from harness.recording.scanned import Problem

__all__ = ["RepairReport", "repair"]

_COMPRESSION = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "": CompressionType.NONE}
_RECORD = struct.Struct("<BQ")
_MESSAGE = struct.Struct("<HIQQ")


@dataclass(frozen=True)
class RepairReport:
    """What :func:`repair` kept and what it could not."""

    source: str
    target: str
    problems: tuple[Problem, ...]
    chunks: int
    messages: int
    attachments: int
    dropped_attachments: tuple[str, ...]
    lost: tuple[LostRange, ...]

    def format(self) -> str:
        """Lines for the CLI."""
        lines = [f"{self.source}: {p}" for p in self.problems]
        if not self.problems:
            lines.append(f"{self.source}: sound; rewritten unchanged in content")
        lines.append(
            f"wrote {self.target}: {self.chunks} chunks, {self.messages} messages, "
            f"{self.attachments} attachments, with summary and footer"
        )
        for name in self.dropped_attachments:
            lines.append(f"dropped attachment {name!r}: its CRC does not match")
        for r in self.lost:
            last = "the end" if r.last_step is None else f"step {r.last_step}"
            lines.append(
                f"lost: bytes {r.offset}..{r.end} ({r.what}); messages of step "
                f"{r.first_step} to {last} may be missing"
            )
        return "\n".join(lines)


def repair(source: str | os.PathLike[str], target: str | os.PathLike[str]) -> RepairReport:
    """Write the intact contents of ``source`` to ``target`` as a complete recording (via a
    temporary file, then renamed). Raises
    :class:`~harness.recording.errors.RecordingFormatError` when ``source`` is not a
    readable recording at all, :class:`~harness.recording.errors.RecordingWriteError` when
    ``target`` cannot be written or is ``source``."""
    src, dst = Path(source), Path(target)
    if dst.exists() and src.exists() and dst.resolve() == src.resolve():
        raise RecordingWriteError(f"{dst}: repair writes a new file; give another target")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingDamagedWarning)
        rec = Recording(src)
    tmp = dst.with_name(f".{dst.name}.repair")
    try:
        with rec, open(tmp, "wb") as out:
            report = _rewrite(rec, out, str(dst))
        os.replace(tmp, dst)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise RecordingWriteError(f"{dst}: cannot write: {exc.strerror or exc}") from None
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return report


def _rewrite(rec: Recording, out: object, target: str) -> RepairReport:
    scan = rec.scan
    compression = rec.metadata.get("compression", "zstd")
    writer = Writer(
        out,  # type: ignore[arg-type]
        chunk_size=2**62,  # chunks close where the source's did (flush below)
        compression=_COMPRESSION.get(compression.replace("none", ""), CompressionType.ZSTD),
        enable_crcs=True,
        enable_data_crcs=True,
    )
    writer.start(profile=scan.header.profile, library=scan.header.library)
    for record in scan.metadata:
        writer.add_metadata(record.name, dict(record.metadata))
    kept = 0
    dropped: list[str] = []
    for info in scan.attachments:
        if info.damaged:
            dropped.append(info.name)
            continue
        writer.add_attachment(0, 0, info.name, info.media_type, rec.attachment(info.name))
        kept += 1
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    for sid, schema in sorted(scan.schemas.items()):
        schema_ids[sid] = writer.register_schema(schema.name, schema.encoding, schema.data)
    for cid, channel in sorted(scan.channels.items()):
        channel_ids[cid] = writer.register_channel(
            channel.topic,
            channel.message_encoding,
            schema_ids.get(channel.schema_id, 0),
            dict(channel.metadata),
        )
    messages = 0
    chunks = 0
    for chunk in scan.chunks:
        data = memoryview(rec._chunk_data(chunk))
        pos = 0
        written = 0
        while pos < len(data):
            opcode, length = _RECORD.unpack_from(data, pos)
            start, end = pos + 9, pos + 9 + length
            if opcode == Opcode.MESSAGE:
                channel_id, sequence, log_time, publish_time = _MESSAGE.unpack_from(data, start)
                writer.add_message(
                    channel_ids[channel_id], log_time, bytes(data[start + 22 : end]),
                    publish_time, sequence,
                )  # fmt: skip
                written += 1
            pos = end
        if written:
            writer.flush()  # type: ignore[no-untyped-call]
            chunks += 1
            messages += written
    writer.finish()  # type: ignore[no-untyped-call]
    return RepairReport(
        str(rec.path), target, tuple(scan.problems), chunks, messages, kept, tuple(dropped),
        tuple(rec.lost),
    )  # fmt: skip
