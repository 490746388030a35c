"""``diff_drive_controller/DiffDriveController``, with ros2_controllers' parameter names and
semantics.

Input: ``geometry_msgs/msg/TwistStamped`` on ``~/cmd_vel`` (``use_stamped_vel: false`` takes
``geometry_msgs/msg/Twist``, as the Humble controller and most teleop tools send it); the
harness parameter ``cmd_vel_topic`` stands for a launch file's remapping (e.g.
``/cmd_vel``). Each command sets the body velocity (``linear.x``, ``angular.z``); the wheel
velocities are ``(v -/+ w * s / 2) / r`` with ``s = wheel_separation *
wheel_separation_multiplier`` and ``r = wheel_radius * {left,right}_wheel_radius_multiplier``,
the same on every wheel of a side. ``cmd_vel_timeout`` (seconds, default 0.5) after the last
command the wheels are commanded to stop. ``linear.x.*`` and ``angular.z.*`` limits
(``max_velocity``, ``min_velocity``, ``max_acceleration``, ``max_deceleration``) clamp the
command every update, as the controller's speed limiter does (jerk limits are not applied).

Output: ``nav_msgs/msg/Odometry`` on ``~/odom`` (``odom_topic`` remaps it) at
``publish_rate`` Hz, integrated from the wheels' encoder positions (the mean of each side's
wheels: a skid-steer base lists several per side), from their velocities with
``position_feedback: false`` (the ``velocity`` state interfaces, times the update period), or
from the commanded velocity with ``open_loop: true``; and, with ``enable_odom_tf`` (default
true), ``odom_frame_id`` -> ``base_frame_id`` on ``/tf``. As in ros2_controllers, both sides
name as many wheels, and ``wheels_per_side`` is read but the name lists decide (the controller
overwrites it with their length).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from harness.controllers.base import (
    Command,
    Controller,
    ControllerBase,
    ControllerOutput,
    JointReadings,
    LogLine,
    Publication,
)
from harness.controllers.config import ControllerSpec
from harness.controllers.odometry import BaseSettings, odometry_publications, read_twist
from harness.controllers.params import Params
from harness.controllers.registry import RobotInterfaces, controller_type

__all__ = ["TYPE_DIFF_DRIVE", "DiffDriveController", "Odometry", "SpeedLimits"]

TYPE_DIFF_DRIVE = "diff_drive_controller/DiffDriveController"
_NS = 1_000_000_000


def _nested(params: Mapping[str, Any], dotted: str) -> Any:
    """``params["a.b.c"]`` or ``params["a"]["b"]["c"]`` (a YAML file nests dotted names)."""
    if dotted in params:
        return params[dotted]
    value: Any = params
    for part in dotted.split("."):
        if not isinstance(value, Mapping) or part not in value:
            return None
        value = value[part]
    return value


class SpeedLimits:
    """One axis's limits (None: unlimited), applied as the controller's speed limiter."""

    def __init__(self, p: Params, axis: str) -> None:
        def limit(name: str) -> float | None:
            value = _nested(p.spec.params, f"{axis}.{name}")
            if value is None or (isinstance(value, float) and math.isnan(value)):
                return None
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise p.error(f"{axis}.{name} must be a number, not {value!r}")
            return float(value)

        self.max_velocity = limit("max_velocity")
        self.min_velocity = limit("min_velocity")
        self.max_acceleration = limit("max_acceleration")
        self.max_deceleration = limit("max_deceleration")

    def clamp(self, wanted: float, previous: float, dt: float) -> float:
        """``wanted`` limited in velocity, then in change from ``previous`` over ``dt``."""
        value = wanted
        if self.max_velocity is not None:
            value = min(value, self.max_velocity)
        low = (
            self.min_velocity
            if self.min_velocity is not None
            else (-self.max_velocity if self.max_velocity is not None else None)
        )
        if low is not None:
            value = max(value, low)
        if dt > 0:
            speeding_up = abs(value) > abs(previous)
            rate = self.max_acceleration if speeding_up else self.max_deceleration
            if rate is None and not speeding_up:
                rate = self.max_acceleration
            if rate is not None and rate > 0:
                step = rate * dt
                value = min(max(value, previous - step), previous + step)
        return value


class Odometry:
    """Planar pose integrated from wheel travel, as ros2_controllers' odometry: second-order
    Runge-Kutta for a small heading change, the exact arc otherwise."""

    def __init__(self) -> None:
        self.x = 0.0
        self.y = 0.0
        self.heading = 0.0
        self.linear = 0.0
        self.angular = 0.0

    def integrate(self, distance: float, rotation: float, dt: float) -> None:
        """Advance by ``distance`` along the heading and ``rotation`` about z over ``dt``."""
        if abs(rotation) < 1e-6:
            direction = self.heading + rotation * 0.5
            self.x += distance * math.cos(direction)
            self.y += distance * math.sin(direction)
            self.heading += rotation
        else:
            old = self.heading
            radius = distance / rotation
            self.heading += rotation
            self.x += radius * (math.sin(self.heading) - math.sin(old))
            self.y += -radius * (math.cos(self.heading) - math.cos(old))
        if dt > 0:
            self.linear = distance / dt
            self.angular = rotation / dt


class DiffDriveController(ControllerBase):
    """One diff drive controller (see the module docstring)."""

    def __init__(self, spec: ControllerSpec, source: str, controllable: Mapping[str, str]) -> None:
        super().__init__(spec.name, spec.type)
        p = Params(spec, source)
        self.left = p.joints(p.strings("left_wheel_names"), controllable)
        self.right = p.joints(p.strings("right_wheel_names"), controllable)
        if set(self.left) & set(self.right):
            raise p.error("a joint is both a left and a right wheel")
        if len(self.left) != len(self.right):
            raise p.error(
                f"the number of left wheels [{len(self.left)}] and the number of right wheels "
                f"[{len(self.right)}] are different"
            )
        p.number("wheels_per_side", 0, minimum=0)  # read, then the name lists decide
        self.separation = p.number("wheel_separation", 0.0, minimum=0.0) * p.number(
            "wheel_separation_multiplier", 1.0
        )
        radius = p.number("wheel_radius", 0.0, minimum=0.0)
        self.left_radius = radius * p.number("left_wheel_radius_multiplier", 1.0)
        self.right_radius = radius * p.number("right_wheel_radius_multiplier", 1.0)
        if self.separation <= 0 or self.left_radius <= 0 or self.right_radius <= 0:
            raise p.error("wheel_separation and wheel_radius must be given and positive")
        self.settings = BaseSettings.read(p)
        self.open_loop = p.flag("open_loop", False)
        self.position_feedback = p.flag("position_feedback", True)
        feedback = "position" if self.position_feedback else "velocity"
        self.linear_limits = SpeedLimits(p, "linear.x")
        self.angular_limits = SpeedLimits(p, "angular.z")
        self.subscriptions = self.settings.subscriptions
        self.publishers = self.settings.publishers
        self.command_interfaces = tuple(f"{j}/velocity" for j in (*self.left, *self.right))
        self.state_interfaces = tuple(f"{j}/{feedback}" for j in (*self.left, *self.right))
        self.odometry = Odometry()
        self.wanted = (0.0, 0.0)
        self.applied = (0.0, 0.0)
        self.last_command_ns: int | None = None
        self.last_publish_ns: int | None = None
        self.previous: tuple[float, float] | None = None

    def _sides(self, state: JointReadings, source: str = "position") -> tuple[float, float]:
        values = state.position if source == "position" else state.velocity
        left = sum(values[j] for j in self.left) / len(self.left)
        right = sum(values[j] for j in self.right) / len(self.right)
        return left, right

    def activate(self, state: JointReadings) -> ControllerOutput:
        """Start: odometry from the current wheel positions, zero velocity."""
        self.active = True
        self.previous = self._sides(state)
        self.wanted = self.applied = (0.0, 0.0)
        self.last_command_ns = None
        return ControllerOutput(commands=self._wheel_commands(0.0, 0.0))

    def deactivate(self, state: JointReadings) -> ControllerOutput:
        """Stop the wheels."""
        self.active = False
        return ControllerOutput(commands=self._wheel_commands(0.0, 0.0))

    def _wheel_commands(self, linear: float, angular: float) -> list[Command]:
        half = angular * self.separation / 2
        left = (linear - half) / self.left_radius
        right = (linear + half) / self.right_radius
        return [Command(j, velocity=left) for j in self.left] + [
            Command(j, velocity=right) for j in self.right
        ]

    def set_parameter(self, name: str, value: float) -> None:
        """Change a speed limit while running (``linear.x.`` or ``angular.z.`` +
        ``max_velocity``, ``min_velocity``, ``max_acceleration``, ``max_deceleration``; NaN:
        unlimited), from the next update on. Raises ``ValueError`` naming what is wrong."""
        axis, _, field = name.rpartition(".")
        limits = {"linear.x": self.linear_limits, "angular.z": self.angular_limits}.get(axis)
        fields = ("max_velocity", "min_velocity", "max_acceleration", "max_deceleration")
        if limits is None or field not in fields:
            raise ValueError(
                f"{self.name}: {name!r} is not a parameter that can change while running "
                f"(linear.x.* or angular.z.*: {', '.join(fields)})"
            )
        setattr(limits, field, None if math.isnan(value) else float(value))

    def on_message(
        self, topic: str, msg: Mapping[str, Any], connection: int, state: JointReadings
    ) -> ControllerOutput:
        """A velocity command: taken at the next update."""
        out = ControllerOutput()
        if not self.active:
            out.logs.append(LogLine(40, "inactive, command ignored", connection))
            return out
        twist = read_twist(
            msg, self.settings.stamped, (("linear", "x"), ("angular", "z")), connection
        )
        if isinstance(twist, LogLine):
            out.logs.append(twist)
            return out
        linear, angular = twist
        self.wanted = (linear, angular)
        self.last_command_ns = state.sim_time_ns
        return out

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput:
        """Odometry, the timeout, the speed limiter, the wheel commands, the publications."""
        out = ControllerOutput()
        if not self.active:
            return out
        dt = period_ns / _NS
        now = state.sim_time_ns
        sides = self._sides(state)
        if self.open_loop or self.previous is None:
            distance, rotation = self.applied[0] * dt, self.applied[1] * dt
        elif not self.position_feedback:
            speeds = self._sides(state, "velocity")
            d_left = speeds[0] * dt * self.left_radius
            d_right = speeds[1] * dt * self.right_radius
            distance = (d_left + d_right) / 2
            rotation = (d_right - d_left) / self.separation
        else:
            d_left = (sides[0] - self.previous[0]) * self.left_radius
            d_right = (sides[1] - self.previous[1]) * self.right_radius
            distance = (d_left + d_right) / 2
            rotation = (d_right - d_left) / self.separation
        self.previous = sides
        self.odometry.integrate(distance, rotation, dt)
        wanted = self.wanted
        if self.last_command_ns is None or now - self.last_command_ns > self.settings.timeout_ns:
            wanted = (0.0, 0.0)
        linear = self.linear_limits.clamp(wanted[0], self.applied[0], dt)
        angular = self.angular_limits.clamp(wanted[1], self.applied[1], dt)
        self.applied = (linear, angular)
        out.commands += self._wheel_commands(linear, angular)
        period = self.settings.publish_period_ns
        due = period == 0 or self.last_publish_ns is None
        due = due or now // period > (self.last_publish_ns or 0) // period  # each period's first
        if due:
            self.last_publish_ns = now
            out.publications += self._publications(now)
        return out

    def _publications(self, now: int) -> list[Publication]:
        o = self.odometry
        pose, velocity = (o.x, o.y, o.heading), (o.linear, 0.0, o.angular)
        return odometry_publications(self.settings.frames, now, pose, velocity)


@controller_type(TYPE_DIFF_DRIVE)
def _diff_drive(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return DiffDriveController(spec, robot.source, robot.controllable)
