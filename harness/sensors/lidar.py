"""Lidars (Gazebo's ``ray``, ``gpu_ray``, ``lidar``, ``gpu_lidar``) by ray casting
(``mj_multiRay``: no rendering). One vertical sample gives a ``sensor_msgs/LaserScan`` (2D),
more give a ``PointCloud2`` (3D, points in the sensor frame, NaN where nothing was hit).

A ray that hits nothing within ``range_max``, or hits nearer than ``range_min``, reads
``inf``. Gaussian noise (``noise_mean``/``noise_stddev``, metres) is added to every hit, then
ranges are rounded to ``range_resolution`` when it is given. The sensor's own link is not hit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.sensors.base import F64, Mount, SensorTopic, View, noise_rng, quat_of
from harness.sensors.errors import SensorConfigError
from harness.sensors.messages import (
    TYPE_LASER_SCAN,
    TYPE_POINT_CLOUD2,
    header,
    laser_scan_msg,
    point_cloud_msg,
)
from harness.sensors.options import SensorOptions, check_finite, check_integer, check_positive
from harness.sensors.registry import Mounted, SensorKind, register_kind
from harness.sensors.sdf_values import element_int, element_noise, element_number
from harness.sensors.spec import SensorSpec

__all__ = ["LidarOptions", "LidarSensor"]


@dataclass(frozen=True)
class LidarOptions(SensorOptions):
    """A lidar's options: horizontal ``samples`` from ``min_angle`` to ``max_angle`` (rad),
    ``vertical_samples`` from ``vertical_min_angle`` to ``vertical_max_angle`` (one: a planar
    scan), ``range_min``/``range_max``/``range_resolution`` (m; resolution 0: not rounded)."""

    samples: int = 360
    min_angle: float = -math.pi
    max_angle: float = math.pi
    vertical_samples: int = 1
    vertical_min_angle: float = 0.0
    vertical_max_angle: float = 0.0
    range_min: float = 0.1
    range_max: float = 30.0
    range_resolution: float = 0.0

    def __post_init__(self) -> None:
        check_integer("samples", self.samples)
        check_integer("vertical_samples", self.vertical_samples)
        check_positive("range_max", self.range_max)
        check_positive("range_min", self.range_min, zero=True)
        check_positive("range_resolution", self.range_resolution, zero=True)
        for name in ("min_angle", "max_angle", "vertical_min_angle", "vertical_max_angle"):
            check_finite(name, getattr(self, name))
        if self.range_min >= self.range_max:
            raise SensorConfigError(
                f"range_min {self.range_min} must be below range_max {self.range_max}"
            )
        if self.min_angle > self.max_angle or self.vertical_min_angle > self.vertical_max_angle:
            raise SensorConfigError("a min angle is above its max angle")


def _angles(samples: int, low: float, high: float) -> F64:
    if samples == 1:
        return np.array([low])
    return np.linspace(low, high, samples)


class LidarSensor:
    """A lidar of ``spec`` at ``mount``."""

    def __init__(
        self,
        spec: SensorSpec,
        model: mujoco.MjModel,
        mount: Mount,
        topics: Mapping[str, str],
        frame_id: str,
    ) -> None:
        self.spec = spec
        self.mount = mount
        self.frame_id = frame_id
        # its ray pattern is fixed here (a noise change replaces the spec, not these)
        self.options: LidarOptions = spec.options_as(LidarOptions)
        options = self.options
        self.planar = options.vertical_samples == 1
        key = "scan" if self.planar else "points"
        self.outputs: tuple[SensorTopic, ...] = (
            SensorTopic(key, topics[key], TYPE_LASER_SCAN if self.planar else TYPE_POINT_CLOUD2),
        )
        self._model = model
        horizontal = _angles(options.samples, options.min_angle, options.max_angle)
        vertical = _angles(
            options.vertical_samples, options.vertical_min_angle, options.vertical_max_angle
        )
        elevation, azimuth = np.meshgrid(vertical, horizontal, indexing="ij")
        self._directions: F64 = np.stack(
            [
                np.cos(elevation) * np.cos(azimuth),
                np.cos(elevation) * np.sin(azimuth),
                np.sin(elevation),
            ],
            axis=-1,
        ).reshape(-1, 3)
        self._n = self._directions.shape[0]
        self._geomid = np.zeros(self._n, np.int32)
        self._dist = np.zeros(self._n, np.float64)
        self._increment = (
            (options.max_angle - options.min_angle) / (options.samples - 1)
            if options.samples > 1
            else 0.0
        )

    def ranges(self, view: View) -> npt.NDArray[np.float64]:
        """The range of every ray now (vertical-major), ``inf`` where out of range."""
        spec, options = self.spec, self.options
        position, rotation = self.mount.world(view.data)
        vec = np.ascontiguousarray((self._directions @ rotation.T).reshape(-1))
        mujoco.mj_multiRay(
            self._model, view.data, position, vec, None, 1, self.mount.body,
            self._geomid, self._dist, None, self._n, options.range_max,
        )  # fmt: skip
        dist = self._dist.copy()
        valid = (dist >= 0) & (dist <= options.range_max)
        if spec.noise_stddev or spec.noise_mean:
            rng = noise_rng(view.seed, spec.name, view.step)
            dist = dist + rng.normal(spec.noise_mean, spec.noise_stddev, dist.shape)
        if options.range_resolution:
            dist = np.round(dist / options.range_resolution) * options.range_resolution
        valid &= dist >= options.range_min
        out: npt.NDArray[np.float64] = np.where(valid, dist, np.inf)
        return out

    def read(self, view: View) -> Mapping[str, Callable[[], dict[str, Any]]]:
        """The scan (2D) or point cloud (3D) builder at this step."""
        spec, options = self.spec, self.options
        hdr = header(view.sim_time_ns, self.frame_id)

        def scan() -> dict[str, Any]:
            return laser_scan_msg(
                hdr, options.min_angle, options.max_angle, self._increment, 1.0 / spec.period_hz
                if spec.period_hz else 0.0, options.range_min, options.range_max,
                self.ranges(view).astype(np.float32),
            )  # fmt: skip

        def points() -> dict[str, Any]:
            r = self.ranges(view)
            cloud = self._directions * np.where(np.isfinite(r), r, np.nan)[:, np.newaxis]
            return point_cloud_msg(
                hdr, cloud.reshape(options.vertical_samples, options.samples, 3).astype(np.float32)
            )

        return {"scan": scan} if self.planar else {"points": points}

    def static_frames(self) -> list[tuple[str, F64, F64]]:
        """The sensor frame in the mount link."""
        return [(self.frame_id, self.mount.position, quat_of(self.mount.rotation))]


def _ray_params(el: etree._Element | None, where: str) -> dict[str, Any]:
    if el is None:
        return {}
    out: dict[str, Any] = {}
    for prefix, key in (("scan/horizontal", ""), ("scan/vertical", "vertical_")):
        samples = element_int(el, f"{prefix}/samples", where)
        if samples is not None:
            out[f"{key}samples"] = samples
        for name in ("min_angle", "max_angle"):
            value = element_number(el, f"{prefix}/{name}", where)
            if value is not None:
                out[f"{key}{name}"] = value
    for name in ("min", "max", "resolution"):
        value = element_number(el, f"range/{name}", where)
        if value is not None:
            out[f"range_{name}"] = value
    out.update(element_noise(el, where))
    return out


def _params(sensor: etree._Element, where: str) -> dict[str, Any]:
    ray = sensor.find("ray")
    return _ray_params(ray if ray is not None else sensor.find("lidar"), where)


def _topics(topic: str, base: str) -> dict[str, str]:
    if topic:
        return {"scan": topic, "points": f"{topic}/points"}
    return {"scan": f"{base}/scan", "points": f"{base}/points"}


def _build(spec: SensorSpec, at: Mounted) -> LidarSensor:
    return LidarSensor(spec, at.model, at.mount, at.topics, at.frame_id)


register_kind(
    SensorKind(
        "lidar",
        ("scan", "points"),
        10.0,
        _build,
        gazebo=("ray", "gpu_ray", "lidar", "gpu_lidar"),
        topics=_topics,
        params=_params,
        options=LidarOptions,
    )
)
