"""Recordings built from fuzz bytes: the attachments, metadata and chunk shapes a writer could
make, or lie about (the recording target of fuzzlib.py reads them).

:func:`build` reads ``data`` as a recipe, one byte per choice (zeros once it runs out), and
writes an MCAP file either with ``mcap.writer.Writer`` (complete: summary, chunk and message
indexes; then maybe cut) or record by record, as an attacker would: chunks whose declared
size, CRC, compression, times or records lie, millions-of-records shapes, attachments with
wrong CRCs and path-like names, metadata missing or late, damaged framing, no summary.
:func:`small_limits` lowers the readers' limits so that those shapes reach them quickly.
"""

from __future__ import annotations

import contextlib
import io
import os
import struct
import zlib
from collections.abc import Iterator, Sequence
from typing import Any, TypeVar

import lz4.frame  # type: ignore[import-untyped]
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.records import Attachment, Channel, DataEnd, Header, Metadata, Schema
from mcap.writer import CompressionType, Writer

from harness.msgs import message_definitions

__all__ = ["LIMITS", "build", "small_limits"]

T = TypeVar("T")
MAGIC = b"\x89MCAP0\r\n"
LIMITS = {
    "HARNESS_MAX_CHUNK_RECORDS": "300",
    "HARNESS_MAX_FILE_RECORDS": "1000",
    "HARNESS_MAX_CHUNK_BYTES": str(2**20),
    "HARNESS_MAX_FILE_BYTES": str(4 * 2**20),
}
"""The limits :func:`small_limits` sets: a few hundred records, a few MiB."""

_DEFINITIONS = message_definitions()
_TYPES = sorted(_DEFINITIONS)
_TOPICS = [
    "/harness/state",
    "/harness/inputs",
    "/harness/bridge",
    "/harness/epoch",
    "/rosout",
    "/x",
]
_NAMES = [
    "model.mjcf.xml", "model.mjb", "source/model/robot.urdf", "source/model/robot.urdf.xacro",
    "source/model/../../x", "/etc/hostname", "file:///etc/hostname", "a.txt", "", "\u00e9",
]  # fmt: skip
_KEYS = ["format_version", "timestep_ns", "model_sha256", "control_modes", "mujoco_version", "x"]
_VALUES = ["1", "0", "", "2", "999", "abc", "1000000", "-1", "{}", '{"j": "position"}']


class _Take:
    """Choices read from fuzz bytes, one (or a few) bytes each; zeros once they run out."""

    def __init__(self, data: bytes) -> None:
        self.data = data
        self.pos = 0

    def byte(self) -> int:
        value = self.data[self.pos] if self.pos < len(self.data) else 0
        self.pos += 1
        return value

    def int(self, bound: int) -> int:
        """An integer in ``[0, bound]``."""
        value = self.byte() | self.byte() << 8 if bound > 255 else self.byte()
        return value % (bound + 1)

    def pick(self, options: Sequence[T]) -> T:
        return options[self.byte() % len(options)]

    def blob(self, bound: int) -> bytes:
        n = self.int(bound)
        out = self.data[self.pos : self.pos + n]
        self.pos += n
        return out


def _record(record: Any) -> bytes:
    builder = RecordBuilder()
    record.write(builder)
    return bytes(builder.end())  # type: ignore[no-untyped-call]


def _schema(t: _Take) -> Schema:
    name = t.pick(_TYPES)
    data = _DEFINITIONS[name].encode() if t.byte() % 4 else t.blob(40)
    return Schema(
        id=t.pick([1, 2, 3, 0, 65535]), name=name, encoding=t.pick(["ros2msg", "", "x"]), data=data
    )


def _channel(t: _Take) -> Channel:
    return Channel(
        id=t.pick([1, 2, 3, 4]),
        schema_id=t.pick([1, 2, 3, 0, 9]),
        topic=t.pick(_TOPICS),
        message_encoding=t.pick(["cdr", "cdr", "json", ""]),
        metadata={},
    )


def _metadata(t: _Take) -> Metadata:
    name = t.pick(["harness"] * 6 + ["other", ""])
    values = {t.pick(_KEYS): t.pick(_VALUES) for _ in range(t.int(6))}
    if name == "harness" and t.byte() % 4 != 3:
        values.setdefault("format_version", "1")
        values.setdefault("timestep_ns", "2000000")
    return Metadata(name=name, metadata=values)


def _attachment(t: _Take) -> bytes:
    name, media = t.pick(_NAMES), t.pick(["application/xml", "application/octet-stream", ""])
    data = t.blob(60)
    raw = _record(Attachment(log_time=0, create_time=0, name=name, media_type=media, data=data))
    crc = t.pick(["right", "right", "zero", "wrong", "length"])
    if crc == "zero":
        raw = raw[:-4] + b"\0\0\0\0"
    elif crc == "wrong":
        raw = raw[:-4] + struct.pack("<I", zlib.crc32(raw) or 1)
    elif crc == "length" and len(raw) > 20:
        raw = raw[:-5] + raw[-4:]  # one byte less data than the length says
        raw = raw[:1] + struct.pack("<Q", len(raw) - 9) + raw[9:]
    return raw


def _message(t: _Take, time: int) -> bytes:
    payload = t.blob(24) if t.byte() % 3 else b"\0\1\0\0" + t.blob(24)
    return (
        b"\x05"
        + struct.pack("<QHIQQ", 22 + len(payload), t.pick([1, 2, 3, 7]), 0, time, time)
        + payload
    )


def _chunk(t: _Take) -> bytes:
    """A chunk record: records (messages, maybe schemas and channels), compressed, with
    its declared size, CRC and times right or wrong."""
    shape = t.pick(["few", "few", "few", "many", "empty", "nested"])
    times = t.pick(["up", "up", "back", "same"])
    records: list[bytes] = []
    if shape == "many":
        # Past the small limits: a smaller cousin of the 27 M-message bomb.
        count = t.pick([301, 1001, 5000])
        records = [
            b"\x05" + struct.pack("<QHIQQ", 22, t.pick([1, 2]), 0, k, k) for k in range(count)
        ]
    elif shape != "empty":
        for k in range(t.int(12)):
            if shape == "nested" and t.byte() % 3 == 0:
                records.append(_record(t.pick([_schema, _channel])(t)))
                continue
            time = {"up": k, "back": 100 - k, "same": 5}[times] * 2_000_000
            records.append(_message(t, time))
    raw = b"".join(records)
    compression = t.pick(["zstd", "zstd", "lz4", "", "bogus"])
    if compression == "zstd":
        packed = zstandard.ZstdCompressor().compress(raw)
    elif compression == "lz4":
        packed = lz4.frame.compress(raw)
    else:
        packed = raw
    if t.byte() % 8 == 0 and packed:  # a flipped byte in the compressed records
        at = t.int(len(packed) - 1)
        packed = packed[:at] + bytes([packed[at] ^ 0x10]) + packed[at + 1 :]
    size = len(raw) + t.pick([0, 0, 0, 1, -1, 2**31, 2**40])
    crc = t.pick([zlib.crc32(raw), zlib.crc32(raw), 0, 1])
    start, end = t.pick([(0, 2**30), (0, 0), (2**62, 0)])
    name = compression.encode()
    body = struct.pack("<QQQII", start, end, max(size, 0), crc, len(name)) + name
    body += struct.pack("<Q", len(packed)) + packed
    return b"\x06" + struct.pack("<Q", len(body)) + body


def _raw(t: _Take) -> bytes:
    out = [
        MAGIC,
        _record(Header(profile=t.pick(["ros2"] * 6 + ["", "x"]), library="fuzz")),
    ]
    if t.byte() % 4 != 3:  # where the recorder writes it
        out.append(_record(_metadata(t)))
    for k in range(t.int(3)):
        schema = _schema(t)
        topic = t.pick(_TOPICS)
        out.append(
            _record(Schema(id=k + 1, name=schema.name, encoding="ros2msg", data=schema.data))
        )
        out.append(
            _record(
                Channel(id=k + 1, schema_id=k + 1, topic=topic, message_encoding="cdr", metadata={})
            )
        )
    for _ in range(t.int(10)):
        kind = t.pick(
            [
                "metadata",
                "attachment",
                "schema",
                "channel",
                "chunk",
                "chunk",
                "chunk",
                "garbage",
                "message",
            ]
        )
        if kind == "metadata":
            out.append(_record(_metadata(t)))
        elif kind == "attachment":
            out.append(_attachment(t))
        elif kind in ("schema", "channel"):
            out.append(_record(_schema(t) if kind == "schema" else _channel(t)))
        elif kind == "chunk":
            out.append(_chunk(t))
        elif kind == "message":
            out.append(_message(t, 0))
        else:
            out.append(t.blob(20))
    tail = t.pick(["data_end", "data_end", "none", "footer"])
    if tail != "none":
        out.append(_record(DataEnd(data_section_crc=0)))
    if tail == "footer":
        out.append(b"\x02" + struct.pack("<QQQI", 20, 0, 0, 0) + MAGIC)
    return b"".join(out)


def _written(t: _Take) -> bytes:
    out = io.BytesIO()
    writer = Writer(
        out,
        chunk_size=t.pick([64, 512, 4096, 2**20]),
        compression=t.pick([CompressionType.ZSTD, CompressionType.LZ4, CompressionType.NONE]),
    )
    writer.start(profile=t.pick(["ros2"] * 7 + [""]), library="fuzz")
    for _ in range(t.int(3)):
        m = _metadata(t)
        writer.add_metadata(m.name, m.metadata)
    for _ in range(t.int(3)):
        writer.add_attachment(0, 0, t.pick(_NAMES), "application/octet-stream", t.blob(60))
    channels = []
    for _ in range(1 + t.int(3)):
        schema = writer.register_schema(
            t.pick(_TYPES), "ros2msg", _DEFINITIONS[t.pick(_TYPES)].encode()
        )
        channels.append(writer.register_channel(t.pick(_TOPICS), "cdr", schema))
    count = t.pick([0, 5, 40, 400])
    times = t.pick(["up", "up", "back"])
    for k in range(count):
        time = (k if times == "up" else count - k) * 2_000_000
        writer.add_message(t.pick(channels), time, b"\0\1\0\0" + t.blob(16), time)
    writer.finish()
    data = out.getvalue()
    if t.byte() % 4 == 3:
        data = data[: t.int(len(data))]  # cut short (a killed writer's file)
    return data


def build(data: bytes) -> bytes:
    """The MCAP file ``data`` describes (see the module docstring)."""
    t = _Take(data)
    return _written(t) if t.byte() % 3 == 0 else _raw(t)


@contextlib.contextmanager
def small_limits() -> Iterator[None]:
    """The readers' limits lowered to :data:`LIMITS` (restored after)."""
    saved = {name: os.environ.get(name) for name in LIMITS}
    os.environ.update(LIMITS)
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
