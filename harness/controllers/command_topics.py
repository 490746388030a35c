"""The command topics: what they do to the simulation (sans-I/O: messages in, simulation
commands out) and one robot's topics bound together (:class:`RobotCommands`).

Three command styles, all taking effect at the next step boundary:

- ``sensor_msgs/msg/JointState`` on ``joint_command`` (the original framework's
  JointStateSubscriber): for each ``name[i]``, ``effort[i]``, ``velocity[i]`` and
  ``position[i]`` apply where that index exists; the field matching the joint's control mode
  is used (``position`` for kinematic and position joints, ``velocity``, ``effort``).
- ``std_msgs/msg/Float64MultiArray`` on the ros2_control-style forward command topics
  (:data:`FORWARD_TOPICS`): one value per controllable joint of the robot, in the simulation's
  joint order (``joint_names`` of the :class:`CommandTarget`).
- ``trajectory_msgs/msg/JointTrajectory`` on ``joint_trajectory``: see :class:`Trajectory`.

A message that names an unknown joint, has a wrong array length or a non-finite value is
refused as a whole (:class:`~harness.controllers.errors.CommandRefused`; nothing changes). Values
beyond a joint's limits are clamped by the simulation (dynamic modes always, kinematic mode when
``kinematic_limits="clamp"``) and reported as :class:`~harness.sim.Notice`\\ s.

Each function acts on a :class:`CommandTarget`: a :class:`~harness.sim.Simulation` (every joint,
MuJoCo names) or one robot's :class:`~harness.sim.RobotJoints` (its own, unprefixed, names).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from harness.controllers.errors import CommandRefused
from harness.controllers.listed import ListedJoints
from harness.models.description import ControlMode
from harness.sim import CommandError, CommandField, Notice, RobotJoints

__all__ = [
    "FORWARD_TOPICS",
    "CommandTarget",
    "Reporter",
    "RobotCommands",
    "Trajectory",
    "apply_forward",
    "apply_joint_state",
    "parse_trajectory",
]

F64 = npt.NDArray[np.float64]

FORWARD_TOPICS: Mapping[CommandField, str] = {
    "position": "forward_position_controller/commands",
    "velocity": "forward_velocity_controller/commands",
    "effort": "forward_effort_controller/commands",
}
"""Forward command topic (relative to the robot's namespace) per commanded field."""


class CommandTarget(Protocol):
    """The joints a command topic drives (:class:`~harness.sim.Simulation` or
    :class:`~harness.sim.RobotJoints`)."""

    @property
    def joint_names(self) -> tuple[str, ...]: ...

    @property
    def control(self) -> Mapping[str, ControlMode]: ...

    def joint_positions(self) -> F64: ...

    def joint_commands(self) -> F64: ...

    def set_positions(self, positions: Mapping[str, float]) -> list[Notice]: ...

    def set_velocities(self, velocities: Mapping[str, float]) -> list[Notice]: ...

    def set_efforts(self, efforts: Mapping[str, float]) -> list[Notice]: ...

    def command_joint_state(
        self,
        name: Sequence[str],
        position: Sequence[float] = (),
        velocity: Sequence[float] = (),
        effort: Sequence[float] = (),
    ) -> list[Notice]: ...


def _duration_ns(value: Mapping[str, Any]) -> int:
    return int(value["sec"]) * 1_000_000_000 + int(value["nanosec"])


def _check_names(names: Sequence[str], what: str) -> None:
    """Refuse a command that names a joint twice (which value would win is arbitrary)."""
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise CommandRefused(f"{what} names joint {name!r} twice")
        seen.add(name)


def apply_joint_state(sim: CommandTarget, msg: Mapping[str, Any]) -> list[Notice]:
    """Apply a ``sensor_msgs/msg/JointState`` command (canonical rosbridge dict)."""
    _check_names(msg["name"], "joint state command")
    try:
        return sim.command_joint_state(msg["name"], msg["position"], msg["velocity"], msg["effort"])
    except CommandError as exc:
        raise CommandRefused(str(exc)) from None


def apply_forward(sim: CommandTarget, field: CommandField, msg: Mapping[str, Any]) -> list[Notice]:
    """Apply a ``std_msgs/msg/Float64MultiArray`` forward command of ``field``."""
    data: Sequence[float] = msg["data"]
    names = sim.joint_names
    if len(data) != len(names):
        raise CommandRefused(
            f"expected {len(names)} values (one per joint: {', '.join(names)}), got {len(data)}"
        )
    values = dict(zip(names, data, strict=True))
    try:
        if field == "position":
            return sim.set_positions(values)
        if field == "velocity":
            return sim.set_velocities(values)
        return sim.set_efforts(values)
    except CommandError as exc:
        raise CommandRefused(str(exc)) from None


@dataclass(frozen=True)
class Trajectory:
    """An accepted joint trajectory, interpolated in simulation time.

    Interpolation is **linear in position** between knots (``times_ns``, absolute simulation
    times): the first knot is the joints' commanded position when the trajectory was accepted
    (at its start time), then one knot per point at ``start + time_from_start``. Before the first
    knot the first knot's positions hold, after the last one the last positions hold. The
    velocity of a segment is its constant slope. Position and kinematic joints are commanded the
    interpolated position, velocity joints the segment's velocity (``fields``); the points'
    ``velocities``, ``accelerations`` and ``effort`` are not used.
    """

    joints: tuple[str, ...]
    fields: tuple[CommandField, ...]
    times_ns: tuple[int, ...]
    positions: F64  # (knots, joints)

    @property
    def end_ns(self) -> int:
        """The time of the last knot."""
        return self.times_ns[-1]

    def setpoint(self, t_ns: int) -> tuple[F64, F64]:
        """Positions and velocities of :attr:`joints` at simulation time ``t_ns``."""
        times = self.times_ns
        i = bisect.bisect_right(times, t_ns) - 1
        if i < 0:
            return self.positions[0].copy(), np.zeros(len(self.joints))
        if i >= len(times) - 1:
            return self.positions[-1].copy(), np.zeros(len(self.joints))
        t0, t1 = times[i], times[i + 1]
        p0, p1 = self.positions[i], self.positions[i + 1]
        u = (t_ns - t0) / (t1 - t0)
        position: F64 = p0 + (p1 - p0) * u
        velocity: F64 = (p1 - p0) / ((t1 - t0) / 1e9)
        return position, velocity

    def commands(self, t_ns: int) -> tuple[dict[str, float], dict[str, float]]:
        """``(positions, velocities)`` to command at ``t_ns``: each joint in one of them."""
        position, velocity = self.setpoint(t_ns)
        positions: dict[str, float] = {}
        velocities: dict[str, float] = {}
        for j, (name, field) in enumerate(zip(self.joints, self.fields, strict=True)):
            if field == "velocity":
                velocities[name] = float(velocity[j])
            else:
                positions[name] = float(position[j])
        return positions, velocities

    def without(self, joints: set[str]) -> Trajectory | None:
        """This trajectory minus ``joints`` (None when no joint is left)."""
        keep = [j for j, name in enumerate(self.joints) if name not in joints]
        if len(keep) == len(self.joints):
            return self
        if not keep:
            return None
        return Trajectory(
            tuple(self.joints[j] for j in keep),
            tuple(self.fields[j] for j in keep),
            self.times_ns,
            self.positions[:, keep],
        )


def parse_trajectory(sim: CommandTarget, msg: Mapping[str, Any], now_ns: int) -> Trajectory:
    """Validate a ``trajectory_msgs/msg/JointTrajectory`` (canonical rosbridge dict) received at
    simulation time ``now_ns``. It starts at ``header.stamp`` when that is non-zero, else at
    ``now_ns``."""
    names: list[str] = list(msg["joint_names"])
    points: list[Mapping[str, Any]] = list(msg["points"])
    if not names:
        raise CommandRefused("trajectory names no joints")
    if not points:
        raise CommandRefused("trajectory has no points")
    _check_names(names, "trajectory")
    index = {n: i for i, n in enumerate(sim.joint_names)}
    control = sim.control
    fields: list[CommandField] = []
    for name in names:
        if name not in index:
            known = ", ".join(sim.joint_names) or "none"
            raise CommandRefused(f"unknown joint {name!r} (controllable joints: {known})")
        mode = control[name]
        if mode == "effort":
            raise CommandRefused(
                f"joint {name!r} is effort-controlled: a trajectory cannot drive it "
                "(use the effort forward command or joint_command)"
            )
        fields.append("velocity" if mode == "velocity" else "position")

    start = _duration_ns(msg["header"]["stamp"]) or now_ns
    rows = [index[n] for n in names]
    current = sim.joint_commands()
    measured = sim.joint_positions()
    first: list[float] = [
        float(measured[r] if f == "velocity" else current[r])
        for r, f in zip(rows, fields, strict=True)
    ]
    times = [start]
    knots = [first]
    previous = -1
    for i, point in enumerate(points):
        positions: Sequence[float] = point["positions"]
        if len(positions) != len(names):
            raise CommandRefused(
                f"point {i} has {len(positions)} positions for {len(names)} joints"
            )
        for name, value in zip(names, positions, strict=True):
            if not math.isfinite(value):
                raise CommandRefused(f"point {i}: position of joint {name!r} is {value!r}")
        # Unused here, but refused like positions: every command topic checks every value.
        for field in ("velocities", "accelerations", "effort"):
            for j, value in enumerate(point.get(field, ())):
                if not math.isfinite(value):
                    joint = repr(names[j]) if j < len(names) else f"#{j}"
                    raise CommandRefused(f"point {i}: {field} of joint {joint} is {value!r}")
        offset = _duration_ns(point["time_from_start"])
        if offset < 0 or offset <= previous:
            raise CommandRefused(
                f"point {i}: time_from_start {offset / 1e9:g} s must be >= 0 and after the "
                "previous point's"
            )
        previous = offset
        if offset == 0:
            knots[0] = [float(v) for v in positions]
            continue
        times.append(start + offset)
        knots.append([float(v) for v in positions])
    return Trajectory(tuple(names), tuple(fields), tuple(times), np.array(knots, dtype=np.float64))


class Reporter(Protocol):
    """Where a robot's command topics report (the session: a ``status`` to the sending client
    when ``connection`` is not 0, and a log event)."""

    def refuse(self, topic: str, connection: int, reason: str) -> None:
        """A command on ``topic`` was refused as a whole (``reason``)."""
        ...

    def notices(self, topic: str, connection: int, notices: Sequence[Notice]) -> None:
        """A command on ``topic`` was applied with ``notices`` (values clamped...)."""
        ...


MessageHandler = Callable[[Mapping[str, Any], int], None]


class RobotCommands:
    """One robot's command topics: ``joint_command`` (``sensor_msgs/msg/JointState``, joints
    listed but not controllable dropped by ``listed``), the forward commands and
    ``joint_trajectory`` (the trajectory in progress, driven by :meth:`setpoint` before each
    step). ``positions`` returns the positions of the joints ``listed`` knows (in its order);
    every refusal and notice goes to ``report``."""

    def __init__(
        self,
        joints: RobotJoints,
        listed: ListedJoints,
        positions: Callable[[], F64],
        report: Reporter,
        *,
        joint_command: str,
        joint_trajectory: str,
    ) -> None:
        self.joints = joints
        self.listed = listed
        self._positions = positions
        self._report = report
        self.joint_command_topic = joint_command
        self.joint_trajectory_topic = joint_trajectory
        self.trajectory: Trajectory | None = None
        self.trajectory_topic = ""
        self.trajectory_warned: set[str] = set()

    def drop_from_trajectory(self, joints: Iterable[str]) -> None:
        """Stop the trajectory driving ``joints`` (the robot's own names)."""
        if self.trajectory is not None:
            self.trajectory = self.trajectory.without(set(joints))

    def _command(
        self,
        topic: str,
        connection: int,
        apply: Callable[[], list[Notice]],
        joints: Iterable[str],
    ) -> None:
        try:
            notices = apply()
        except CommandRefused as exc:
            self._report.refuse(topic, connection, str(exc))
            return
        self.drop_from_trajectory(joints)
        self._report.notices(topic, connection, notices)

    def on_joint_command(self, msg: Mapping[str, Any], connection: int) -> None:
        """A ``joint_command`` message from ``connection``."""

        def apply() -> list[Notice]:
            stripped, notices = self.listed.strip(msg, self._positions())
            return notices + apply_joint_state(self.joints, stripped)

        self._command(self.joint_command_topic, connection, apply, msg["name"])

    def forward_handler(self, command_field: CommandField, topic: str) -> MessageHandler:
        """The handler of the forward command ``topic`` of ``command_field``."""

        def handle(msg: Mapping[str, Any], connection: int) -> None:
            self._command(
                topic,
                connection,
                lambda: apply_forward(self.joints, command_field, msg),
                self.joints.joint_names,
            )

        return handle

    def on_trajectory(self, msg: Mapping[str, Any], connection: int, now_ns: int) -> None:
        """A ``joint_trajectory`` message from ``connection`` at sim time ``now_ns``."""
        topic = self.joint_trajectory_topic
        try:
            trajectory = parse_trajectory(self.joints, msg, now_ns)
        except CommandRefused as exc:
            self._report.refuse(topic, connection, str(exc))
            return
        self.trajectory = trajectory
        self.trajectory_topic = topic
        self.trajectory_warned = set()

    def setpoint(self, t_next_ns: int) -> None:
        """Command the trajectory in progress (if any) for the step ending at ``t_next_ns``;
        a notice is reported once per joint and trajectory."""
        trajectory = self.trajectory
        if trajectory is None:
            return
        positions, velocities = trajectory.commands(t_next_ns)
        joints = self.joints
        notices = joints.set_positions(positions) if positions else []
        if velocities:
            notices += joints.set_velocities(velocities)
        fresh = [n for n in notices if n.joint not in self.trajectory_warned]
        if fresh:
            self.trajectory_warned.update(n.joint for n in fresh)
            self._report.notices(self.trajectory_topic, 0, fresh)
        if t_next_ns >= trajectory.end_ns:
            self.trajectory = None
