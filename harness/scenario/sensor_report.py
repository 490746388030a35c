"""The report's sensor section: one captured frame of each camera in a recording, inline as a
PNG (a self-contained page)."""

from __future__ import annotations

import base64
import html
from pathlib import Path

import numpy as np

from harness.errors import HarnessError

__all__ = ["camera_frames_html"]

_IMAGE = "sensor_msgs/msg/Image"
_COMPRESSED = "sensor_msgs/msg/CompressedImage"


def camera_frames_html(recording: Path | None) -> str:
    """``<figure>``\\ s of the middle RGB frame of each camera topic (empty without any)."""
    if recording is None or not recording.is_file():
        return ""
    from harness.recording import Recording
    from harness.sensors.messages import png_bytes

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
