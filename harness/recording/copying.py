"""A recording copied record by record with some attachments left out or added: what a
golden is written from (the run's recording without ``model.mjb``, or with its sources replaced
by references to the project's files)."""

from __future__ import annotations

from collections.abc import Container, Mapping
from pathlib import Path

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from harness.recording.metadata import media_type

__all__ = ["copy_recording"]


def copy_recording(
    source: Path,
    target: Path,
    *,
    drop: Container[str] = (),
    add: Mapping[str, bytes] | None = None,
) -> None:
    """Copy the MCAP ``source`` to ``target`` (zstd chunks): every message, schema, channel
    and metadata record, the attachments not named in ``drop``, then ``add`` (name -> bytes)."""
    with open(source, "rb") as src, open(target, "wb") as out:
        reader = make_reader(src)
        header = reader.get_header()
        writer = Writer(out, compression=CompressionType.ZSTD)
        writer.start(profile=header.profile, library=header.library)
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if channel.id not in channels:
                if schema is not None and schema.id not in schemas:
                    schemas[schema.id] = writer.register_schema(
                        schema.name, schema.encoding, schema.data
                    )
                channels[channel.id] = writer.register_channel(
                    channel.topic,
                    channel.message_encoding,
                    schemas.get(channel.schema_id, 0),
                    dict(channel.metadata),
                )
            writer.add_message(
                channels[channel.id],
                message.log_time,
                message.data,
                message.publish_time,
                message.sequence,
            )
        for attachment in reader.iter_attachments():
            if attachment.name not in drop:
                writer.add_attachment(
                    attachment.create_time,
                    attachment.log_time,
                    attachment.name,
                    attachment.media_type,
                    attachment.data,
                )
        for name, blob in (add or {}).items():
            writer.add_attachment(0, 0, name, media_type(name), blob)
        for metadata in reader.iter_metadata():
            writer.add_metadata(metadata.name, dict(metadata.metadata))
        writer.finish()  # type: ignore[no-untyped-call]
