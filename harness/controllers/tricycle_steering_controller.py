"""``tricycle_steering_controller/TricycleSteeringController``: two traction wheels on one axle
(``traction_joints_names``: right, then left) and one steering joint, with ros2_controllers'
parameters: ``wheelbase``, ``traction_track_width``, ``traction_wheels_radius`` (the deprecated
``wheel_track`` and ``rear_wheels_radius``/``front_wheels_radius`` with ``front_steering``
too) and those of the steering library (:mod:`~harness.controllers.steering_library`).

The middle wheel's speed ``v / r`` is spread over the axle by the turning radius
``R = wheelbase / tan(steering)``: right ``* (R + track / 2) / R``, left ``* (R - track / 2) /
R``; odometry takes the mean of the two wheels' estimates of ``v``.

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

__all__ = ["TYPE_TRICYCLE_STEERING", "TricycleSteeringController", "axle_speeds", "axle_velocity"]

TYPE_TRICYCLE_STEERING = "tricycle_steering_controller/TricycleSteeringController"


def read_axle(p: Params) -> SteeringGeometry:
    """``wheelbase``, ``traction_wheels_radius`` and ``traction_track_width`` (or their
    deprecated names)."""
    if "traction_wheels_radius" in p.spec.params or "front_steering" not in p.spec.params:
        radius = p.number("traction_wheels_radius", 0.0, minimum=0.0)
    else:
        key = "rear_wheels_radius" if p.flag("front_steering", True) else "front_wheels_radius"
        radius = p.number(key, 0.0, minimum=0.0)
    track_key = "traction_track_width" if "wheel_track" not in p.spec.params else "wheel_track"
    track = p.number(track_key, 0.0, minimum=0.0)
    if track <= 0:
        raise p.error("traction_track_width must be given and positive")
    return SteeringGeometry(p.number("wheelbase", 0.0, minimum=0.0), radius, track)


def axle_speeds(geom: SteeringGeometry, v: float, steer: float) -> list[float]:
    """[right, left] wheel speeds (rad/s) of an axle whose middle moves at ``v`` with the
    virtual middle wheel steered by ``steer``."""
    ws = v / geom.radius
    if abs(steer) < 1e-6:
        return [ws, ws]
    radius = geom.wheelbase / math.tan(steer)
    return [ws * (radius + geom.track / 2) / radius, ws * (radius - geom.track / 2) / radius]


def axle_velocity(geom: SteeringGeometry, right: float, left: float, steer: float) -> float:
    """``v`` of the axle's middle from its wheels' speeds (the mean of their estimates)."""
    if abs(steer) < 1e-9:
        return (right + left) / 2 * geom.radius
    radius = geom.wheelbase / math.tan(steer)
    v_r = right * geom.radius * radius / (radius + geom.track / 2)
    v_l = left * geom.radius * radius / (radius - geom.track / 2)
    return (v_r + v_l) / 2


class TricycleSteeringController(SteeringController):
    """One tricycle steering controller (see the module docstring)."""

    traction_count = 2

    def geometry(self, p: Params) -> SteeringGeometry:
        """The axle's lengths."""
        return read_axle(p)

    def commands(self, v: float, w: float) -> tuple[list[float], list[float]]:
        """The axle's wheels by the turning radius, one steering angle."""
        steer = self.steering_angle(v, w)
        return axle_speeds(self.geom, v, steer), [steer]

    def measured(self, traction: Sequence[float], steering: Sequence[float]) -> tuple[float, float]:
        """``v`` from both wheels, ``w`` from the steering angle."""
        v = axle_velocity(self.geom, traction[0], traction[1], steering[0])
        return v, math.tan(steering[0]) * v / self.geom.wheelbase


@controller_type(TYPE_TRICYCLE_STEERING)
def _tricycle(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return TricycleSteeringController(spec, robot)
