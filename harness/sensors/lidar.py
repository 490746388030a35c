"""Lidars (Gazebo's ``ray``, ``gpu_ray``, ``lidar``, ``gpu_lidar``) by ray casting
(``mj_multiRay``: no rendering). One vertical sample gives a ``sensor_msgs/LaserScan`` (2D),
more give a ``PointCloud2`` (3D, points in the sensor frame, NaN where nothing was hit).

A ray that hits nothing within ``range_max``, or hits nearer than ``range_min``, reads
``inf``. Gaussian noise (``noise_mean``/``noise_stddev``, metres) is added to every hit, then
ranges are rounded to ``range_resolution`` when it is given. The sensor's own link is not hit.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.sensors.base import F64, Mount, SensorTopic, View, noise_rng, quat_of
from harness.sensors.messages import (
    TYPE_LASER_SCAN,
    TYPE_POINT_CLOUD2,
    header,
    laser_scan_msg,
    point_cloud_msg,
)
from harness.sensors.registry import Mounted, SensorKind, register_kind
from harness.sensors.sdf_values import element_int, element_noise, element_number
from harness.sensors.spec import SensorSpec

__all__ = ["LidarSensor"]


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
        self.planar = spec.vertical_samples == 1
        key = "scan" if self.planar else "points"
        self.outputs: tuple[SensorTopic, ...] = (
            SensorTopic(key, topics[key], TYPE_LASER_SCAN if self.planar else TYPE_POINT_CLOUD2),
        )
        self._model = model
        horizontal = _angles(spec.samples, spec.min_angle, spec.max_angle)
        vertical = _angles(spec.vertical_samples, spec.vertical_min_angle, spec.vertical_max_angle)
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
            (spec.max_angle - spec.min_angle) / (spec.samples - 1) if spec.samples > 1 else 0.0
        )

    def ranges(self, view: View) -> npt.NDArray[np.float64]:
        """The range of every ray now (vertical-major), ``inf`` where out of range."""
        spec = self.spec
        position, rotation = self.mount.world(view.data)
        vec = np.ascontiguousarray((self._directions @ rotation.T).reshape(-1))
        mujoco.mj_multiRay(
            self._model, view.data, position, vec, None, 1, self.mount.body,
            self._geomid, self._dist, None, self._n, spec.range_max,
        )  # fmt: skip
        dist = self._dist.copy()
        valid = (dist >= 0) & (dist <= spec.range_max)
        if spec.noise_stddev or spec.noise_mean:
            rng = noise_rng(view.seed, spec.name, view.step)
            dist = dist + rng.normal(spec.noise_mean, spec.noise_stddev, dist.shape)
        if spec.range_resolution:
            dist = np.round(dist / spec.range_resolution) * spec.range_resolution
        valid &= dist >= spec.range_min
        out: npt.NDArray[np.float64] = np.where(valid, dist, np.inf)
        return out

    def read(self, view: View) -> Mapping[str, Callable[[], dict[str, Any]]]:
        """The scan (2D) or point cloud (3D) builder at this step."""
        spec = self.spec
        hdr = header(view.sim_time_ns, self.frame_id)

        def scan() -> dict[str, Any]:
            return laser_scan_msg(
                hdr, spec.min_angle, spec.max_angle, self._increment, 1.0 / spec.period_hz
                if spec.period_hz else 0.0, spec.range_min, spec.range_max,
                self.ranges(view).astype(np.float32),
            )  # fmt: skip

        def points() -> dict[str, Any]:
            r = self.ranges(view)
            cloud = self._directions * np.where(np.isfinite(r), r, np.nan)[:, np.newaxis]
            return point_cloud_msg(
                hdr, cloud.reshape(spec.vertical_samples, spec.samples, 3).astype(np.float32)
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
    )
)
