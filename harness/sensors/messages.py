"""ROS messages of the sensors, in the canonical dict form the bridge and the recorder take
(``bytes`` for ``uint8[]``, lists of floats, ``{"sec", "nanosec"}`` stamps)."""

from __future__ import annotations

import struct
import zlib
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = [
    "TYPE_CAMERA_INFO",
    "TYPE_COMPRESSED_IMAGE",
    "TYPE_CONTACTS",
    "TYPE_IMAGE",
    "TYPE_IMU",
    "TYPE_LASER_SCAN",
    "TYPE_POINT_CLOUD2",
    "TYPE_TF",
    "TYPE_WRENCH",
    "camera_info_msg",
    "compressed_msg",
    "contact_state",
    "depth_image_msg",
    "header",
    "imu_msg",
    "laser_scan_msg",
    "png_bytes",
    "point_cloud_msg",
    "rgb_image_msg",
    "static_tf_msg",
    "wrench_msg",
]

TYPE_IMAGE = "sensor_msgs/msg/Image"
TYPE_CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
TYPE_COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
TYPE_POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
TYPE_LASER_SCAN = "sensor_msgs/msg/LaserScan"
TYPE_IMU = "sensor_msgs/msg/Imu"
TYPE_WRENCH = "geometry_msgs/msg/WrenchStamped"
TYPE_CONTACTS = "harness_msgs/msg/ContactsState"
TYPE_TF = "tf2_msgs/msg/TFMessage"

F64 = npt.NDArray[np.float64]
_FLOAT32 = 7  # sensor_msgs/PointField FLOAT32


def header(sim_time_ns: int, frame_id: str) -> dict[str, Any]:
    """A ``std_msgs/Header`` at a simulation time."""
    sec, nanosec = divmod(sim_time_ns, 1_000_000_000)
    return {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": frame_id}


def rgb_image_msg(hdr: dict[str, Any], rgb: npt.NDArray[np.uint8]) -> dict[str, Any]:
    """A ``sensor_msgs/Image`` in ``rgb8``."""
    height, width = rgb.shape[:2]
    return {
        "header": hdr,
        "height": height,
        "width": width,
        "encoding": "rgb8",
        "is_bigendian": 0,
        "step": width * 3,
        "data": np.ascontiguousarray(rgb).tobytes(),
    }


def depth_image_msg(hdr: dict[str, Any], depth: npt.NDArray[np.float32]) -> dict[str, Any]:
    """A ``sensor_msgs/Image`` in ``32FC1`` (metres, little-endian)."""
    height, width = depth.shape
    return {
        "header": hdr,
        "height": height,
        "width": width,
        "encoding": "32FC1",
        "is_bigendian": 0,
        "step": width * 4,
        "data": np.ascontiguousarray(depth, dtype="<f4").tobytes(),
    }


def camera_info_msg(
    hdr: dict[str, Any], width: int, height: int, fx: float, fy: float, cx: float, cy: float
) -> dict[str, Any]:
    """A ``sensor_msgs/CameraInfo`` of an ideal pinhole camera (no distortion)."""
    return {
        "header": hdr,
        "height": height,
        "width": width,
        "distortion_model": "plumb_bob",
        "d": [0.0, 0.0, 0.0, 0.0, 0.0],
        "k": [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
        "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        "p": [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
    }


def png_bytes(rgb: npt.NDArray[np.uint8]) -> bytes:
    """``rgb`` (H x W x 3) as a PNG file (zlib level 6: deterministic for the same pixels)."""
    height, width = rgb.shape[:2]
    rows = np.zeros((height, 1 + width * 3), dtype=np.uint8)  # filter byte 0 on every row
    rows[:, 1:] = np.ascontiguousarray(rgb).reshape(height, width * 3)

    def chunk(kind: bytes, body: bytes) -> bytes:
        return (
            struct.pack(">I", len(body))
            + kind
            + body
            + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)
        )

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(rows.tobytes(), 6))
        + chunk(b"IEND", b"")
    )


def compressed_msg(hdr: dict[str, Any], rgb: npt.NDArray[np.uint8]) -> dict[str, Any]:
    """A ``sensor_msgs/CompressedImage`` (PNG, as image_transport's ``compressed`` names it)."""
    return {"header": hdr, "format": "rgb8; png compressed rgb8", "data": png_bytes(rgb)}


def point_cloud_msg(hdr: dict[str, Any], points: npt.NDArray[np.float32]) -> dict[str, Any]:
    """A ``sensor_msgs/PointCloud2`` of x y z float32 points; ``points`` is H x W x 3 (an
    organised cloud, NaN where nothing was hit) or N x 3."""
    if points.ndim == 2:
        points = points[np.newaxis]
    height, width = points.shape[:2]
    return {
        "header": hdr,
        "height": height,
        "width": width,
        "fields": [
            {"name": axis, "offset": 4 * i, "datatype": _FLOAT32, "count": 1}
            for i, axis in enumerate("xyz")
        ],
        "is_bigendian": False,
        "point_step": 12,
        "row_step": 12 * width,
        "data": np.ascontiguousarray(points, dtype="<f4").tobytes(),
        "is_dense": bool(np.isfinite(points).all()),
    }


def laser_scan_msg(
    hdr: dict[str, Any],
    angle_min: float,
    angle_max: float,
    angle_increment: float,
    scan_time: float,
    range_min: float,
    range_max: float,
    ranges: npt.NDArray[np.float32],
) -> dict[str, Any]:
    """A ``sensor_msgs/LaserScan`` (``inf`` where nothing was hit within range)."""
    return {
        "header": hdr,
        "angle_min": angle_min,
        "angle_max": angle_max,
        "angle_increment": angle_increment,
        "time_increment": 0.0,
        "scan_time": scan_time,
        "range_min": range_min,
        "range_max": range_max,
        "ranges": ranges.astype(np.float32).tolist(),
        "intensities": [],
    }


def _vector(v: Sequence[float] | F64) -> dict[str, float]:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def _diagonal(variance: float) -> list[float]:
    return [variance, 0.0, 0.0, 0.0, variance, 0.0, 0.0, 0.0, variance]


def imu_msg(
    hdr: dict[str, Any],
    quat_wxyz: F64,
    angular: F64,
    linear: F64,
    variance: float,
    accel_variance: float,
) -> dict[str, Any]:
    """A ``sensor_msgs/Imu``: orientation in the world, rates and acceleration in the sensor
    frame; covariances diagonal with the noise variance."""
    w, x, y, z = (float(v) for v in quat_wxyz)
    return {
        "header": hdr,
        "orientation": {"x": x, "y": y, "z": z, "w": w},
        "orientation_covariance": _diagonal(0.0),
        "angular_velocity": _vector(angular),
        "angular_velocity_covariance": _diagonal(variance),
        "linear_acceleration": _vector(linear),
        "linear_acceleration_covariance": _diagonal(accel_variance),
    }


def wrench_msg(hdr: dict[str, Any], force: F64, torque: F64) -> dict[str, Any]:
    """A ``geometry_msgs/WrenchStamped``."""
    return {"header": hdr, "wrench": {"force": _vector(force), "torque": _vector(torque)}}


def contact_state(
    name1: str, name2: str, force: F64, position: F64, normal: F64, depth: float
) -> dict[str, Any]:
    """One ``harness_msgs/ContactState`` of a single contact point."""
    wrench = {"force": _vector(force), "torque": _vector((0.0, 0.0, 0.0))}
    return {
        "info": f"{name1} -> {name2}",
        "collision1_name": name1,
        "collision2_name": name2,
        "wrenches": [wrench],
        "total_wrench": wrench,
        "contact_positions": [_vector(position)],
        "contact_normals": [_vector(normal)],
        "depths": [depth],
    }


def static_tf_msg(sim_time_ns: int, frames: Sequence[tuple[str, str, F64, F64]]) -> dict[str, Any]:
    """A ``tf2_msgs/TFMessage`` of ``(parent, child, xyz, quat w-x-y-z)`` transforms."""
    transforms = []
    for parent, child, xyz, quat in frames:
        w, x, y, z = (float(v) for v in quat)
        transforms.append(
            {
                "header": header(sim_time_ns, parent),
                "child_frame_id": child,
                "transform": {
                    "translation": _vector(xyz),
                    "rotation": {"x": x, "y": y, "z": z, "w": w},
                },
            }
        )
    return {"transforms": transforms}
