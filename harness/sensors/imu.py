"""IMUs: ``sensor_msgs/Imu`` with the sensor frame's orientation in the world, its angular
velocity and its linear acceleration *including gravity* (at rest, +9.81 m/s^2 along the axis
that points up), both in the sensor frame. Gaussian noise (``noise_mean``/``noise_stddev``) is
added to each angular rate axis, and (``accel_noise_*``, default the same) to each acceleration
axis; the covariances are the variances. Gazebo's per-axis ``<imu>`` noise is read from the x
axes of ``angular_velocity`` and ``linear_acceleration``.

As ros2_control hardware, an IMU has the state interfaces of ``semantic_components::IMUSensor``
(``<name>/orientation.x`` ... ``<name>/linear_acceleration.z``): the values of its last
message, which a controller (``imu_sensor_broadcaster``) reads."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.sensors.base import F64, Mount, SensorTopic, View, cross, noise_rng, quat_of
from harness.sensors.errors import SensorConfigError
from harness.sensors.messages import TYPE_IMU, header, imu_msg
from harness.sensors.options import SensorOptions, check_positive
from harness.sensors.registry import Mounted, SensorKind, register_kind
from harness.sensors.sdf_values import element_noise
from harness.sensors.spec import SensorSpec

__all__ = ["IMU_INTERFACES", "ImuOptions", "ImuSensor", "body_motion"]

IMU_INTERFACES = (
    "orientation.x",
    "orientation.y",
    "orientation.z",
    "orientation.w",
    "angular_velocity.x",
    "angular_velocity.y",
    "angular_velocity.z",
    "linear_acceleration.x",
    "linear_acceleration.y",
    "linear_acceleration.z",
)
"""An IMU's state interfaces, in ros2_control's order."""


def body_motion(view: View, mount: Mount) -> tuple[F64, F64, F64, F64]:
    """(position, rotation, angular velocity, linear acceleration incl. gravity) of the
    mounted frame, in the world frame."""
    view.forces()
    model, data = view.model, view.data
    position, rotation = mount.world(data)
    vel = np.zeros(6)
    acc = np.zeros(6)
    xbody = mujoco.mjtObj.mjOBJ_XBODY
    mujoco.mj_objectVelocity(model, data, xbody, mount.body, vel, 0)
    mujoco.mj_objectAcceleration(model, data, xbody, mount.body, acc, 0)
    omega, alpha, acc_origin = vel[:3], acc[:3], acc[3:]
    r = position - data.xpos[mount.body]
    linear = acc_origin + cross(alpha, r) + cross(omega, cross(omega, r))
    return position, rotation, omega, linear


@dataclass(frozen=True)
class ImuOptions(SensorOptions):
    """An IMU's options: the Gaussian noise of each linear acceleration axis,
    ``accel_noise_mean``/``accel_noise_stddev`` (m/s^2), when it differs from the angular
    rate's (the spec's ``noise_mean``/``noise_stddev``; None: the same)."""

    accel_noise_mean: float | None = None
    accel_noise_stddev: float | None = None

    def __post_init__(self) -> None:
        if self.accel_noise_stddev is not None:
            check_positive("accel_noise_stddev", self.accel_noise_stddev, zero=True)
        mean = self.accel_noise_mean
        if mean is not None and not (isinstance(mean, int | float) and math.isfinite(mean)):
            raise SensorConfigError("accel_noise_mean must be a finite number")

    def accel_noise(self, mean: float, stddev: float) -> tuple[float, float]:
        """The acceleration's (mean, stddev), given the angular rate's."""
        return (
            mean if self.accel_noise_mean is None else self.accel_noise_mean,
            stddev if self.accel_noise_stddev is None else self.accel_noise_stddev,
        )


class ImuSensor:
    """An IMU of ``spec`` at ``mount``."""

    def __init__(
        self, spec: SensorSpec, mount: Mount, topics: Mapping[str, str], frame_id: str
    ) -> None:
        self.spec = spec
        self.mount = mount
        self.frame_id = frame_id
        self.outputs: tuple[SensorTopic, ...] = (SensorTopic("imu", topics["imu"], TYPE_IMU),)
        self.state_interfaces = IMU_INTERFACES

    def values(self, view: View) -> tuple[F64, F64, F64]:
        """(orientation w-x-y-z, angular velocity, linear acceleration) in the sensor frame."""
        spec = self.spec
        _, rotation, omega, linear = body_motion(view, self.mount)
        angular = rotation.T @ omega
        accel = rotation.T @ linear
        options = spec.options_as(ImuOptions)
        accel_mean, accel_std = options.accel_noise(spec.noise_mean, spec.noise_stddev)
        if spec.noise_stddev or spec.noise_mean or accel_std or accel_mean:
            unit = noise_rng(view.seed, spec.name, view.step).standard_normal(6)
            angular = angular + spec.noise_mean + spec.noise_stddev * unit[:3]
            accel = accel + accel_mean + accel_std * unit[3:]
        return quat_of(rotation), angular, accel

    def interface_values(self, view: View) -> tuple[float, ...]:
        """The values of :data:`IMU_INTERFACES` at this step (those of its message)."""
        quat, angular, accel = self.values(view)
        w, x, y, z = (float(v) for v in quat)
        return (x, y, z, w, *map(float, angular), *map(float, accel))

    def read(self, view: View) -> Mapping[str, Callable[[], dict[str, Any]]]:
        """The ``Imu`` builder at this step."""

        def imu() -> dict[str, Any]:
            quat, angular, accel = self.values(view)
            hdr = header(view.sim_time_ns, self.frame_id)
            spec = self.spec
            options = spec.options_as(ImuOptions)
            accel_std = options.accel_noise(spec.noise_mean, spec.noise_stddev)[1]
            return imu_msg(hdr, quat, angular, accel, spec.noise_stddev**2, accel_std**2)

        return {"imu": imu}

    def static_frames(self) -> list[tuple[str, F64, F64]]:
        """The sensor frame in the mount link."""
        return [(self.frame_id, self.mount.position, quat_of(self.mount.rotation))]


def _params(sensor: etree._Element, where: str) -> dict[str, Any]:
    imu = sensor.find("imu")
    gyro = imu.find("angular_velocity") if imu is not None else None
    accel = imu.find("linear_acceleration") if imu is not None else None
    params = element_noise(gyro if gyro is not None else imu, where)
    if accel is not None:
        params.update({f"accel_{k}": v for k, v in element_noise(accel, where).items()})
    return dict(params)


def _build(spec: SensorSpec, at: Mounted) -> ImuSensor:
    return ImuSensor(spec, at.mount, at.topics, at.frame_id)


register_kind(
    SensorKind("imu", ("imu",), 100.0, _build, gazebo=("imu",), params=_params, options=ImuOptions)
)
