"""``force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster``: ``~/wrench``
(``geometry_msgs/msg/WrenchStamped``) from a force-torque sensor's state interfaces, as
ros2_controllers' broadcaster (a wrapper of ``semantic_components::ForceTorqueSensor``)
publishes it.

Parameters (the real ones): ``frame_id`` (required: the message's frame) and either
``sensor_name`` (the six interfaces ``<sensor_name>/force.x`` ... ``torque.z``) or
``interface_names.force.x`` ... ``interface_names.torque.z`` (any subset, each a full state
interface name; an axis not named is NaN in the message, as the semantic component leaves it);
both or neither is a configuration error, as in the real controller. Every controller update
while active publishes one message stamped at the update's simulation time with the sensor's
last measurement. The sensor is one of the robot's force-torque sensors: a Gazebo/SDF
``force_torque`` sensor, a ``sensors:`` entry, or a ``<ros2_control>`` ``<sensor>`` with
force/torque state interfaces (:mod:`harness.sensors.ros2_control_sensors`); an interface the
robot lacks is a configuration error naming the interfaces it has.

This module is the whole of the controller: it registers its type and touches no other file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
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

__all__ = ["FT_AXES", "TYPE_FORCE_TORQUE_SENSOR_BROADCASTER", "ForceTorqueSensorBroadcaster"]

TYPE_FORCE_TORQUE_SENSOR_BROADCASTER = (
    "force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster"
)
TYPE_WRENCH = "geometry_msgs/msg/WrenchStamped"
FT_AXES = ("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z")
"""The semantic component's interfaces, in its order."""


def _dotted(params: Mapping[str, Any], dotted: str) -> Any:
    """``params["a.b.c"]`` or ``params["a"]["b"]["c"]`` (a YAML file may nest dotted names)."""
    if dotted in params:
        return params[dotted]
    value: Any = params
    for part in dotted.split("."):
        if not isinstance(value, Mapping) or part not in value:
            return None
        value = value[part]
    return value


class ForceTorqueSensorBroadcaster(ControllerBase):
    """One force-torque sensor broadcaster (see the module docstring)."""

    reads_state = False
    """It reads the sensor's interfaces, never the joints."""

    def __init__(self, spec: ControllerSpec, robot: RobotInterfaces) -> None:
        super().__init__(spec.name, spec.type)
        p = Params(spec, robot.source)
        self.frame_id = p.string("frame_id")
        sensor_name = p.get("sensor_name", "")
        named = {axis: _dotted(spec.params, f"interface_names.{axis}") for axis in FT_AXES}
        named = {axis: value for axis, value in named.items() if value not in (None, "")}
        if sensor_name and named:
            raise p.error("give sensor_name or interface_names, not both")
        if sensor_name:
            if not isinstance(sensor_name, str):
                raise p.error(f"sensor_name must be a name, not {sensor_name!r}")
            self.axes: dict[str, str] = {axis: f"{sensor_name}/{axis}" for axis in FT_AXES}
        elif named:
            for axis, value in named.items():
                if not isinstance(value, str):
                    raise p.error(f"interface_names.{axis} must be an interface name")
            self.axes = {axis: str(value) for axis, value in named.items()}
        else:
            raise p.error("sensor_name or interface_names.<force|torque>.<x|y|z> is required")
        self.state_interfaces = tuple(self.axes.values())
        missing = [i for i in self.state_interfaces if i not in robot.sensors.names]
        if missing:
            raise p.error(
                f"the robot has no state interface {missing[0]!r} "
                f"(sensor interfaces: {', '.join(robot.sensors.names) or 'none'})"
            )
        self.publishers = (TopicEndpoint("~/wrench", TYPE_WRENCH),)
        self._sensors = robot.sensors

    def message(self, sim_time_ns: int) -> dict[str, Any]:
        """The ``geometry_msgs/msg/WrenchStamped`` of the sensor's current values."""
        values = self._sensors.values()
        v = {axis: values[name] for axis, name in self.axes.items()}
        fx, fy, fz, tx, ty, tz = (v.get(axis, math.nan) for axis in FT_AXES)
        return {
            "header": {"stamp": stamp(sim_time_ns), "frame_id": self.frame_id},
            "wrench": {
                "force": {"x": fx, "y": fy, "z": fz},
                "torque": {"x": tx, "y": ty, "z": tz},
            },
        }

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput:
        """Publish the sensor's values."""
        out = ControllerOutput()
        if self.active:
            out.publications.append(
                Publication("~/wrench", TYPE_WRENCH, self.message(state.sim_time_ns))
            )
        return out


@controller_type(TYPE_FORCE_TORQUE_SENSOR_BROADCASTER)
def _force_torque_sensor_broadcaster(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return ForceTorqueSensorBroadcaster(spec, robot)
