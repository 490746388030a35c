"""A planar (holonomic) base controller, the counterpart of Gazebo Classic's
``libgazebo_ros_planar_move.so``: the commanded body velocity is applied directly to the
robot's floating base, a kinematic write of its free joint recorded with every step's applied
input (:class:`~harness.sim.planar.PlanarBase`), so a run replays bit for bit.

Parameters (diff_drive's names where they mean the same): ``cmd_vel_topic`` (default
``~/cmd_vel``), ``use_stamped_vel`` (default true: ``geometry_msgs/msg/TwistStamped``; false:
``Twist``), ``cmd_vel_timeout`` (seconds, default 0.5: the base stops after it),
``linear.x.*``, ``linear.y.*`` and ``angular.z.*`` speed limits, ``odom_topic`` (``~/odom``),
``publish_rate`` (50 Hz), ``odom_frame_id``, ``base_frame_id``, ``enable_odom_tf``, and
``base_joint`` (the free joint, default ``<base_frame_id>::__free__``). Odometry integrates
the applied command (the base follows it exactly).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from harness.controllers.base import (
    BaseVelocity,
    Controller,
    ControllerBase,
    ControllerOutput,
    JointReadings,
    LogLine,
    Publication,
)
from harness.controllers.config import ControllerSpec
from harness.controllers.diff_drive import SpeedLimits
from harness.controllers.odometry import BaseSettings, odometry_publications, read_twist
from harness.controllers.params import Params
from harness.controllers.registry import RobotInterfaces, controller_type

__all__ = ["TYPE_PLANAR", "PlanarController"]

TYPE_PLANAR = "planar_controller/PlanarController"
_NS = 1_000_000_000
_FREE = "::__free__"


class PlanarController(ControllerBase):
    """One planar base controller (see the module docstring)."""

    def __init__(self, spec: ControllerSpec, source: str) -> None:
        super().__init__(spec.name, spec.type)
        p = Params(spec, source)
        self.settings = BaseSettings.read(p)
        self.base_joint = p.string("base_joint", self.settings.frames.base_frame + _FREE)
        self.limits = (
            SpeedLimits(p, "linear.x"),
            SpeedLimits(p, "linear.y"),
            SpeedLimits(p, "angular.z"),
        )
        self.subscriptions = self.settings.subscriptions
        self.publishers = self.settings.publishers
        self.wanted = (0.0, 0.0, 0.0)
        self.applied = (0.0, 0.0, 0.0)
        self.pose = [0.0, 0.0, 0.0]  # x, y, heading in the odometry frame
        self.last_command_ns: int | None = None
        self.last_publish_ns: int | None = None

    def _base(self, velocity: tuple[float, float, float]) -> BaseVelocity:
        return BaseVelocity(self.base_joint, *velocity)

    def activate(self, state: JointReadings) -> ControllerOutput:
        """Start at rest."""
        self.active = True
        self.wanted = self.applied = (0.0, 0.0, 0.0)
        self.last_command_ns = None
        return ControllerOutput(base=self._base(self.applied))

    def deactivate(self, state: JointReadings) -> ControllerOutput:
        """Stop the base."""
        self.active = False
        self.applied = (0.0, 0.0, 0.0)
        return ControllerOutput(base=self._base(self.applied))

    def on_message(
        self, topic: str, msg: Mapping[str, Any], connection: int, state: JointReadings
    ) -> ControllerOutput:
        """A velocity command: taken at the next update."""
        out = ControllerOutput()
        if not self.active:
            out.logs.append(LogLine(40, "inactive, command ignored", connection))
            return out
        axes = (("linear", "x"), ("linear", "y"), ("angular", "z"))
        twist = read_twist(msg, self.settings.stamped, axes, connection)
        if isinstance(twist, LogLine):
            out.logs.append(twist)
            return out
        wanted = (twist[0], twist[1], twist[2])
        self.wanted = wanted
        self.last_command_ns = state.sim_time_ns
        return out

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput:
        """Odometry, the timeout, the speed limits, the base velocity, the publications."""
        out = ControllerOutput()
        if not self.active:
            return out
        dt = period_ns / _NS
        now = state.sim_time_ns
        vx, vy, wz = self.applied
        x, y, heading = self.pose
        cos, sin = math.cos(heading), math.sin(heading)
        self.pose = [x + (vx * cos - vy * sin) * dt, y + (vx * sin + vy * cos) * dt,
                     heading + wz * dt]  # fmt: skip
        wanted = self.wanted
        if self.last_command_ns is None or now - self.last_command_ns > self.settings.timeout_ns:
            wanted = (0.0, 0.0, 0.0)
        applied = tuple(
            lim.clamp(w, a, dt) for lim, w, a in zip(self.limits, wanted, self.applied, strict=True)
        )
        if applied != self.applied:
            out.base = self._base((applied[0], applied[1], applied[2]))
        self.applied = (applied[0], applied[1], applied[2])
        period = self.settings.publish_period_ns
        due = period == 0 or self.last_publish_ns is None
        due = due or now // period > (self.last_publish_ns or 0) // period  # each period's first
        if due:
            self.last_publish_ns = now
            out.publications += self._publications(now)
        return out

    def _publications(self, now: int) -> list[Publication]:
        x, y, heading = self.pose
        return odometry_publications(self.settings.frames, now, (x, y, heading), self.applied)


@controller_type(TYPE_PLANAR)
def _planar(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return PlanarController(spec, robot.source)
