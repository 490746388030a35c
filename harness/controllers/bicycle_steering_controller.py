"""``bicycle_steering_controller/BicycleSteeringController``: one traction wheel and one
steering joint (a car's virtual middle wheels, e.g. ros2_control_demos' example_11), with
ros2_controllers' parameters: ``wheelbase``, ``traction_wheel_radius`` (the deprecated
``rear_wheel_radius``/``front_wheel_radius`` with ``front_steering`` too) and those of the
steering library (:mod:`~harness.controllers.steering_library`).

The traction wheel turns at ``v / r``, the steering joint at ``atan(w * wheelbase / v)``;
odometry: ``v = wheel velocity * r``, ``w = tan(steering) * v / wheelbase``.

This module is the whole of the controller: it registers its type and touches no other file.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from harness.controllers.base import Controller
from harness.controllers.config import ControllerSpec
from harness.controllers.params import Params
from harness.controllers.registry import RobotInterfaces, controller_type
from harness.controllers.steering_library import SteeringController, SteeringGeometry

__all__ = ["TYPE_BICYCLE_STEERING", "BicycleSteeringController"]

TYPE_BICYCLE_STEERING = "bicycle_steering_controller/BicycleSteeringController"


class BicycleSteeringController(SteeringController):
    """One bicycle steering controller (see the module docstring)."""

    def geometry(self, p: Params) -> SteeringGeometry:
        """``wheelbase`` and ``traction_wheel_radius``."""
        if "traction_wheel_radius" in p.spec.params or "front_steering" not in p.spec.params:
            radius = p.number("traction_wheel_radius", 0.0, minimum=0.0)
        else:
            key = "rear_wheel_radius" if p.flag("front_steering", True) else "front_wheel_radius"
            radius = p.number(key, 0.0, minimum=0.0)
        return SteeringGeometry(p.number("wheelbase", 0.0, minimum=0.0), radius)

    def commands(self, v: float, w: float) -> tuple[list[float], list[float]]:
        """The wheel at ``v / r``, the steering at the middle wheel's angle."""
        return [v / self.geom.radius], [self.steering_angle(v, w)]

    def measured(self, traction: Sequence[float], steering: Sequence[float]) -> tuple[float, float]:
        """``v`` from the wheel, ``w`` from the steering angle."""
        v = traction[0] * self.geom.radius
        return v, math.tan(steering[0]) * v / self.geom.wheelbase


@controller_type(TYPE_BICYCLE_STEERING)
def _bicycle(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return BicycleSteeringController(spec, robot)
