"""The odometry a mobile base controller publishes: ``nav_msgs/msg/Odometry`` of a planar pose
and body velocity, and optionally the same pose as a ``/tf`` transform (``enable_odom_tf``)."""

from __future__ import annotations

import math
from typing import NamedTuple

from harness.controllers.base import Publication
from harness.controllers.params import stamp

__all__ = ["OdometryFrames", "odometry_publications"]


class OdometryFrames(NamedTuple):
    """Where a base controller's odometry goes: its topic, its frames and whether the pose
    is also a transform on ``/tf``."""

    topic: str
    odom_frame: str
    base_frame: str
    tf: bool


def odometry_publications(
    frames: OdometryFrames,
    now_ns: int,
    pose: tuple[float, float, float],
    velocity: tuple[float, float, float],
) -> list[Publication]:
    """The publications of a planar ``pose`` (x, y, heading) and body ``velocity`` (vx, vy,
    wz) at sim time ``now_ns``."""
    x, y, heading = pose
    vx, vy, wz = velocity
    quat = {"x": 0.0, "y": 0.0, "z": math.sin(heading / 2), "w": math.cos(heading / 2)}
    header = {"stamp": stamp(now_ns), "frame_id": frames.odom_frame}
    odom = {
        "header": header,
        "child_frame_id": frames.base_frame,
        "pose": {
            "pose": {"position": {"x": x, "y": y, "z": 0.0}, "orientation": quat},
            "covariance": [0.0] * 36,
        },
        "twist": {
            "twist": {
                "linear": {"x": vx, "y": vy, "z": 0.0},
                "angular": {"x": 0.0, "y": 0.0, "z": wz},
            },
            "covariance": [0.0] * 36,
        },
    }
    out = [Publication(frames.topic, "nav_msgs/msg/Odometry", odom)]
    if frames.tf:
        transform = {
            "header": header,
            "child_frame_id": frames.base_frame,
            "transform": {"translation": {"x": x, "y": y, "z": 0.0}, "rotation": quat},
        }
        out.append(Publication("/tf", "tf2_msgs/msg/TFMessage", {"transforms": [transform]}))
    return out
