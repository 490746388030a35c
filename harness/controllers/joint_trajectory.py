"""``joint_trajectory_controller/JointTrajectoryController``: the ``~/joint_trajectory`` topic and
the ``~/follow_joint_trajectory`` action (``control_msgs/action/FollowJointTrajectory``).

Semantics of ros2_controllers' controller, in simulation time:

- Every update (``update_rate`` of the controller manager) samples the trajectory at the current
  time (the *desired* state) and one period ahead (the command written for the next period);
  interpolation as in :mod:`harness.controllers.spline`.
- Path tolerances (``constraints.<joint>.trajectory``, a goal's ``path_tolerance``) are checked
  before the last point, goal tolerances (``constraints.<joint>.goal``,
  ``stopped_velocity_tolerance``, a goal's ``goal_tolerance``) after it, for ``goal_time``
  (``constraints.goal_time``, a goal's ``goal_time_tolerance``; 0 waits forever). A violation
  aborts the goal (PATH_TOLERANCE_VIOLATED / GOAL_TOLERANCE_VIOLATED) and holds the current
  position. Within the goal tolerances after the last point the goal succeeds.
- A new goal preempts the active one (aborted, INVALID_GOAL, "Current goal preempted by new
  incoming action."); a cancel ends the active goal as canceled and holds position.
- Feedback (desired, actual, error) goes out at ``action_monitor_rate`` (default 20 Hz);
  ``~/controller_state`` at ``state_publish_rate`` (default 50 Hz, Humble's; 0: every update).

One deliberate difference: a goal the real controller *rejects* (unknown joints, non-increasing
times, a start in the past, ...) is accepted and aborted at once here, with the
FollowJointTrajectory error code (INVALID_JOINTS, INVALID_GOAL, OLD_HEADER_TIMESTAMP) and a text
naming the problem: through rosbridge a rejection only says "Action goal was rejected".
Results go out at the update that decides them (the real controller sends them on its next
action monitor tick, up to ``1 / action_monitor_rate`` later). Not supported: points without
positions (``allow_integration_in_goal_trajectories``), ``cmd_timeout``, angle wraparound of
continuous joints, speed scaling, closed-loop PID adapters (the simulation's joint servos or
kinematic writes stand for the hardware).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

from harness.controllers.base import (
    GOAL_ABORTED,
    GOAL_CANCELED,
    GOAL_SUCCEEDED,
    ActionEndpoint,
    Command,
    Controller,
    ControllerBase,
    ControllerOutput,
    Feedback,
    JointReadings,
    LogLine,
    Publication,
    Result,
    TopicEndpoint,
)
from harness.controllers.config import TYPE_JOINT_TRAJECTORY, ControllerSpec
from harness.controllers.params import Params, duration_ns, point_msg, stamp
from harness.controllers.registry import RobotInterfaces, controller_type
from harness.controllers.spline import (
    Point,
    Sample,
    SampledTrajectory,
    SegmentTolerances,
    StateTolerance,
    goal_tolerances,
    params_tolerances,
    within,
)
from harness.controllers.values import JointIndex

__all__ = [
    "ACTION_TYPE",
    "GOAL_TOLERANCE_VIOLATED",
    "INVALID_GOAL",
    "INVALID_JOINTS",
    "OLD_HEADER_TIMESTAMP",
    "PATH_TOLERANCE_VIOLATED",
    "STATE_TYPE",
    "SUCCESSFUL",
    "InvalidTrajectory",
    "JointTrajectoryController",
]

ACTION_TYPE = "control_msgs/action/FollowJointTrajectory"
STATE_TYPE = "control_msgs/msg/JointTrajectoryControllerState"
TRAJECTORY_TYPE = "trajectory_msgs/msg/JointTrajectory"
SUCCESSFUL = 0
INVALID_GOAL = -1
INVALID_JOINTS = -2
OLD_HEADER_TIMESTAMP = -3
PATH_TOLERANCE_VIOLATED = -4
GOAL_TOLERANCE_VIOLATED = -5
_INTERFACES = ("position", "velocity", "acceleration", "effort")
_FLOAT_EPS = 1.1920929e-07
_ZEROS = itertools.repeat(0.0)


_Actual = tuple[list[float], list[float]]
"""The joints' positions and velocities (none without the velocity state interface)."""


class _Pending(NamedTuple):
    """What a feedback message says, kept until it goes out (it is built then)."""

    goal: int
    now: int
    desired: Sample
    actual: _Actual
    err_pos: list[float]
    err_vel: list[float]


def _enforced(tolerance: StateTolerance) -> bool:
    """Whether ``tolerance`` checks anything (a tolerance of 0 is not enforced)."""
    return tolerance.position > 0.0 or tolerance.velocity > 0.0 or tolerance.acceleration > 0.0


class InvalidTrajectory(Exception):
    """A trajectory the controller refuses: ``code`` is the FollowJointTrajectory error code."""

    def __init__(self, code: int, text: str) -> None:
        super().__init__(text)
        self.code = code


def _values(
    point: Mapping[str, Any], key: str, size: int, i: int, required: bool
) -> tuple[float, ...]:
    values: Sequence[float] = point.get(key, ())
    if not values and not required:
        return ()
    if len(values) != size:
        raise InvalidTrajectory(INVALID_GOAL, f"point {i}: {len(values)} {key} for {size} joints")
    for v in values:
        if not math.isfinite(v):
            raise InvalidTrajectory(INVALID_GOAL, f"point {i}: {key} holds {v!r}")
    return tuple(float(v) for v in values)


class JointTrajectoryController(ControllerBase):
    """One joint_trajectory_controller over ``joints`` (see the module docstring)."""

    def __init__(self, spec: ControllerSpec, source: str, controllable: Mapping[str, str]) -> None:
        super().__init__(spec.name, TYPE_JOINT_TRAJECTORY)
        p = Params(spec, source)
        self.joints = p.joints(p.strings("joints"), controllable)
        self.command = p.strings("command_interfaces", ["position"])
        self.state = p.strings("state_interfaces", ["position", "velocity"])
        for iface in (*self.command, *self.state):
            if iface not in _INTERFACES:
                raise p.error(f"unknown interface {iface!r} (known: {', '.join(_INTERFACES)})")
        if "position" not in self.state:
            raise p.error("state_interfaces must include position")
        for joint in self.joints:
            if controllable[joint] == "effort":
                raise p.error(
                    f"joint {joint!r} is effort-controlled in this session: the trajectory "
                    "controller drives position or velocity joints (choose another mode)"
                )
        self.allow_partial = p.flag("allow_partial_joints_goal", False)
        self.allow_nonzero_end_velocity = p.flag("allow_nonzero_velocity_at_trajectory_end", False)
        self.monitor_period_ns = round(1e9 / p.number("action_monitor_rate", 20.0, minimum=0.1))
        rate = p.number("state_publish_rate", 50.0, minimum=0.0)
        self.state_period_ns = round(1e9 / rate) if rate > 0 else 0
        constraints = p.get("constraints", {})
        if not isinstance(constraints, Mapping):
            raise p.error(f"constraints must be a mapping, not {constraints!r}")
        self.constraints: dict[str, Any] = {
            str(k): dict(v) if isinstance(v, Mapping) else v for k, v in constraints.items()
        }
        """The ``constraints`` parameters (changed by :meth:`set_parameter`)."""
        try:
            self.default_tolerances = params_tolerances(self.joints, constraints)
        except ValueError as exc:
            raise p.error(str(exc)) from None
        self.has_velocity_state = "velocity" in self.state
        self.has_velocity_command = "velocity" in self.command or "effort" in self.command
        self.has_effort_command = "effort" in self.command
        self.command_interfaces = tuple(f"{j}/{i}" for j in self.joints for i in self.command)
        self.state_interfaces = tuple(f"{j}/{i}" for j in self.joints for i in self.state)
        self.subscriptions = (TopicEndpoint("~/joint_trajectory", TRAJECTORY_TYPE),)
        self.publishers = (TopicEndpoint("~/controller_state", STATE_TYPE),)
        self.actions = (ActionEndpoint("~/follow_joint_trajectory", ACTION_TYPE),)
        self.trajectory: SampledTrajectory | None = None
        self.tolerances: SegmentTolerances = self.default_tolerances
        self.goal: int | None = None
        self.holding: Sample | None = None
        """The state held when no trajectory runs (the last point reached, or where a
        violation or cancel stopped)."""
        self._pending_feedback: _Pending | None = None
        """What the next feedback says (built when it goes out, at ``action_monitor_rate``)."""
        self._monitor_next = 0
        self._state_next = 0
        self._index = JointIndex(self.joints)
        self._zeros = (0.0,) * len(self.joints)
        self._tolerances_seen: SegmentTolerances | None = None
        self._path_enforced = True
        self._goal_enforced = True

    # ----------------------------------------------------------------------------- lifecycle

    def activate(self, state: JointReadings) -> ControllerOutput:
        """Start holding the current position (no trajectory)."""
        self.active = True
        self._hold(state)
        return ControllerOutput()

    def deactivate(self, state: JointReadings) -> ControllerOutput:
        """Stop; an active goal is aborted as the real controller does."""
        out = ControllerOutput()
        if self.goal is not None:
            out.results.append(
                self._result(
                    self.goal,
                    INVALID_GOAL,
                    "Current goal cancelled during deactivate transition.",
                    GOAL_ABORTED,
                )
            )
            self.goal = None
        self.active = False
        self.trajectory = None
        return out

    # ----------------------------------------------------------------------------- input

    def validate(
        self, msg: Mapping[str, Any], now_ns: int, state: JointReadings
    ) -> SampledTrajectory:
        """The trajectory of a ``trajectory_msgs/msg/JointTrajectory`` in the controller's joint
        order; :class:`InvalidTrajectory` when the controller refuses it."""
        names: list[str] = list(msg["joint_names"])
        points: list[Mapping[str, Any]] = list(msg["points"])
        if not self.allow_partial and len(names) != len(self.joints):
            raise InvalidTrajectory(
                INVALID_JOINTS,
                f"joints {names} do not match the controller's joints {list(self.joints)} "
                "(allow_partial_joints_goal is false)",
            )
        if not names:
            raise InvalidTrajectory(INVALID_JOINTS, "empty joint names")
        if not points:
            raise InvalidTrajectory(INVALID_GOAL, "empty trajectory")
        for name in names:
            if name not in self.joints:
                raise InvalidTrajectory(
                    INVALID_JOINTS,
                    f"joint {name!r} is not one of the controller's joints "
                    f"({', '.join(self.joints)})",
                )
        if len(set(names)) != len(names):
            raise InvalidTrajectory(INVALID_JOINTS, f"a joint is named twice: {names}")
        last_velocities: Sequence[float] = points[-1].get("velocities", ())
        if not self.allow_nonzero_end_velocity:
            for name, v in zip(names, last_velocities, strict=False):
                if abs(v) > _FLOAT_EPS:
                    raise InvalidTrajectory(
                        INVALID_GOAL,
                        f"velocity of the last point of joint {name!r} is not zero: {v!r}",
                    )
        start = duration_ns(msg["header"]["stamp"])
        end = start + duration_ns(points[-1]["time_from_start"])
        if start != 0 and end < now_ns:
            raise InvalidTrajectory(
                OLD_HEADER_TIMESTAMP,
                f"trajectory with start time {start / 1e9:.9f} s ends in the past "
                f"({end / 1e9:.9f} s < now {now_ns / 1e9:.9f} s)",
            )
        size = len(names)
        parsed: list[Point] = []
        previous = 0
        for i, point in enumerate(points):
            t = duration_ns(point["time_from_start"])
            if i > 0 and t <= previous:
                raise InvalidTrajectory(
                    INVALID_GOAL,
                    f"time between points {i - 1} and {i} is not strictly increasing "
                    f"({previous / 1e9:g} s, {t / 1e9:g} s)",
                )
            previous = t
            positions = _values(point, "positions", size, i, True)
            velocities = _values(point, "velocities", size, i, False)
            accelerations = _values(point, "accelerations", size, i, False)
            effort = _values(point, "effort", size, i, False)
            if effort and not self.has_effort_command:
                raise InvalidTrajectory(
                    INVALID_GOAL,
                    "trajectories with effort fields need the 'effort' command interface",
                )
            parsed.append(
                self._reorder(names, t, positions, velocities, accelerations, effort, state)
            )
        return SampledTrajectory(tuple(parsed), start)

    def _reorder(
        self,
        names: Sequence[str],
        t: int,
        positions: tuple[float, ...],
        velocities: tuple[float, ...],
        accelerations: tuple[float, ...],
        effort: tuple[float, ...],
        state: JointReadings,
    ) -> Point:
        index = {n: i for i, n in enumerate(names)}

        def order(values: tuple[float, ...], fill: Mapping[str, float] | None) -> tuple[float, ...]:
            if not values:
                return ()
            return tuple(
                values[index[j]] if j in index else (fill[j] if fill is not None else 0.0)
                for j in self.joints
            )

        return Point(
            t,
            order(positions, state.position),
            order(velocities, None),
            order(accelerations, None),
            order(effort, None),
        )

    def set_parameter(self, name: str, value: float) -> None:
        """Change a ``constraints`` parameter while running (``constraints.goal_time``,
        ``constraints.stopped_velocity_tolerance``, ``constraints.<joint>.trajectory|goal``),
        as ros2_control's JTC re-reads its parameters: the default tolerances change for the
        goals that follow (and the topic interface); a goal in flight keeps the tolerances it
        was accepted with. Raises ``ValueError`` naming what is wrong."""
        parts = name.split(".")
        scalar = ("goal_time", "stopped_velocity_tolerance")
        if not (
            (len(parts) == 2 and parts[0] == "constraints" and parts[1] in scalar)
            or (len(parts) == 3 and parts[0] == "constraints" and parts[1] in self.joints
                and parts[2] in ("trajectory", "goal"))
        ):  # fmt: skip
            raise ValueError(
                f"{self.name}: {name!r} is not a parameter that can change while running "
                "(constraints.goal_time, constraints.stopped_velocity_tolerance, "
                "constraints.<joint>.trajectory, constraints.<joint>.goal)"
            )
        constraints = {
            k: dict(v) if isinstance(v, dict) else v for k, v in self.constraints.items()
        }
        if len(parts) == 2:
            constraints[parts[1]] = float(value)
        else:
            constraints.setdefault(parts[1], {})[parts[2]] = float(value)
        self.default_tolerances = params_tolerances(self.joints, constraints)
        self.constraints = constraints
        if self.goal is None:
            self.tolerances = self.default_tolerances

    def on_message(
        self, topic: str, msg: Mapping[str, Any], connection: int, state: JointReadings
    ) -> ControllerOutput:
        """A trajectory on ``~/joint_trajectory`` replaces the current one."""
        out = ControllerOutput()
        if not self.active:
            out.logs.append(LogLine(40, "inactive, trajectory ignored", connection))
            return out
        try:
            self.trajectory = self.validate(msg, state.sim_time_ns, state)
        except InvalidTrajectory as exc:
            out.logs.append(LogLine(40, f"trajectory refused: {exc}", connection))
        return out

    def on_goal(
        self, action: str, goal: int, values: Mapping[str, Any], state: JointReadings
    ) -> ControllerOutput:
        """A FollowJointTrajectory goal: validated, then preempts the active goal."""
        out = ControllerOutput()
        if not self.active:
            out.results.append(
                self._result(goal, INVALID_GOAL, "controller is not active", GOAL_ABORTED)
            )
            return out
        try:
            trajectory = self.validate(values["trajectory"], state.sim_time_ns, state)
        except InvalidTrajectory as exc:
            out.results.append(self._result(goal, exc.code, str(exc), GOAL_ABORTED))
            out.logs.append(LogLine(30, f"goal refused: {exc}"))
            return out
        if self.goal is not None:
            out.results.append(
                self._result(
                    self.goal,
                    INVALID_GOAL,
                    "Current goal preempted by new incoming action.",
                    GOAL_ABORTED,
                )
            )
        self.trajectory = trajectory
        self.goal = goal
        self._pending_feedback = None
        self._monitor_next = state.sim_time_ns + self.monitor_period_ns
        self.tolerances = goal_tolerances(self.default_tolerances, self.joints, values)
        for note in self.tolerances.notes:
            out.logs.append(LogLine(40, f"{note}"))
        return out

    def on_cancel(self, action: str, goal: int, state: JointReadings) -> ControllerOutput:
        """Cancel the active goal: canceled, holding the current position."""
        out = ControllerOutput()
        if goal == self.goal:
            out.results.append(Result(goal, {"error_code": 0, "error_string": ""}, GOAL_CANCELED))
            self.goal = None
            self._pending_feedback = None
            out.commands += self._hold(state)
        return out

    # ----------------------------------------------------------------------------- update

    def _hold(self, state: JointReadings) -> list[Command]:
        self.trajectory = None
        zeros = self._zeros
        positions = self._index.take(state.position)
        self.holding = Sample(tuple(positions), zeros, zeros, zeros)
        return [Command(j, p, 0.0) for j, p in zip(self.joints, positions, strict=True)]

    def _result(self, goal: int, code: int, text: str, status: int) -> Result:
        return Result(goal, {"error_code": code, "error_string": text}, status)

    def _actual(self, state: JointReadings) -> _Actual:
        """The joints' state interfaces now (each array taken at once: :class:`JointIndex`)."""
        take = self._index.take
        return take(state.position), take(state.velocity) if self.has_velocity_state else []

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput:
        """One control cycle at ``state.sim_time_ns``."""
        out = ControllerOutput()
        if not self.active:
            return out
        now = state.sim_time_ns
        actual: _Actual | None = None  # read when a trajectory or the state message needs it
        desired: Sample | None = None
        error: tuple[list[float], list[float]] | None = None
        holding = False
        trajectory = self.trajectory
        if trajectory is not None:
            actual = self._actual(state)
            first_sample = not trajectory.sampled
            if first_sample:
                trajectory.set_point_before(now, Point(0, tuple(actual[0]), tuple(actual[1])))
            desired, start_index, end_index = trajectory.sample(now)
            command, _, _ = trajectory.sample(now + period_ns)
            if desired is not None and command is not None:
                error = self._check(
                    out, trajectory, state, actual, desired, command, start_index, end_index,
                    first_sample,
                )  # fmt: skip
        elif self.holding is not None:
            desired = self.holding
            holding = True  # its error is only said in the state message: made there
        if self._pending_feedback is not None:
            self._flush_feedback(out, now)
        if self.state_period_ns == 0 or now >= self._state_next:
            # the first update at or after each period (no drift: the mean rate is the rate)
            self._state_next = (now // max(1, self.state_period_ns) + 1) * self.state_period_ns
            read = actual
            out.publications.append(
                Publication(
                    "~/controller_state",
                    STATE_TYPE,
                    # built in this cycle or not at all: the readings are this cycle's
                    build=lambda: self._state_msg(
                        now, self._actual(state) if read is None else read, desired, error, holding
                    ),
                )
            )
        return out

    def _check(
        self,
        out: ControllerOutput,
        trajectory: SampledTrajectory,
        state: JointReadings,
        actual: _Actual,
        desired: Sample,
        command: Sample,
        start_index: int,
        end_index: int,
        first_sample: bool,
    ) -> tuple[list[float], list[float]]:
        now = state.sim_time_ns
        tol = self.tolerances
        segment_t = trajectory.start_ns + trajectory.points[start_index].time_from_start_ns
        time_difference = (now - segment_t) / 1e9
        before_last = end_index != len(trajectory.points)
        err_pos = [d - a for d, a in zip(desired.positions, actual[0], strict=True)]
        err_vel = (
            [d - a for d, a in zip(desired.velocities, actual[1], strict=True)]
            if self.has_velocity_state and self.has_velocity_command
            else [0.0] * len(self.joints)
        )
        if tol is not self._tolerances_seen:  # a tolerance of 0 is not enforced: skip all-0
            self._tolerances_seen = tol
            self._path_enforced = any(map(_enforced, tol.state))
            self._goal_enforced = any(map(_enforced, tol.goal))
        path_violated = (
            (before_last or first_sample)
            and self._path_enforced
            and not all(map(within, tol.state, err_pos, err_vel, _ZEROS))
        )
        outside_goal = (
            not before_last
            and self._goal_enforced
            and not all(map(within, tol.goal, err_pos, err_vel, _ZEROS))
        )
        within_goal_time = not (
            outside_goal and tol.goal_time != 0.0 and time_difference > tol.goal_time
        )
        if not path_violated and within_goal_time:
            out.commands += [  # Command(joint, position, velocity)
                Command(j, p, v)
                for j, p, v in zip(self.joints, command.positions, command.velocities, strict=True)
            ]
        goal = self.goal
        if goal is not None:
            self._pending_feedback = _Pending(goal, now, desired, actual, err_pos, err_vel)
            if path_violated:
                self._end(out, goal, PATH_TOLERANCE_VIOLATED,
                          "Aborted due to path tolerance violation")  # fmt: skip
                out.commands += self._hold(state)
            elif not before_last:
                if not outside_goal:
                    out.results.append(
                        self._result(goal, SUCCESSFUL, "Goal successfully reached!", GOAL_SUCCEEDED)
                    )
                    self.goal = None
                    self._flush_feedback(out, now, force=True)
                    self.trajectory = None
                    self.holding = desired
                elif not within_goal_time:
                    self._end(
                        out,
                        goal,
                        GOAL_TOLERANCE_VIOLATED,
                        f"Aborted due to goal_time_tolerance exceeding by {time_difference:f} "
                        "seconds",
                    )
                    out.commands += self._hold(state)
        elif path_violated or (not before_last and not within_goal_time):
            out.logs.append(LogLine(40, "tolerance violated: holding position"))
            out.commands += self._hold(state)
        elif not before_last and not outside_goal:
            self.trajectory = None  # reached: the last command holds
            self.holding = desired
        return err_pos, err_vel

    def _end(self, out: ControllerOutput, goal: int, code: int, text: str) -> None:
        self._flush_feedback(out, 0, force=True)
        out.results.append(self._result(goal, code, text, GOAL_ABORTED))
        out.logs.append(LogLine(30, f"{text}"))
        self.goal = None

    def _flush_feedback(self, out: ControllerOutput, now: int, force: bool = False) -> None:
        pending = self._pending_feedback
        if pending is None:
            return
        if force or now >= self._monitor_next:
            out.feedback.append(self._feedback(pending))
            self._pending_feedback = None
            if not force:
                self._monitor_next += self.monitor_period_ns * max(
                    1, (now - self._monitor_next) // self.monitor_period_ns + 1
                )

    def _feedback(self, pending: _Pending) -> Feedback:
        """The feedback message of the update ``pending`` holds."""
        goal, now, desired, actual, err_pos, err_vel = pending
        return Feedback(
            goal,
            {
                "header": {"stamp": stamp(now), "frame_id": ""},
                "joint_names": list(self.joints),
                "desired": point_msg(desired.positions, desired.velocities, desired.accelerations),
                "actual": point_msg(actual[0], actual[1]),
                "error": point_msg(err_pos, err_vel if self.has_velocity_state else ()),
            },
        )

    def _state_msg(
        self,
        now: int,
        actual: _Actual,
        desired: Sample | None,
        error: tuple[list[float], list[float]] | None,
        holding: bool,
    ) -> dict[str, Any]:
        """The ``~/controller_state`` message of an update (``holding``: ``desired`` is the
        position held, whose error is made here)."""
        if holding and desired is not None:
            error = (
                [d - a for d, a in zip(desired.positions, actual[0], strict=True)],
                [0.0] * len(self.joints),
            )
        actual_msg = point_msg(actual[0], actual[1])
        if desired is None or error is None:
            desired_msg = point_msg(actual[0], actual[1])
            error_msg = point_msg([0.0] * len(self.joints))
        else:
            desired_msg = point_msg(desired.positions, desired.velocities, desired.accelerations)
            error_msg = point_msg(error[0], error[1] if self.has_velocity_state else ())
        msg = {
            "header": {"stamp": stamp(now), "frame_id": ""},
            "joint_names": list(self.joints),
            "reference": desired_msg,
            "feedback": actual_msg,
            "error": error_msg,
            "output": desired_msg,
            "desired": desired_msg,
            "actual": actual_msg,
        }
        return msg


@controller_type(TYPE_JOINT_TRAJECTORY)
def _joint_trajectory(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return JointTrajectoryController(spec, robot.source, robot.controllable)
