"""The command topics: what they do to the simulation (sans-I/O: messages in, simulation
commands out) and the harness's multiplexer (:class:`RobotCommands`, controller
``command_mux``), which serves the harness's own topics as a controller of the robot's
controller manager like any other.

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

The functions act on a :class:`CommandTarget`: a :class:`~harness.sim.Simulation` (every joint,
MuJoCo names) or one robot's :class:`~harness.sim.RobotJoints` (its own, unprefixed, names).
In a session every command topic is a controller (the forward topics are
:mod:`~harness.controllers.forward_command` controllers of the default set, ``joint_command``
and ``joint_trajectory`` the multiplexer's), and every command reaches the simulation in one
form, :class:`~harness.controllers.base.Command`, through one path
(:class:`harness.session.ControlHost`).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from harness.controllers.base import (
    NOTHING,
    Command,
    ControllerBase,
    ControllerOutput,
    JointReadings,
    LogLine,
    TopicEndpoint,
)
from harness.controllers.errors import CommandRefused
from harness.controllers.listed import ListedJoints
from harness.models import ControlMode
from harness.sim import CommandError, CommandField, Notice

__all__ = [
    "FORWARD_TOPICS",
    "MUX_NAME",
    "TYPE_COMMAND_MUX",
    "CommandTarget",
    "Reporter",
    "RobotCommands",
    "Trajectory",
    "TrajectoryBase",
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


class TrajectoryBase(Protocol):
    """What :func:`parse_trajectory` reads of the joints (a :class:`CommandTarget` has it)."""

    @property
    def joint_names(self) -> tuple[str, ...]: ...

    @property
    def control(self) -> Mapping[str, ControlMode]: ...

    def joint_positions(self) -> F64: ...

    def joint_commands(self) -> F64: ...


def parse_trajectory(sim: TrajectoryBase, msg: Mapping[str, Any], now_ns: int) -> Trajectory:
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
    """Where command refusals and notices were reported before the command topics became a
    controller (kept for callers that still pass one; :class:`RobotCommands` reports through
    its :class:`~harness.controllers.base.ControllerOutput`)."""

    def refuse(self, topic: str, connection: int, reason: str) -> None:
        """A command on ``topic`` was refused as a whole (``reason``)."""
        ...

    def notices(self, topic: str, connection: int, notices: Sequence[Notice]) -> None:
        """A command on ``topic`` was applied with ``notices`` (values clamped...)."""
        ...


TYPE_COMMAND_MUX = "harness/CommandMux"
"""The plugin type the harness's multiplexer lists as (harness-owned: no YAML names it)."""
MUX_NAME = "command_mux"
"""The multiplexer's controller name."""
_HARNESS_NODE = "/harness"  # rosbridge's HARNESS_NODE: the built-in topics' node as before
_TYPE_JOINT_STATE = "sensor_msgs/msg/JointState"
_TYPE_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
_FIELD_OF_MODE: Mapping[str, CommandField] = {
    "kinematic": "position",
    "position": "position",
    "velocity": "velocity",
    "effort": "effort",
}
_FIELDS: tuple[CommandField, ...] = ("position", "velocity", "effort")


class _Joints(Protocol):
    @property
    def joint_names(self) -> tuple[str, ...]: ...

    @property
    def control(self) -> Mapping[str, ControlMode]: ...


class _AtInstant:
    """A :class:`CommandTarget` that only reads: the joints' positions and commands of one
    :class:`~harness.controllers.base.JointReadings` (what :func:`parse_trajectory` reads)."""

    def __init__(self, joints: _Joints, state: JointReadings) -> None:
        self.joint_names = tuple(joints.joint_names)
        self.control = joints.control
        self._state = state

    def joint_positions(self) -> F64:
        position = self._state.position
        return np.array([position[n] for n in self.joint_names], dtype=np.float64)

    def joint_commands(self) -> F64:
        command = self._state.command
        return np.array([command[n] for n in self.joint_names], dtype=np.float64)


class RobotCommands(ControllerBase):
    """The harness's multiplexer of one robot (controller :data:`MUX_NAME`, type
    :data:`TYPE_COMMAND_MUX`), in the default set and with ``controllers=False``: it claims
    every controllable joint's command interface and offers them to the set's other
    controllers as shared reference interfaces (``command_mux/<joint>/<interface>``: the
    forward commands, the trajectory and gripper controllers all command through it, the
    last command of a joint wins), so it is the one controller exempt from ros2_control's
    one-claim rule. It serves the harness's own command topics:

    - ``joint_command`` (``sensor_msgs/msg/JointState``): joints listed on
      ``joint_states`` but not controllable dropped by ``listed`` (``positions``: the
      current positions of the joints ``listed`` knows, in its order), then per joint the
      field its mode takes (the others given for it are reported as ignored);
    - ``joint_trajectory`` (``trajectory_msgs/msg/JointTrajectory``, :class:`Trajectory`):
      its setpoint is commanded at every step (:meth:`update`) until its end or until
      another command takes its joints (:meth:`taken`).

    Its commands and reports are its :class:`~harness.controllers.base.ControllerOutput`, like any
    controller's (``report`` is accepted for older callers and unused)."""

    multiplexes = True
    every_step = True

    def __init__(
        self,
        joints: _Joints,
        listed: ListedJoints,
        positions: Callable[[], F64],
        report: Reporter | None = None,
        *,
        joint_command: str,
        joint_trajectory: str,
    ) -> None:
        super().__init__(MUX_NAME, TYPE_COMMAND_MUX)
        self.joints = joints
        self.listed = listed
        self._positions = positions
        self.joint_command_topic = joint_command
        self.joint_trajectory_topic = joint_trajectory
        names = tuple(joints.joint_names)
        control = joints.control
        self.command_interfaces = tuple(f"{j}/{_FIELD_OF_MODE[control[j]]}" for j in names)
        self.reference_interfaces = tuple(f"{MUX_NAME}/{j}/{f}" for j in names for f in _FIELDS)
        self.subscriptions = (
            TopicEndpoint(joint_command, _TYPE_JOINT_STATE, _HARNESS_NODE),
            TopicEndpoint(joint_trajectory, _TYPE_TRAJECTORY, _HARNESS_NODE),
        )
        self._known = frozenset(names)
        self.trajectory: Trajectory | None = None
        self.trajectory_topic = ""

    # ----------------------------------------------------------------------------- lifecycle

    def activate(self, state: JointReadings) -> ControllerOutput:
        """Become active (no trajectory in progress)."""
        self.active = True
        self.trajectory = None
        return ControllerOutput()

    def deactivate(self, state: JointReadings) -> ControllerOutput:
        """Become inactive: the trajectory in progress ends where it is."""
        self.active = False
        self.trajectory = None
        return ControllerOutput()

    @property
    def idle(self) -> bool:
        """No trajectory in progress: :meth:`update` returns nothing."""
        return self.trajectory is None

    # ----------------------------------------------------------------------------- inputs

    def on_message(
        self, topic: str, msg: Mapping[str, Any], connection: int, state: JointReadings
    ) -> ControllerOutput:
        """A ``joint_command`` or ``joint_trajectory`` message from ``connection``."""
        out = ControllerOutput()
        if not self.active:
            out.logs.append(LogLine(40, "inactive, command ignored", connection))
            return out
        if topic == self.joint_trajectory_topic:
            self._on_trajectory(topic, msg, connection, state, out)
            return out
        stripped, notices = self.listed.strip(msg, self._positions())
        try:
            commands = self.joint_state_commands(stripped)
        except CommandRefused as exc:
            out.logs.append(LogLine(40, f"command refused: {exc}", connection))
            return out
        out.logs += [LogLine(30, n.message, connection) for n in notices]
        out.commands = commands
        # checked as the simulation checks it, so it is written: every joint it names is
        # taken from the trajectory (also one named without a value, as before)
        self.drop_from_trajectory(msg["name"])
        return out

    def joint_state_commands(self, msg: Mapping[str, Any]) -> list[Command]:
        """The commands of a ``sensor_msgs/msg/JointState`` (checked as the simulation checks
        it: the same refusals, in the same order): per joint the field its mode takes, else
        every field given for it (the simulation reports those as ignored)."""
        names: Sequence[str] = msg["name"]
        _check_names(names, "joint state command")
        given: dict[CommandField, Sequence[float]] = {}
        for field in ("effort", "velocity", "position"):
            values: Sequence[float] = msg[field]
            if len(values) > len(names):
                raise CommandRefused(
                    f"joint state command has {len(values)} {field} values for {len(names)} names"
                )
            given[field] = values
        known = self._known
        for field, values in given.items():
            for i, raw in enumerate(values):
                joint = names[i]
                if joint not in known:
                    listing = ", ".join(self.joints.joint_names) or "none"
                    raise CommandRefused(
                        f"unknown joint {joint!r} (controllable joints: {listing})"
                    )
                try:
                    value = float(raw)
                except (TypeError, ValueError):
                    raise CommandRefused(
                        f"joint {joint!r}: {field} {raw!r} is not a number"
                    ) from None
                if not math.isfinite(value):
                    raise CommandRefused(f"joint {joint!r}: {field} {value!r} is not finite")
        position, velocity, effort = given["position"], given["velocity"], given["effort"]
        control = self.joints.control
        commands: list[Command] = []
        for i, joint in enumerate(names):
            mode = control.get(joint)
            if mode is None:
                continue  # named without a value: nothing to check or write
            wanted = _FIELD_OF_MODE[mode]
            p = float(position[i]) if i < len(position) else None
            v = float(velocity[i]) if i < len(velocity) else None
            e = float(effort[i]) if i < len(effort) else None
            if wanted == "position" and p is not None:
                commands.append(Command(joint, p))
            elif wanted == "velocity" and v is not None:
                commands.append(Command(joint, None, v))
            elif wanted == "effort" and e is not None:
                commands.append(Command(joint, None, None, e))
            else:  # nothing for its mode: each field given, reported as ignored
                if e is not None:
                    commands.append(Command(joint, None, None, e))
                if v is not None:
                    commands.append(Command(joint, None, v))
                if p is not None:
                    commands.append(Command(joint, p))
        return commands

    def _on_trajectory(
        self,
        topic: str,
        msg: Mapping[str, Any],
        connection: int,
        state: JointReadings,
        out: ControllerOutput,
    ) -> None:
        try:
            trajectory = parse_trajectory(_AtInstant(self.joints, state), msg, state.sim_time_ns)
        except CommandRefused as exc:
            out.logs.append(LogLine(40, f"command refused: {exc}", connection))
            return
        self.trajectory = trajectory
        self.trajectory_topic = topic
        self.notice_key += 1  # a new trajectory: its notices are said again

    def taken(self, commands: Sequence[Command], by: str) -> None:
        """``commands`` were written (by a message or another controller): the trajectory in
        progress lets go of their joints."""
        if self.trajectory is not None:
            self.trajectory = self.trajectory.without({c[0] for c in commands})

    def drop_from_trajectory(self, joints: Iterable[str]) -> None:
        """Stop the trajectory driving ``joints`` (the robot's own names)."""
        if self.trajectory is not None:
            self.trajectory = self.trajectory.without(set(joints))

    # ----------------------------------------------------------------------------- cycle

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput:
        """The trajectory's setpoint for the step ending at ``sim_time_ns + period_ns`` (it
        is updated every step); its notices are said once per joint and trajectory."""
        trajectory = self.trajectory
        if trajectory is None:
            return NOTHING  # without a trajectory (every step)
        out = ControllerOutput()
        t_next = state.sim_time_ns + period_ns
        positions, velocities = trajectory.commands(t_next)
        out.commands = [Command(j, p) for j, p in positions.items()]
        out.commands += [Command(j, None, v) for j, v in velocities.items()]
        out.where = self.trajectory_topic
        if t_next >= trajectory.end_ns:
            self.trajectory = None
        return out
