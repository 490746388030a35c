"""``--level full`` for sensors: the re-run's sensor messages against the recorded ones.

Every message on a topic the recording's ``harness.sensors`` metadata lists is compared in
order, as CDR bytes: bit for bit. Images are byte-identical only on the same renderer: when the
re-run renders with another OpenGL renderer than the recorded one (``harness.sensors.renderer``
metadata), images, depth images and point clouds are compared with a tolerance instead (at most
2 % of pixels off by more than 24 levels, or, for depth, by more than 1 cm; headers and sizes
exact), the bridge frames carrying them are compared without their payload, and the report
says so.
"""

from __future__ import annotations

import json
import zlib
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from harness.recording import RecordedMessage, Recording, from_rosbridge, typestore
from harness.sensors import METADATA_RECORD, RendererInfo

__all__ = ["SensorCheck"]

_RENDERED = frozenset(
    {"sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage", "sensor_msgs/msg/PointCloud2"}
)
_PIXEL_LEVELS = 24
_DEPTH_M = 0.01
_FRACTION = 0.02


def _png_pixels(data: bytes) -> np.ndarray[Any, Any]:
    """The rows of a PNG the sensors wrote (one IDAT, filter 0) as an array."""
    width, height = (int.from_bytes(data[16 + 4 * i : 20 + 4 * i], "big") for i in range(2))
    start = data.index(b"IDAT") + 4
    length = int.from_bytes(data[start - 8 : start - 4], "big")
    rows = np.frombuffer(zlib.decompress(data[start : start + length]), np.uint8)
    return rows.reshape(height, 1 + width * 3)[:, 1:].reshape(height, width, 3)


def _off_fraction(expected: Any, actual: Any, msgtype: str) -> float | None:
    """The fraction of pixels/points off by more than the tolerance (None: not comparable)."""
    if msgtype == "sensor_msgs/msg/CompressedImage":
        a = _png_pixels(bytes(expected.data)).astype(np.int16)
        b = _png_pixels(bytes(actual.data)).astype(np.int16)
        return None if a.shape != b.shape else float((np.abs(a - b) > _PIXEL_LEVELS).mean())
    if (expected.height, expected.width) != (actual.height, actual.width):
        return None
    a_raw, b_raw = np.asarray(expected.data, np.uint8), np.asarray(actual.data, np.uint8)
    if a_raw.size != b_raw.size:
        return None
    if msgtype == "sensor_msgs/msg/Image" and expected.encoding == "rgb8":
        a, b = a_raw.astype(np.int16), b_raw.astype(np.int16)
        return float((np.abs(a - b) > _PIXEL_LEVELS).mean())
    fa = a_raw.view("<f4").astype(np.float64)
    fb = b_raw.view("<f4").astype(np.float64)
    same = (fa == fb) | (np.isnan(fa) & np.isnan(fb))
    close = np.abs(np.nan_to_num(fa - fb, nan=np.inf, posinf=np.inf)) <= _DEPTH_M
    return float((~(same | close)).mean())


class SensorCheck:
    """The recorded sensor messages of ``rec`` and a running comparison; ``renderer`` gives
    the re-run's OpenGL strings once it has rendered (None before)."""

    def __init__(self, rec: Recording, renderer: Callable[[], RendererInfo | None]) -> None:
        meta = rec.all_metadata.get(METADATA_RECORD)
        self.topics: dict[str, str] = json.loads(meta["topics"]) if meta else {}
        self.recorded_renderer: Mapping[str, str] = rec.all_metadata.get(
            METADATA_RECORD + ".renderer", {}
        )
        self._expected: dict[str, list[RecordedMessage]] = {t: [] for t in self.topics}
        if self.topics:
            for m in rec.messages(list(self.topics)):
                self._expected[m.topic].append(m)
        self._at = dict.fromkeys(self.topics, 0)
        self._renderer = renderer
        self.compared = 0
        self.notes: list[str] = []

    @property
    def tolerant(self) -> bool:
        """Whether the re-run renders with another renderer than the recording's."""
        info = self._renderer()
        if info is None or not self.recorded_renderer:
            return False
        return info.to_metadata() != dict(self.recorded_renderer)

    def skips_payload(self, topic: str) -> bool:
        """Whether bridge frames on ``topic`` are compared without their payload."""
        return self.topics.get(topic) in _RENDERED and self.tolerant

    def check(self, topic: str, msgtype: str, msg: Any, sim_time_ns: int) -> str | None:
        """Compare one re-run message; returns what differs (None: equal or not a sensor's)."""
        if topic not in self.topics:
            return None
        i = self._at[topic]
        self._at[topic] = i + 1
        expected = self._expected[topic]
        if i >= len(expected):
            return f"{topic}: the re-run produced message #{i}, the recording has {len(expected)}"
        ref = expected[i]
        if ref.sim_time_ns != sim_time_ns:
            return f"{topic} #{i}: recorded at {ref.sim_time_ns} ns, re-run at {sim_time_ns} ns"
        store = typestore()
        actual = bytes(store.serialize_cdr(from_rosbridge(store, msgtype, msg), msgtype))
        self.compared += 1
        if actual == ref.data:
            return None
        if msgtype not in _RENDERED or not self.tolerant:
            return f"{topic} #{i}: the message differs (CDR bytes)"
        a: Any = store.deserialize_cdr(ref.data, msgtype)
        b: Any = store.deserialize_cdr(actual, msgtype)
        if a.header.stamp != b.header.stamp or a.header.frame_id != b.header.frame_id:
            return f"{topic} #{i}: the header differs"
        off = _off_fraction(a, b, msgtype)
        if off is None:
            return f"{topic} #{i}: the image size differs"
        if off > _FRACTION:
            return f"{topic} #{i}: {off:.1%} of the pixels differ beyond the tolerance"
        if not self.notes:
            current = self._renderer()
            assert current is not None
            self.notes.append(
                f"images were recorded with {self.recorded_renderer.get('gl_renderer', '?')!r} "
                f"and re-rendered with {current.renderer!r}: compared with a tolerance"
            )
        return None

    def missing(self) -> str | None:
        """What the recording has that the re-run did not produce (None: nothing)."""
        for topic, msgs in self._expected.items():
            if self._at[topic] < len(msgs):
                return f"{topic}: the re-run did not produce message #{self._at[topic]}"
        return None
