"""Rewrite a copy of a recording with the mcap library, changing decoded records.

``rewrite(src, dst, edit=fn, metadata=fn, attachments=fn)``: ``edit(topic, msg)`` gets every
decoded message (a rosbags object, modifiable in place) and returns it, or ``None`` to drop it;
``metadata``/``attachments`` map the old dict to the new one (``metadata`` applies to the
metadata record named ``metadata_name``); ``chunk_size`` as the recorder's.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from harness.recording.layout import typestore

__all__ = ["rewrite"]


def rewrite(
    src: Path,
    dst: Path,
    *,
    edit: Callable[[str, Any], Any] | None = None,
    metadata: Callable[[dict[str, str]], dict[str, str]] | None = None,
    attachments: Callable[[dict[str, bytes]], dict[str, bytes]] | None = None,
    metadata_name: str = "harness",
    chunk_size: int = 1024 * 1024,
) -> Path:
    store = typestore()
    with open(src, "rb") as f_in, open(dst, "wb") as f_out:
        reader = make_reader(f_in)
        header = reader.get_header()
        writer = Writer(f_out, compression=CompressionType.ZSTD, chunk_size=chunk_size)
        writer.start(profile=header.profile, library=header.library)
        for record in reader.iter_metadata():
            data = dict(record.metadata)
            if metadata is not None and record.name == metadata_name:
                data = metadata(data)
            writer.add_metadata(record.name, data)
        blobs = {a.name: (a.media_type, bytes(a.data)) for a in reader.iter_attachments()}
        named = {name: blob for name, (_, blob) in blobs.items()}
        if attachments is not None:
            named = attachments(named)
        for name, blob in named.items():
            media = blobs.get(name, ("application/octet-stream", b""))[0]
            writer.add_attachment(0, 0, name, media, blob)
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            assert schema is not None
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id], channel.metadata
                )
            data = message.data
            if edit is not None:
                msg = edit(channel.topic, store.deserialize_cdr(data, schema.name))
                if msg is None:
                    continue
                data = store.serialize_cdr(msg, schema.name)
            writer.add_message(
                channels[channel.id], message.log_time, data, message.publish_time,
                message.sequence,
            )  # fmt: skip
        writer.finish()
    return dst
