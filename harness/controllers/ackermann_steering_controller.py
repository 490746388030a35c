"""``ackermann_steering_controller/AckermannSteeringController``: two traction wheels
(right, left) and two steering joints (right, left), with ros2_controllers' parameters:
``wheelbase``, ``traction_track_width``, ``steering_track_width`` (default: the traction
track), ``traction_wheels_radius`` and those of the steering library
(:mod:`~harness.controllers.steering_library`).

The traction wheels turn as the tricycle's; each steering joint takes its own Ackermann angle
``atan2(2 L sin(phi), 2 L cos(phi) +/- track sin(phi))`` (right +, left -) for the middle
wheel's ``phi``. Odometry estimates the middle angle from each steering joint's (the mean)
and ``w = tan(phi) * v / wheelbase``.

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
from harness.controllers.tricycle_steering_controller import (
    axle_speeds,
    axle_velocity,
    read_axle,
)

__all__ = ["TYPE_ACKERMANN_STEERING", "AckermannSteeringController"]

TYPE_ACKERMANN_STEERING = "ackermann_steering_controller/AckermannSteeringController"


class AckermannSteeringController(SteeringController):
    """One Ackermann steering controller (see the module docstring)."""

    traction_count = 2
    steering_count = 2

    def geometry(self, p: Params) -> SteeringGeometry:
        """The traction axle's lengths; ``steering_track_width`` for the steering axle."""
        geom = read_axle(p)
        self.steering_track = p.number("steering_track_width", geom.track, minimum=0.0)
        return geom

    def commands(self, v: float, w: float) -> tuple[list[float], list[float]]:
        """The axle's wheels by the turning radius, each steering joint its own angle."""
        phi = self.steering_angle(v, w)
        if abs(phi) < 1e-6:
            return [v / self.geom.radius] * 2, [phi, phi]
        length, track = self.geom.wheelbase, self.steering_track
        numerator = 2 * length * math.sin(phi)
        first, second = 2 * length * math.cos(phi), track * math.sin(phi)
        angles = [math.atan2(numerator, first + second), math.atan2(numerator, first - second)]
        return axle_speeds(self.geom, v, phi), angles

    def measured(self, traction: Sequence[float], steering: Sequence[float]) -> tuple[float, float]:
        """The middle angle from both steering joints, ``v`` from both wheels."""
        length, half = self.geom.wheelbase, self.steering_track / 2
        right = math.atan(length * math.tan(steering[0]) / (length - half * math.tan(steering[0])))
        left = math.atan(length * math.tan(steering[1]) / (length + half * math.tan(steering[1])))
        phi = (right + left) / 2
        v = axle_velocity(self.geom, traction[0], traction[1], phi)
        return v, math.tan(phi) * v / length


@controller_type(TYPE_ACKERMANN_STEERING)
def _ackermann(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return AckermannSteeringController(spec, robot)
