"""What ros2_controllers' ``steering_controllers_library`` gives its three controllers
(:mod:`~harness.controllers.bicycle_steering_controller`,
:mod:`~harness.controllers.tricycle_steering_controller`,
:mod:`~harness.controllers.ackermann_steering_controller`): the parameters, the reference, the
odometry and the update, with the library's names and semantics.

Input: ``geometry_msgs/msg/TwistStamped`` on ``~/reference`` (``linear.x`` m/s, ``angular.z``
rad/s of the base). ``reference_timeout`` (seconds, default 1) after the last reference the
traction wheels are commanded to stop (the steering keeps its last angle). The steering angle
of the virtual middle wheel is ``atan(w * wheelbase / v)`` (0 when ``v`` is 0) and the traction
wheels turn at ``v / radius``; each configuration spreads these over its joints
(:meth:`SteeringController.commands`).

Joints: ``traction_joints_names`` (velocity command interfaces) and ``steering_joints_names``
(position), read from ``traction_joints_state_names`` / ``steering_joints_state_names`` when
given; the deprecated ``front_steering`` with ``rear_wheels_names``/``front_wheels_names`` are
read too. ``position_feedback`` (default false) integrates odometry from the traction wheels'
positions, else from their velocities; ``open_loop`` (default false) from the commanded
twist.

Output, every update while active: ``nav_msgs/msg/Odometry`` on ``~/odometry`` (twist: the
rolling mean over ``velocity_rolling_window_size`` updates; covariances from
``pose_covariance_diagonal``/``twist_covariance_diagonal``) and, with ``enable_odom_tf``
(default true), ``odom_frame_id`` -> ``base_frame_id`` on ``~/tf_odometry`` (a launch file
remaps it to ``/tf``; the harness parameter ``tf_topic`` does the same).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping, Sequence
from functools import partial
from typing import Any

from harness.controllers.base import (
    Command,
    ControllerBase,
    ControllerOutput,
    JointReadings,
    LogLine,
    Publication,
    TopicEndpoint,
)
from harness.controllers.config import ControllerSpec
from harness.controllers.diff_drive import Odometry
from harness.controllers.odometry import OdometryFrames, odometry_publications, read_twist
from harness.controllers.params import Params
from harness.controllers.registry import RobotInterfaces

__all__ = ["SteeringController", "SteeringGeometry"]

_NS = 1_000_000_000
_TWIST = "geometry_msgs/msg/TwistStamped"
_ODOM = "nav_msgs/msg/Odometry"
_TF = "tf2_msgs/msg/TFMessage"
_DIAGONAL = (0, 7, 14, 21, 28, 35)


def _msg_of(publication: Publication) -> Mapping[str, Any]:
    return publication.msg


class SteeringGeometry:
    """The lengths of one configuration: ``wheelbase``, the traction wheels' ``radius`` and
    ``track`` (the distance between the two traction wheels, 0 for one)."""

    def __init__(self, wheelbase: float, radius: float, track: float = 0.0) -> None:
        self.wheelbase = wheelbase
        self.radius = radius
        self.track = track


class SteeringController(ControllerBase):
    """One steering controller: the library's behaviour; a configuration subclass gives the
    joint counts (:attr:`traction_count`, :attr:`steering_count`), reads its geometry
    (:meth:`geometry`) and spreads the commands (:meth:`commands`)."""

    traction_count = 1
    steering_count = 1

    def __init__(self, spec: ControllerSpec, robot: RobotInterfaces) -> None:
        super().__init__(spec.name, spec.type)
        p = Params(spec, robot.source)
        self.params = p
        traction, steering = self._joint_names(p)
        self.traction = p.joints(traction, robot.controllable)
        self.steering = p.joints(steering, robot.controllable)
        for names, count, what in (
            (self.traction, self.traction_count, "traction_joints_names"),
            (self.steering, self.steering_count, "steering_joints_names"),
        ):
            if len(names) != count:
                raise p.error(f"{what} must name {count} joint(s), not {len(names)}")
        if set(self.traction) & set(self.steering):
            raise p.error("a joint is both a traction and a steering joint")
        self.traction_state = p.strings("traction_joints_state_names", ()) or self.traction
        self.steering_state = p.strings("steering_joints_state_names", ()) or self.steering
        for names, what in (
            (self.traction_state, "traction_joints_state_names"),
            (self.steering_state, "steering_joints_state_names"),
        ):
            if len(names) != len(self.traction if "traction" in what else self.steering):
                raise p.error(f"{what} must name as many joints as the command names")
            for name in names:
                if name not in robot.joints:
                    raise p.error(f"{what}: the robot has no joint {name!r}")
        self.geom = self.geometry(p)
        if self.geom.wheelbase <= 0 or self.geom.radius <= 0:
            raise p.error("wheelbase and the traction wheel radius must be given and positive")
        self.timeout_ns = round(p.number("reference_timeout", 1.0, minimum=0.0) * _NS)
        self.open_loop = p.flag("open_loop", False)
        self.position_feedback = p.flag("position_feedback", False)
        window = p.number("velocity_rolling_window_size", 10, minimum=1)
        self.window = int(window)
        odom_tf = p.flag("enable_odom_tf", True)
        self.frames = OdometryFrames(
            p.string("odom_topic", "~/odometry"),
            p.string("odom_frame_id", "odom"),
            p.string("base_frame_id", "base_link"),
            odom_tf,
        )
        self.tf_topic = p.string("tf_topic", "~/tf_odometry")
        self.pose_covariance = self._diagonal(p, "pose_covariance_diagonal")
        self.twist_covariance = self._diagonal(p, "twist_covariance_diagonal")
        feedback = "position" if self.position_feedback else "velocity"
        self.command_interfaces = (
            *(f"{j}/velocity" for j in self.traction),
            *(f"{j}/position" for j in self.steering),
        )
        self.state_interfaces = (
            *(f"{j}/{feedback}" for j in self.traction_state),
            *(f"{j}/position" for j in self.steering_state),
        )
        self.subscriptions = (TopicEndpoint(p.string("reference_topic", "~/reference"), _TWIST),)
        publishers = [TopicEndpoint(self.frames.topic, _ODOM)]
        if odom_tf:
            publishers.append(TopicEndpoint(self.tf_topic, _TF))
        self.publishers = tuple(publishers)
        self.odometry = Odometry()
        self._linear: deque[float] = deque(maxlen=self.window)
        self._angular: deque[float] = deque(maxlen=self.window)
        self.reference: tuple[float, float] | None = None
        self.reference_ns = 0
        self.last_command = (0.0, 0.0)
        self.steer = [0.0] * self.steering_count
        self._previous: list[float] | None = None

    # ------------------------------------------------------------------ configuration hooks

    def _joint_names(self, p: Params) -> tuple[tuple[str, ...], tuple[str, ...]]:
        if "traction_joints_names" in p.spec.params or "front_steering" not in p.spec.params:
            return p.strings("traction_joints_names"), p.strings("steering_joints_names")
        rear, front = p.strings("rear_wheels_names"), p.strings("front_wheels_names")
        return (rear, front) if p.flag("front_steering", True) else (front, rear)

    def geometry(self, p: Params) -> SteeringGeometry:
        """The configuration's lengths from its parameters."""
        raise NotImplementedError

    def commands(self, v: float, w: float) -> tuple[list[float], list[float]]:
        """(traction wheel velocities in rad/s, steering angles in rad) for body velocity
        ``v``, ``w``: the library's ``get_commands``."""
        raise NotImplementedError

    def measured(self, traction: Sequence[float], steering: Sequence[float]) -> tuple[float, float]:
        """(v, w) of the base from the traction wheels' velocities (rad/s) and the steering
        angles: the library's ``update_from_velocity``."""
        raise NotImplementedError

    # ----------------------------------------------------------------------------- helpers

    @staticmethod
    def _diagonal(p: Params, key: str) -> list[float]:
        value = p.get(key, [0.0, 7.0, 14.0, 21.0, 28.0, 35.0])
        if (
            not isinstance(value, list | tuple)
            or len(value) != 6
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
        ):
            raise p.error(f"{key} must be 6 numbers, not {value!r}")
        matrix = [0.0] * 36
        for index, v in zip(_DIAGONAL, value, strict=True):
            matrix[index] = float(v)
        return matrix

    def steering_angle(self, v: float, w: float) -> float:
        """The virtual middle wheel's steering angle for ``v``, ``w``."""
        if abs(v) < 1.1920929e-07:  # float epsilon, as the library
            return 0.0
        return math.atan(w * self.geom.wheelbase / v)

    def _traction_values(self, state: JointReadings) -> list[float]:
        source = state.position if self.position_feedback else state.velocity
        return [source[j] for j in self.traction_state]

    # ----------------------------------------------------------------------------- lifecycle

    def activate(self, state: JointReadings) -> ControllerOutput:
        """Start: no reference, odometry from here."""
        self.active = True
        self.reference = None
        self._previous = self._traction_values(state) if self.position_feedback else None
        self.steer = [state.position[j] for j in self.steering_state]
        return ControllerOutput()

    def deactivate(self, state: JointReadings) -> ControllerOutput:
        """Stop the traction wheels."""
        self.active = False
        return ControllerOutput(commands=[Command(j, velocity=0.0) for j in self.traction])

    def on_message(
        self, topic: str, msg: Mapping[str, Any], connection: int, state: JointReadings
    ) -> ControllerOutput:
        """A reference: taken at the next update."""
        out = ControllerOutput()
        if not self.active:
            out.logs.append(LogLine(40, "inactive, reference ignored", connection))
            return out
        twist = read_twist(msg, True, (("linear", "x"), ("angular", "z")), connection)
        if isinstance(twist, LogLine):
            out.logs.append(twist)
            return out
        self.reference = (twist[0], twist[1])
        self.reference_ns = state.sim_time_ns
        return out

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput:
        """Odometry, then the commands of the reference (stop after the timeout)."""
        out = ControllerOutput()
        if not self.active:
            return out
        dt = period_ns / _NS
        self._integrate(state, dt)
        now = state.sim_time_ns
        reference = self.reference
        if reference is not None and now - self.reference_ns > self.timeout_ns:
            reference = self.reference = None
        if reference is None:
            self.last_command = (0.0, 0.0)
            out.commands += [Command(j, velocity=0.0) for j in self.traction]
            out.commands += [
                Command(j, position=a) for j, a in zip(self.steering, self.steer, strict=True)
            ]
        else:
            self.last_command = reference
            wheels, angles = self.commands(*reference)
            self.steer = angles
            out.commands += [
                Command(j, velocity=v) for j, v in zip(self.traction, wheels, strict=True)
            ]
            out.commands += [
                Command(j, position=a) for j, a in zip(self.steering, angles, strict=True)
            ]
        out.publications += self._publications(now)
        return out

    def _integrate(self, state: JointReadings, dt: float) -> None:
        if dt <= 0:
            return
        if self.open_loop:
            v, w = self.last_command
            self.odometry.integrate(v * dt, w * dt, dt)
            self.odometry.linear, self.odometry.angular = v, w
            return
        traction = self._traction_values(state)
        if self.position_feedback:
            previous = self._previous if self._previous is not None else traction
            self._previous = traction
            traction = [(now - before) / dt for now, before in zip(traction, previous, strict=True)]
        steering = [state.position[j] for j in self.steering_state]
        v, w = self.measured(traction, steering)
        self.odometry.integrate(v * dt, w * dt, dt)
        self._linear.append(v)
        self._angular.append(w)
        self.odometry.linear = sum(self._linear) / len(self._linear)
        self.odometry.angular = sum(self._angular) / len(self._angular)

    def _publications(self, now: int) -> list[Publication]:
        o = self.odometry
        pose_covariance = list(self.pose_covariance)
        twist_covariance = list(self.twist_covariance)

        def with_covariances(plain: Publication) -> dict[str, Any]:
            msg = dict(plain.msg)
            msg["pose"] = {**msg["pose"], "covariance": pose_covariance}
            msg["twist"] = {**msg["twist"], "covariance": twist_covariance}
            return msg

        out = []
        for pub in odometry_publications(
            self.frames, now, (o.x, o.y, o.heading), (o.linear, 0.0, o.angular)
        ):
            if pub.type == _ODOM:
                build = partial(with_covariances, pub)
                out.append(Publication(pub.topic, pub.type, build=build))
            else:  # built when published
                out.append(Publication(self.tf_topic, pub.type, build=partial(_msg_of, pub)))
        return out
