"""Cameras: RGB (``camera``), depth (``depth``) and both (``rgbd``), drawn by MuJoCo's offscreen
renderer (:mod:`harness.sensors.render`).

Messages: ``sensor_msgs/Image`` (``rgb8``; depth ``32FC1`` in metres along the optical axis,
``+inf`` beyond the far clip), ``CameraInfo`` (ideal pinhole: ``fx = fy = (w/2)/tan(hfov/2)``,
``cx = (w-1)/2``, ``cy = (h-1)/2``), ``CompressedImage`` (PNG) and ``PointCloud2`` from depth
(organised, NaN where nothing was hit), all in ``<frame_id>_optical`` (z forward, x right,
y down), which ``/tf_static`` places in the sensor frame (x forward, z up).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

import mujoco
import numpy as np
import numpy.typing as npt
from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.sensors.base import F64, Mount, SensorTopic, View, noise_rng, quat_of
from harness.sensors.errors import SensorConfigError
from harness.sensors.messages import (
    TYPE_CAMERA_INFO,
    TYPE_COMPRESSED_IMAGE,
    TYPE_IMAGE,
    TYPE_POINT_CLOUD2,
    camera_info_msg,
    compressed_msg,
    depth_image_msg,
    header,
    point_cloud_msg,
    rgb_image_msg,
)
from harness.sensors.options import SensorOptions, check_integer, check_positive
from harness.sensors.registry import Mounted, SensorKind, register_kind
from harness.sensors.render import OffscreenRenderer
from harness.sensors.sdf_values import element_int, element_noise, element_number
from harness.sensors.spec import SensorSpec

__all__ = ["OPTICAL", "CameraOptions", "CameraSensor"]

OPTICAL: F64 = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
"""The optical frame's axes (columns x right, y down, z forward) in the sensor frame."""

_TYPES = {
    "image": TYPE_IMAGE,
    "camera_info": TYPE_CAMERA_INFO,
    "compressed": TYPE_COMPRESSED_IMAGE,
    "depth": TYPE_IMAGE,
    "points": TYPE_POINT_CLOUD2,
}


@dataclass(frozen=True)
class CameraOptions(SensorOptions):
    """A camera's (``camera``, ``depth``, ``rgbd``) options: image ``width``/``height``
    (pixels), horizontal field of view ``hfov`` (rad), ``near``/``far`` clip (m); ``record``:
    ``"raw"`` records ``Image``, ``"compressed"`` the PNG ``CompressedImage`` instead."""

    width: int = 320
    height: int = 240
    hfov: float = 1.047
    near: float = 0.05
    far: float = 100.0
    record: Literal["raw", "compressed"] = "raw"

    def __post_init__(self) -> None:
        check_integer("width", self.width)
        check_integer("height", self.height)
        for name in ("hfov", "near", "far"):
            check_positive(name, getattr(self, name))
        if self.hfov >= math.pi:
            raise SensorConfigError(f"hfov must be below pi rad, not {self.hfov!r}")
        if self.near >= self.far:
            raise SensorConfigError(f"near clip {self.near} must be below far {self.far}")
        if self.record not in ("raw", "compressed"):
            raise SensorConfigError("record must be 'raw' or 'compressed'")


class CameraSensor:
    """A camera of ``spec`` at ``mount``; ``renderer`` gives the shared renderer (made on the
    first frame, so that a session without cameras never starts OpenGL)."""

    uses_renderer = True
    """It draws with the suite's shared offscreen renderer (sized to the largest
    :attr:`image_size`)."""

    def __init__(
        self,
        spec: SensorSpec,
        model: mujoco.MjModel,
        mount: Mount,
        topics: Mapping[str, str],
        frame_id: str,
        renderer: Callable[[], OffscreenRenderer],
        sensor_frame: str = "",
    ) -> None:
        self.spec = spec
        self.mount = mount
        # An explicit frame_id (a plugin's <frame_name>) is what the images carry; otherwise
        # they carry "<sensor>_optical". Either is published in /tf_static below the sensor frame.
        self._sensor_frame = sensor_frame
        self.frame_id = frame_id if spec.frame_id else frame_id + "_optical"
        self._renderer = renderer
        self._scene: mujoco.MjvScene | None = None
        # its image geometry is fixed here (a noise change replaces the spec, not these)
        self.options: CameraOptions = spec.options_as(CameraOptions)
        options = self.options
        width, height = options.width, options.height
        self.image_size = (width, height)
        """(width, height) in pixels."""
        if spec.camera:
            cam = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, spec.camera))
            vfov = math.radians(float(model.cam_fovy[cam])) if cam >= 0 else options.hfov
            hfov = 2 * math.atan(math.tan(vfov / 2) * width / height)
        else:
            hfov = options.hfov
            vfov = 2 * math.atan(math.tan(hfov / 2) * height / width)
        self.hfov, self.vfov = hfov, vfov
        self.fx = (width / 2) / math.tan(hfov / 2)
        self.fy = (height / 2) / math.tan(vfov / 2)
        self.cx, self.cy = (width - 1) / 2, (height - 1) / 2
        wants_rgb = spec.type in ("camera", "rgbd")
        record_raw = options.record == "raw"
        self.outputs = tuple(
            SensorTopic(
                key,
                topics[key],
                _TYPES[key],
                record=(key != "image" or record_raw) and (key != "compressed" or not record_raw),
            )
            for key in ("image", "compressed", "camera_info", "depth", "points")
            if key in topics and (wants_rgb or key not in ("image", "compressed"))
        )
        self._rgb = wants_rgb
        self._depth = spec.type in ("depth", "rgbd")
        # Rays of the organised point cloud, per unit depth, in the optical frame.
        u = (np.arange(width) - self.cx) / self.fx
        v = (np.arange(height) - self.cy) / self.fy
        self._ray_x = np.broadcast_to(u[np.newaxis, :], (height, width)).astype(np.float32)
        self._ray_y = np.broadcast_to(v[:, np.newaxis], (height, width)).astype(np.float32)

    def render(
        self, view: View
    ) -> tuple[npt.NDArray[np.uint8] | None, npt.NDArray[np.float32] | None]:
        """The RGB image and the depth image (metres, ``inf`` beyond the far clip) now."""
        renderer = self._renderer()
        if self._scene is None:
            self._scene = renderer.new_scene()
        spec = self.spec
        options = self.options
        rgb = np.empty((options.height, options.width, 3), np.uint8) if self._rgb else None
        depth = np.empty((options.height, options.width), np.float32) if self._depth else None
        position, rotation = self.mount.world(view.data)
        renderer.render(
            self._scene,
            view.data,
            position,
            rotation,
            self.vfov,
            options.near,
            options.far,
            rgb,
            depth,
        )
        if depth is not None:
            depth[depth >= np.float32(options.far) * np.float32(0.99999)] = np.inf
            if spec.noise_stddev or spec.noise_mean:
                rng = noise_rng(view.seed, spec.name, view.step)
                noise = rng.normal(spec.noise_mean, spec.noise_stddev, depth.shape)
                depth += noise.astype(np.float32)
        return rgb, depth

    def read(self, view: View) -> Mapping[str, Callable[[], dict[str, Any]]]:
        """Every output's message builder at this step (one render, shared, on first use)."""
        rendered: list[tuple[npt.NDArray[np.uint8] | None, npt.NDArray[np.float32] | None]] = []

        def images() -> tuple[npt.NDArray[np.uint8] | None, npt.NDArray[np.float32] | None]:
            if not rendered:
                rendered.append(self.render(view))
            return rendered[0]

        hdr = header(view.sim_time_ns, self.frame_id)

        def info() -> dict[str, Any]:
            size = (self.options.width, self.options.height)
            return camera_info_msg(hdr, *size, self.fx, self.fy, self.cx, self.cy)

        def image() -> dict[str, Any]:
            rgb = images()[0]
            assert rgb is not None
            return rgb_image_msg(hdr, rgb)

        def compressed() -> dict[str, Any]:
            rgb = images()[0]
            assert rgb is not None
            return compressed_msg(hdr, rgb)

        def depth() -> dict[str, Any]:
            d = images()[1]
            assert d is not None
            return depth_image_msg(hdr, d)

        def points() -> dict[str, Any]:
            d = images()[1]
            assert d is not None
            z = np.where(np.isfinite(d), d, np.float32(np.nan))
            cloud = np.stack([self._ray_x * z, self._ray_y * z, z], axis=-1)
            return point_cloud_msg(hdr, cloud.astype(np.float32))

        return {
            "camera_info": info,
            "image": image,
            "compressed": compressed,
            "depth": depth,
            "points": points,
        }

    def static_frames(self) -> list[tuple[str, F64, F64]]:
        """The sensor frame and its optical frame in the mount link."""
        rotation = self.mount.rotation
        optical = (self.frame_id, self.mount.position, quat_of(rotation @ OPTICAL))
        if not self._sensor_frame or self._sensor_frame == self.frame_id:
            return [optical]
        return [(self._sensor_frame, self.mount.position, quat_of(rotation)), optical]


def _camera_params(el: etree._Element | None, where: str) -> dict[str, Any]:
    if el is None:
        return {}
    out: dict[str, Any] = {}
    for key, path in (("hfov", "horizontal_fov"), ("near", "clip/near"), ("far", "clip/far")):
        value = element_number(el, path, where)
        if value is not None:
            out[key] = value
    for key, path in (("width", "image/width"), ("height", "image/height")):
        size = element_int(el, path, where)
        if size is not None:
            out[key] = size
    out.update(element_noise(el, where))
    return out


def _params(sensor: etree._Element, where: str) -> dict[str, Any]:
    return _camera_params(sensor.find("camera"), where)


def _build(spec: SensorSpec, at: Mounted) -> CameraSensor:
    sensor_frame = at.prefix + spec.token
    return CameraSensor(spec, at.model, at.mount, at.topics, at.frame_id, at.renderer, sensor_frame)


def _info(topic: str) -> str:
    parent = topic.rsplit("/", 1)[0] if "/" in topic.strip("/") else ""
    return f"{parent}/camera_info" if parent else "camera_info"


def _camera_topics(topic: str, base: str) -> dict[str, str]:
    if topic:
        return {"image": topic, "camera_info": _info(topic), "compressed": f"{topic}/compressed"}
    return {
        "image": f"{base}/image_raw",
        "camera_info": f"{base}/camera_info",
        "compressed": f"{base}/image_raw/compressed",
    }


def _depth_topics(topic: str, base: str) -> dict[str, str]:
    if topic:
        return {"depth": topic, "camera_info": _info(topic), "points": f"{topic}/points"}
    return {
        "camera_info": f"{base}/camera_info",
        "depth": f"{base}/depth/image_raw",
        "points": f"{base}/points",
    }


def _rgbd_topics(topic: str, base: str) -> dict[str, str]:
    if topic:
        return {
            "image": f"{topic}/image",
            "camera_info": f"{topic}/camera_info",
            "compressed": f"{topic}/image/compressed",
            "depth": f"{topic}/depth_image",
            "points": f"{topic}/points",
        }
    return {**_camera_topics("", base), **_depth_topics("", base)}


register_kind(
    SensorKind(
        "camera",
        ("image", "camera_info", "compressed"),
        10.0,
        _build,
        gazebo=("camera",),
        topics=_camera_topics,
        params=_params,
        renders=True,
        options=CameraOptions,
    )
)
register_kind(
    SensorKind(
        "depth",
        ("depth", "camera_info", "points"),
        10.0,
        _build,
        gazebo=("depth_camera",),
        topics=_depth_topics,
        params=_params,
        renders=True,
        options=CameraOptions,
    )
)
register_kind(
    SensorKind(
        "rgbd",
        ("image", "camera_info", "compressed", "depth", "points"),
        10.0,
        _build,
        gazebo=("depth", "rgbd_camera", "rgbd"),
        topics=_rgbd_topics,
        params=_params,
        renders=True,
        options=CameraOptions,
    )
)
