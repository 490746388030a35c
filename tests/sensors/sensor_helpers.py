"""Paths of the sensor tests' data, and a recording as if made on another renderer."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tests.replay.mcap_edit import rewrite

DATA = Path(__file__).resolve().parents[1] / "data" / "sensors"
RIG = DATA / "sensor_rig.xml"


def rewrite_images(
    src: Path, dst: Path, *, renderer: str, change: Callable[[np.ndarray], None]
) -> Path:
    """A copy of a recording as if made on another renderer: the ``gl_renderer`` metadata set
    to ``renderer`` and ``change`` applied to the pixels of every ``/cam/image_raw`` frame."""

    def images(topic: str, msg: Any) -> Any:
        if topic == "/cam/image_raw":
            pixels = np.array(msg.data, np.uint8)
            change(pixels)
            msg.data = pixels
        return msg

    def gl_renderer(data: dict[str, str]) -> dict[str, str]:
        return {**data, "gl_renderer": renderer}

    return rewrite(
        src, dst, edit=images, metadata=gl_renderer, metadata_name="harness.sensors.renderer"
    )
