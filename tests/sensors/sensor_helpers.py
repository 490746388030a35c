"""Paths of the sensor tests' data, and a recording rewriter (another renderer's images)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from harness.recording.layout import typestore

DATA = Path(__file__).resolve().parents[1] / "data" / "sensors"
RIG = DATA / "sensor_rig.xml"


def rewrite_images(
    src: Path, dst: Path, *, renderer: str, change: Callable[[np.ndarray], None]
) -> Path:
    """A copy of a recording as if made on another renderer: the ``gl_renderer`` metadata set
    to ``renderer`` and ``change`` applied to the pixels of every ``/cam/image_raw`` frame."""
    store = typestore()
    with open(src, "rb") as f_in, open(dst, "wb") as f_out:
        reader = make_reader(f_in)
        header = reader.get_header()
        writer = Writer(f_out, compression=CompressionType.ZSTD)
        writer.start(profile=header.profile, library=header.library)
        for record in reader.iter_metadata():
            data = dict(record.metadata)
            if record.name == "harness.sensors.renderer":
                data["gl_renderer"] = renderer
            writer.add_metadata(record.name, data)
        for a in reader.iter_attachments():
            writer.add_attachment(0, 0, a.name, a.media_type, bytes(a.data))
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
            if channel.topic == "/cam/image_raw":
                msg: Any = store.deserialize_cdr(data, schema.name)
                pixels = np.array(msg.data, np.uint8)
                change(pixels)
                msg.data = pixels
                data = store.serialize_cdr(msg, schema.name)
            writer.add_message(
                channels[channel.id], message.log_time, data, message.publish_time,
                message.sequence,
            )  # fmt: skip
        writer.finish()
    return dst
