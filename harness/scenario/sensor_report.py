"""The report's sensor section: one captured frame of each camera in a recording, inline as a
PNG, and one scan of each 2D lidar, inline as an SVG of its points (a self-contained page)."""

from __future__ import annotations

import base64
import html
from pathlib import Path

import numpy as np

from harness.errors import HarnessError

__all__ = ["camera_frames_html", "laser_scans_html"]

_IMAGE = "sensor_msgs/msg/Image"
_COMPRESSED = "sensor_msgs/msg/CompressedImage"
_SCAN = "sensor_msgs/msg/LaserScan"
_SVG_SIZE = 240  # px


def camera_frames_html(recording: Path | None) -> str:
    """``<figure>``\\ s of the middle RGB frame of each camera topic (empty without any)."""
    if recording is None or not recording.is_file():
        return ""
    from harness.recording import Recording
    from harness.sensors import png_bytes

    try:
        with Recording(recording) as rec:
            counts = {
                t: info.messages
                for t, info in rec.topics.items()
                if info.msgtype in (_IMAGE, _COMPRESSED) and info.messages
            }
            figures = []
            for topic, count in sorted(counts.items()):
                target = count // 2
                middle = next(m for i, m in enumerate(rec.messages(topic)) if i == target)
                msg = rec.decode(middle)
                if middle.msgtype == _IMAGE:
                    if msg.encoding != "rgb8":
                        continue
                    rgb = np.asarray(msg.data, np.uint8).reshape(msg.height, msg.width, 3)
                    png = png_bytes(rgb)
                else:
                    png = bytes(msg.data)
                figures.append(
                    f'<figure class="camera"><img alt="{html.escape(topic)}" '
                    f'src="data:image/png;base64,{base64.b64encode(png).decode()}">'
                    f"<figcaption>{html.escape(topic)} at {middle.sim_time_ns / 1e9:.3f} s "
                    f"(frame {target + 1} of {count})</figcaption></figure>"
                )
    except (HarnessError, OSError, ValueError) as exc:
        return f'<p class="note">Camera frames unavailable: {html.escape(str(exc))}</p>'
    return "<h3>Cameras</h3>" + "".join(figures) if figures else ""


def scan_svg(ranges: list[float], angle_min: float, increment: float, range_max: float) -> str:
    """An SVG of one LaserScan's points seen from above (x forward is up), the sensor at the
    centre, the plot ``range_max`` in radius; invalid returns (inf, NaN, beyond range) left out."""
    half = _SVG_SIZE / 2
    scale = half / range_max if range_max > 0 else 1.0
    dots = []
    for i, r in enumerate(ranges):
        if not np.isfinite(r) or r <= 0 or r > range_max:
            continue
        a = angle_min + i * increment
        px, py = half - r * np.sin(a) * scale, half - r * np.cos(a) * scale
        dots.append(f'<circle cx="{px:.1f}" cy="{py:.1f}" r="1.5"/>')
    return (
        f'<svg class="scan" xmlns="http://www.w3.org/2000/svg" width="{_SVG_SIZE}" '
        f'height="{_SVG_SIZE}" viewBox="0 0 {_SVG_SIZE} {_SVG_SIZE}">'
        f'<circle cx="{half}" cy="{half}" r="{half - 1}" fill="none" stroke="#ccc"/>'
        f'<circle cx="{half}" cy="{half}" r="3" fill="#c00"/>'
        f'<g fill="#036">{"".join(dots)}</g></svg>'
    )


def laser_scans_html(recording: Path | None) -> str:
    """``<figure>``\\ s of the middle scan of each LaserScan topic as an SVG (empty without any)."""
    if recording is None or not recording.is_file():
        return ""
    from harness.recording import Recording

    try:
        with Recording(recording) as rec:
            counts = {
                t: info.messages
                for t, info in rec.topics.items()
                if info.msgtype == _SCAN and info.messages
            }
            figures = []
            for topic, count in sorted(counts.items()):
                target = count // 2
                middle = next(m for i, m in enumerate(rec.messages(topic)) if i == target)
                msg = rec.decode(middle)
                svg = scan_svg(
                    [float(r) for r in msg.ranges],
                    float(msg.angle_min),
                    float(msg.angle_increment),
                    float(msg.range_max),
                )
                figures.append(
                    f'<figure class="scan">{svg}<figcaption>{html.escape(topic)} at '
                    f"{middle.sim_time_ns / 1e9:.3f} s (scan {target + 1} of {count})"
                    "</figcaption></figure>"
                )
    except (HarnessError, OSError, ValueError) as exc:
        return f'<p class="note">Laser scans unavailable: {html.escape(str(exc))}</p>'
    return "<h3>Laser scans</h3>" + "".join(figures) if figures else ""
