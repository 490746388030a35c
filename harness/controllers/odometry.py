"""What the mobile base controllers (diff drive, planar) share: their velocity command topic and
odometry settings read from ros2_controllers' parameter names, the command's parsing, and the
odometry they publish (``nav_msgs/msg/Odometry`` of a planar pose and body velocity, and
optionally the same pose as a ``/tf`` transform, ``enable_odom_tf``)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

from harness.controllers.base import LogLine, Publication, TopicEndpoint
from harness.controllers.params import Params, stamp

__all__ = ["BaseSettings", "OdometryFrames", "odometry_publications", "read_twist"]

_NS = 1_000_000_000


class OdometryFrames(NamedTuple):
    """Where a base controller's odometry goes: its topic, its frames and whether the pose
    is also a transform on ``/tf``."""

    topic: str
    odom_frame: str
    base_frame: str
    tf: bool


class BaseSettings(NamedTuple):
    """A base controller's command and odometry parameters (ros2_controllers' names)."""

    timeout_ns: int
    publish_period_ns: int
    stamped: bool
    cmd_topic: str
    frames: OdometryFrames
    subscriptions: tuple[TopicEndpoint, ...]
    publishers: tuple[TopicEndpoint, ...]

    @classmethod
    def read(cls, p: Params) -> BaseSettings:
        """``cmd_vel_timeout``, ``publish_rate``, ``odom_frame_id``, ``base_frame_id``,
        ``enable_odom_tf``, ``use_stamped_vel``, ``cmd_vel_topic``, ``odom_topic``."""
        timeout_ns = round(p.number("cmd_vel_timeout", 0.5, minimum=0.0) * _NS)
        rate = p.number("publish_rate", 50.0, minimum=0.0)
        odom_frame = p.string("odom_frame_id", "odom")
        base_frame = p.string("base_frame_id", "base_link")
        odom_tf = p.flag("enable_odom_tf", True)
        stamped = p.flag("use_stamped_vel", True)
        cmd_type = "geometry_msgs/msg/TwistStamped" if stamped else "geometry_msgs/msg/Twist"
        cmd_topic = p.string("cmd_vel_topic", "~/cmd_vel")
        odom_topic = p.string("odom_topic", "~/odom")
        publishers = [TopicEndpoint(odom_topic, "nav_msgs/msg/Odometry")]
        if odom_tf:
            publishers.append(TopicEndpoint("/tf", "tf2_msgs/msg/TFMessage"))
        return cls(
            timeout_ns,
            round(_NS / rate) if rate > 0 else 0,
            stamped,
            cmd_topic,
            OdometryFrames(odom_topic, odom_frame, base_frame, odom_tf),
            (TopicEndpoint(cmd_topic, cmd_type),),
            tuple(publishers),
        )


def read_twist(
    msg: Mapping[str, Any], stamped: bool, axes: Sequence[tuple[str, str]], connection: int
) -> tuple[float, ...] | LogLine:
    """The velocities of ``axes`` (e.g. ``("linear", "x")``) of a Twist (or TwistStamped when
    ``stamped``), or the log line that refuses it (a missing field, a non-finite value)."""
    twist = msg.get("twist", msg) if stamped else msg
    try:
        values = tuple(float(twist[part][axis]) for part, axis in axes)
    except (KeyError, TypeError, ValueError) as exc:
        return LogLine(40, f"command refused: no {exc}", connection)
    if not all(math.isfinite(v) for v in values):
        return LogLine(40, "command refused: non-finite velocity", connection)
    return values


def odometry_publications(
    frames: OdometryFrames,
    now_ns: int,
    pose: tuple[float, float, float],
    velocity: tuple[float, float, float],
) -> list[Publication]:
    """The publications of a planar ``pose`` (x, y, heading) and body ``velocity`` (vx, vy,
    wz) at sim time ``now_ns`` (each message built when it is published: :class:`Publication`)."""
    x, y, heading = pose
    vx, vy, wz = velocity

    def quat() -> dict[str, float]:
        return {"x": 0.0, "y": 0.0, "z": math.sin(heading / 2), "w": math.cos(heading / 2)}

    def header() -> dict[str, Any]:
        return {"stamp": stamp(now_ns), "frame_id": frames.odom_frame}

    def odom() -> dict[str, Any]:
        return {
            "header": header(),
            "child_frame_id": frames.base_frame,
            "pose": {
                "pose": {"position": {"x": x, "y": y, "z": 0.0}, "orientation": quat()},
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

    def tf() -> dict[str, Any]:
        transform = {
            "header": header(),
            "child_frame_id": frames.base_frame,
            "transform": {"translation": {"x": x, "y": y, "z": 0.0}, "rotation": quat()},
        }
        return {"transforms": [transform]}

    out = [Publication(frames.topic, "nav_msgs/msg/Odometry", build=odom)]
    if frames.tf:
        out.append(Publication("/tf", "tf2_msgs/msg/TFMessage", build=tf))
    return out
