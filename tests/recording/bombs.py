"""Small MCAP files that cost a reader much work: chunks of millions of empty messages.

One zstd chunk of 27 M empty message records is a 70 KB file (the attack review's break 6);
it is written here from raw records (no summary, no index, as an attacker would), without
ever holding the 837 MB its chunk decompresses to.
"""

from __future__ import annotations

import struct
from pathlib import Path

import zstandard
from mcap.data_stream import RecordBuilder
from mcap.records import Channel, DataEnd, Header, Metadata, Schema

__all__ = ["MESSAGE_RECORD", "write_bomb"]

MESSAGE_RECORD = b"\x05" + struct.pack("<QHIQQ", 22, 1, 0, 0, 0)
"""An empty message on channel 1 (31 bytes: the smallest a message record can be)."""

_MAGIC = b"\x89MCAP0\r\n"
_BLOCK = 2**15  # records per block fed to the compressor


def _record(record: Header | Metadata | Schema | Channel | DataEnd) -> bytes:
    builder = RecordBuilder()
    record.write(builder)
    return bytes(builder.end())  # type: ignore[no-untyped-call]


def _chunk(messages: int) -> bytes:
    compressor = zstandard.ZstdCompressor(level=3).compressobj(size=messages * 31)
    block = MESSAGE_RECORD * _BLOCK
    parts = []
    full, rest = divmod(messages, _BLOCK)
    for _ in range(full):
        parts.append(compressor.compress(block))
    parts.append(compressor.compress(MESSAGE_RECORD * rest))
    parts.append(compressor.flush())
    records = b"".join(parts)
    name = b"zstd"
    # start, end, uncompressed size, uncompressed CRC (0: none), compression, records
    body = struct.pack("<QQQII", 0, 0, messages * 31, 0, len(name)) + name
    body += struct.pack("<Q", len(records)) + records
    return b"\x06" + struct.pack("<Q", len(body)) + body


def write_bomb(
    path: Path,
    messages: int = 27_000_000,
    chunks: int = 1,
    *,
    profile: str = "ros2",
    harness: bool = True,
) -> Path:
    """Write ``chunks`` chunks of ``messages`` empty messages each to ``path``, after a
    header of ``profile`` and (``harness``) a ``harness`` metadata record; a data end, no
    summary, no footer."""
    out = [_MAGIC, _record(Header(profile=profile, library="bomb"))]
    if harness:
        out.append(
            _record(Metadata(name="harness", metadata={"format_version": "1", "timestep_ns": "1"}))
        )
    out.append(_record(Schema(id=1, name="std_msgs/msg/Empty", encoding="ros2msg", data=b"")))
    out.append(_record(Channel(id=1, schema_id=1, topic="/b", message_encoding="cdr", metadata={})))
    chunk = _chunk(messages)
    out += [chunk] * chunks
    out.append(_record(DataEnd(data_section_crc=0)))
    path.write_bytes(b"".join(out))
    return path
