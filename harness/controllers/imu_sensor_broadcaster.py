"""``imu_sensor_broadcaster/IMUSensorBroadcaster``: ``~/imu`` (``sensor_msgs/msg/Imu``) from an
IMU's state interfaces, as ros2_controllers' broadcaster (a wrapper of the
``semantic_components::IMUSensor``) publishes it.

Parameters (the real ones): ``sensor_name`` (required: the IMU, the prefix of its interfaces
``<sensor_name>/orientation.x`` ... ``orientation.w``, ``angular_velocity.x..z``,
``linear_acceleration.x..z``), ``frame_id`` (required: the message's frame) and the
row-major 3x3 ``static_covariance_orientation``, ``static_covariance_angular_velocity``,
``static_covariance_linear_acceleration`` (default all zeros). Every controller update while
active publishes one message stamped at the update's simulation time, holding the values of the
sensor's last measurement (what the sensor itself published at that step, when their rates
agree). The sensor is one of the robot's declared sensors (URDF ``<gazebo>``, SDF, a
``sensors:`` list) whose kind has these state interfaces; a ``sensor_name`` without them is a
configuration error naming the interfaces the robot has.

This module is the whole of the controller: it registers its type and touches no other file.
"""

from __future__ import annotations

import math
from typing import Any

from harness.controllers.base import (
    Controller,
    ControllerBase,
    ControllerOutput,
    JointReadings,
    Publication,
    TopicEndpoint,
)
from harness.controllers.config import ControllerSpec
from harness.controllers.params import Params, stamp
from harness.controllers.registry import RobotInterfaces, controller_type

__all__ = ["IMU_STATE_INTERFACES", "TYPE_IMU_SENSOR_BROADCASTER", "ImuSensorBroadcaster"]

TYPE_IMU_SENSOR_BROADCASTER = "imu_sensor_broadcaster/IMUSensorBroadcaster"
TYPE_IMU = "sensor_msgs/msg/Imu"
IMU_STATE_INTERFACES = (
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
"""The interfaces of ``semantic_components::IMUSensor``, in its order."""
_COVARIANCES = ("orientation", "angular_velocity", "linear_acceleration")


class ImuSensorBroadcaster(ControllerBase):
    """One IMU sensor broadcaster (see the module docstring)."""

    reads_state = False
    """It reads the sensor's interfaces, never the joints."""

    def __init__(self, spec: ControllerSpec, robot: RobotInterfaces) -> None:
        super().__init__(spec.name, spec.type)
        p = Params(spec, robot.source)
        self.sensor_name = p.string("sensor_name")
        self.frame_id = p.string("frame_id")
        self.covariance = {key: self._covariance(p, key) for key in _COVARIANCES}
        self.state_interfaces = tuple(f"{self.sensor_name}/{i}" for i in IMU_STATE_INTERFACES)
        missing = [i for i in self.state_interfaces if i not in robot.sensors.names]
        if missing:
            raise p.error(
                f"sensor_name {self.sensor_name!r}: the robot has no state interface "
                f"{missing[0]!r} (sensor interfaces: {', '.join(robot.sensors.names) or 'none'})"
            )
        self.publishers = (TopicEndpoint("~/imu", TYPE_IMU),)
        self._sensors = robot.sensors

    @staticmethod
    def _covariance(p: Params, key: str) -> list[float]:
        name = f"static_covariance_{key}"
        value = p.get(name, [0.0] * 9)
        if (
            not isinstance(value, list | tuple)
            or len(value) != 9
            or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                for v in value
            )
        ):
            raise p.error(f"{name} must be 9 finite numbers (a row-major 3x3), not {value!r}")
        return [float(v) for v in value]

    def message(self, sim_time_ns: int) -> dict[str, Any]:
        """The ``sensor_msgs/msg/Imu`` of the sensor's current values."""
        values = self._sensors.values()
        ox, oy, oz, ow, gx, gy, gz, ax, ay, az = (values[i] for i in self.state_interfaces)
        return {
            "header": {"stamp": stamp(sim_time_ns), "frame_id": self.frame_id},
            "orientation": {"x": ox, "y": oy, "z": oz, "w": ow},
            "orientation_covariance": list(self.covariance["orientation"]),
            "angular_velocity": {"x": gx, "y": gy, "z": gz},
            "angular_velocity_covariance": list(self.covariance["angular_velocity"]),
            "linear_acceleration": {"x": ax, "y": ay, "z": az},
            "linear_acceleration_covariance": list(self.covariance["linear_acceleration"]),
        }

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput:
        """Publish the sensor's values."""
        out = ControllerOutput()
        if self.active:
            out.publications.append(Publication("~/imu", TYPE_IMU, self.message(state.sim_time_ns)))
        return out


@controller_type(TYPE_IMU_SENSOR_BROADCASTER)
def _imu_sensor_broadcaster(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return ImuSensorBroadcaster(spec, robot)
