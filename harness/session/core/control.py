"""The session's side of the controllers (:mod:`harness.controllers`): one controller manager per
robot, bound to the graph.

:class:`ControlHost` is the small interface :class:`~harness.session.core.SessionCore` calls:
:meth:`~ControlHost.start` (subscribe the controllers' topics, serve their actions and the
``controller_manager`` services), :meth:`~ControlHost.before_step` (every controller update due
at this step boundary) and :meth:`~ControlHost.reset`. Whatever a controller returns is applied
here: joint commands through the robot's :class:`~harness.sim.RobotJoints` (a refused command
tells its client with a status frame, as the command topics do), publications through the core
(recorded like every message), action feedback and results through the bridge (recorded as
frames), log lines as events. Everything happens at step boundaries in simulation time, so a
recording replays it bit for bit. The ``controllers=`` option itself (its forms, the default
set, its metadata) is :mod:`harness.session.core.control_options`; the joint readings a
controller is given, :mod:`harness.session.core.readings`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

from harness.controllers import (
    SERVICES,
    BaseVelocity,
    Command,
    Controller,
    ControllerManager,
    ControllerOutput,
    ControllersConfig,
    JointReadings,
    builtin_controllers,
    default_controllers,
)
from harness.events import Level
from harness.models import LoadedRobot, LoadedWorld
from harness.rosbridge import ActionGoal
from harness.sensors import sensor_interfaces
from harness.session.core.bridge import Publisher
from harness.session.core.control_options import (
    CONFIG_DEFAULT,
    CONFIG_NONE,
    ControllersOption,
    base_driven,
    controllers_from_metadata,
    controllers_metadata,
    controllers_option,
    resolve_default,
)
from harness.session.core.readings import UNREAD, Snapshot
from harness.session.core.topics import node_name
from harness.sim import CommandError, ControlConfigError, Notice

__all__ = [
    "ControlHost",
    "ControllersOption",
    "base_driven",
    "controllers_from_metadata",
    "controllers_metadata",
    "controllers_option",
    "resolve_default",
]


class _Core(Publisher, Protocol):
    """What the host needs of the session core (it publishes through it)."""

    sim: Any
    robot: Any
    robot_name: str
    robots: Any
    graph: Any
    bridge: Any

    def log(self, level: Level, text: str) -> None: ...


class _RobotControl:
    """One robot's controller manager, the goals in flight and when each controller is
    updated."""

    def __init__(
        self,
        host: ControlHost,
        channels: Any,
        config: ControllersConfig,
        *,
        multiplexer: Controller | None,
        services: bool,
    ) -> None:
        self.host = host
        self.channels = channels
        self.services = services
        """Whether it serves the ``controller_manager`` services (not with
        ``controllers=False``: then only the harness's own command topics are there)."""
        joints = channels.joints
        self.manager = ControllerManager(
            config,
            joints.control,
            channels.js_names,
            self.read,
            robot=channels.namespace or host.core.robot_name,
            sensors=sensor_interfaces(getattr(host.core, "sensors", None), channels.namespace),
            multiplexer=multiplexer,
        )
        dt: int = host.core.sim.dt_ns
        self.dt_ns = dt
        self.every = max(1, round(self.manager.update_period_ns / dt))
        self.muxes: list[Any] = [
            c for c in self.manager.built.values() if getattr(c, "multiplexes", False)
        ]
        self.steps = [c for c in self.manager.built.values() if getattr(c, "every_step", False)]
        """Controllers updated at every step (the multiplexer: its trajectory's setpoint)."""
        periods = self.manager.periods_ns
        self.periods = {
            name: period
            for name, period in periods.items()
            if name not in {c.name for c in self.steps}
        }
        """Controller -> its update period (ns of simulation time)."""
        self.uniform = len(set(self.periods.values())) <= 1 and all(
            p % dt == 0 for p in self.periods.values()
        )
        """Whether every controller is updated every :attr:`every` steps (the common case)."""
        self.broadcasters = (
            tuple(
                name
                for name, c in self.manager.built.items()
                if getattr(c, "publishes_joint_states", False)
            )
            if config.exclusive
            else ()
        )
        """Its joint state broadcasters, when they pace ``/joint_states`` (a named set)."""
        self.goals: dict[int, ActionGoal] = {}
        self.warned: set[tuple[str, str, str, int]] = set()
        self._unread: JointReadings | None = None
        self.topics: dict[str, str] = {}
        """Resolved topic -> controller name (the topics its controllers subscribe)."""

    def _cycle_step(self, m: int) -> int:
        """The step of the manager's cycle ``m``: the first at or after ``m`` periods."""
        return -((-m * self.manager.update_period_ns) // self.dt_ns)

    def due(self, name: str, k: int) -> bool:
        """Whether controller ``name`` is updated at step ``k``: at a cycle of the manager
        (the first step at or after each of its periods, in simulation time) that is the
        first at or after one of the controller's own periods."""
        dt = self.dt_ns
        cycle = self.manager.update_period_ns
        if k == 0:
            return True
        if (k * dt) // cycle == ((k - 1) * dt) // cycle:
            return False
        period = self.periods[name]
        if period == cycle:
            return True
        previous = self._cycle_step((k * dt) // cycle - 1)
        return (previous * dt) // period < (k * dt) // period

    def period_at(self, name: str, k: int) -> int:
        """The simulation time since controller ``name``'s previous update slot (its period
        rounded to steps at the first one), whether or not it was active then."""
        dt = self.dt_ns
        period = self.periods[name]
        n = (k * dt) // period
        if n == 0:
            return max(1, round(period / dt)) * dt
        cycle = self.manager.update_period_ns
        previous = self._cycle_step(-((-(n - 1) * period) // cycle))
        return (k - previous) * dt

    def resolve(self, controller: str, name: str) -> str:
        ns = self.channels.namespace
        base = f"/{ns}/{controller}" if ns else f"/{controller}"
        return base + "/" + name.removeprefix("~/") if name.startswith("~/") else name

    def unread(self) -> JointReadings:
        """Readings for controllers that never look at them (``reads_state`` False): the
        time only; reading a joint raises. One per instant (a command may come every step)."""
        now = self.host.core.sim.sim_time_ns
        unread = self._unread
        if unread is None or unread.sim_time_ns != now:
            unread = self._unread = JointReadings(now, UNREAD, UNREAD, UNREAD, UNREAD)
        return unread

    def read_for(self, controllers: Sequence[Any]) -> JointReadings:
        """:meth:`read`, or :meth:`unread` when none of ``controllers`` reads the joints."""
        for controller in controllers:
            if getattr(controller, "reads_state", True):
                return self.read()
        return self.unread()

    def read(self) -> JointReadings:
        joints = self.channels.joints
        names = joints.joint_names
        # Each array is read when a controller first looks (the joints' state does not change
        # between two steps; a command written meanwhile shows in ``command``).
        return JointReadings(
            self.host.core.sim.sim_time_ns,
            Snapshot(names, joints.joint_positions),
            Snapshot(names, joints.joint_velocities),
            Snapshot(names, joints.joint_efforts),
            Snapshot(names, joints.joint_commands),
        )


def _robot_sources(loaded: Any, index: int) -> Mapping[str, bytes]:
    """The source files of robot ``index`` of what the core runs (none when unknown)."""
    if isinstance(loaded, LoadedRobot):
        return loaded.sources
    if isinstance(loaded, LoadedWorld) and index < len(loaded.robots):
        return loaded.robots[index].sources
    return {}


def _robot_default(joints: Any, sources: Mapping[str, bytes]) -> ControllersConfig:
    """A robot's default set with its drive plugins (the translation of :func:`resolve_default`)."""
    from harness.controllers import robot_controllers

    return robot_controllers(default_controllers(joints.joint_names, joints.control), sources)


class ControlHost:
    """The controllers of every robot of a core (see the module docstring). ``config``: a
    :class:`ControllersConfig` (every robot gets it), ``"default"`` (each robot its
    :func:`~harness.controllers.default_controllers`) or ``"none"``."""

    def __init__(self, core: _Core, config: ControllersConfig | str) -> None:
        self.core = core
        self.robots: list[_RobotControl] = []
        self._next_goal = 1
        for channels in core.robots:
            joints = channels.joints
            own = (
                _robot_default(joints, _robot_sources(core.robot, len(self.robots)))
                if config == CONFIG_DEFAULT
                else builtin_controllers(joints.joint_names)
                if config == CONFIG_NONE
                else config
            )
            assert isinstance(own, ControllersConfig)
            # a set the harness made (the default set, the built-in topics) shares the joints
            # through the robot's multiplexer; a set a YAML or robot file names replaces it
            # with its own topics
            robot = _RobotControl(
                self,
                channels,
                own,
                multiplexer=None if own.exclusive else channels.commands,
                services=config != CONFIG_NONE,
            )
            for name, controller in robot.manager.built.items():
                for endpoint in controller.subscriptions:
                    robot.topics[robot.resolve(name, endpoint.name)] = name
            self.robots.append(robot)
        self.paces_joint_states = any(robot.broadcasters for robot in self.robots)
        """Whether a robot's ``/joint_states`` follow its broadcaster's schedule (a set a
        YAML or robot file names, with a ``joint_state_broadcaster``)."""

    def joint_states_due(self, channels: Any, k: int, default: bool) -> bool:
        """Whether the robot of ``channels`` publishes ``/joint_states`` at step ``k``: while
        its broadcaster is active, at the first step at or after each of its periods; without
        one, when the session's own rate says so (``default``)."""
        for robot in self.robots:
            if robot.channels is channels and robot.broadcasters:
                loaded = robot.manager.loaded
                return any(
                    name in loaded and loaded[name].state == "active" and robot.due(name, k)
                    for name in robot.broadcasters
                )
        return default

    def claims(self, topic: str) -> bool:
        """Whether a controller subscribes ``topic`` (the core then leaves it alone)."""
        return any(topic in robot.topics for robot in self.robots)

    # ----------------------------------------------------------------------------- set-up

    def start(self) -> None:
        """Subscribe, serve, and load/activate every robot's controllers."""
        graph = self.core.graph
        serve_action = getattr(graph, "serve_action", None)
        for robot in self.robots:
            manager = robot.manager
            namespace = robot.channels.namespace
            for name, controller in manager.built.items():
                node = node_name(namespace, name)
                for topic in controller.publishers:
                    graph.advertise(robot.resolve(name, topic.name), topic.type, node=node)
                for topic in controller.subscriptions:
                    graph.subscribe(
                        robot.resolve(name, topic.name),
                        topic.type,
                        self._on_message(robot, name, topic.name),
                        node=topic.node or node,
                    )
                for action in controller.actions:
                    resolved = robot.resolve(name, action.name)
                    if serve_action is None:
                        self.core.log(
                            Level.WARNING,
                            f"{resolved}: actions are not served through an external "
                            "rosbridge server",
                        )
                        continue
                    serve_action(
                        resolved, action.type, self._on_goal(robot, name, action.name), node=node
                    )
            for service, type in SERVICES.items() if robot.services else ():
                graph.serve(
                    robot.resolve("controller_manager", "~/" + service),
                    type,
                    self._on_service(robot, service),
                    node=node_name(namespace, "controller_manager"),
                )
            self._apply(robot, manager.start())

    # ----------------------------------------------------------------------------- stepping

    def before_step(self) -> None:
        """Run every controller update due at the current step boundary: those at their
        update rate (every robot's, in load order), then those of every step."""
        k = self.core.sim.step_index
        for robot in self.robots:
            if robot.uniform:
                if k % robot.every:
                    continue
                due = [c for c in robot.manager.active() if c.name in robot.periods]
            else:
                due = [
                    c
                    for c in robot.manager.active()
                    if c.name in robot.periods and robot.due(c.name, k)
                ]
            if not due:
                continue
            state = robot.read_for(due)
            # one period for all when they share it (uniform: every controller's is the same)
            shared = robot.period_at(due[0].name, k) if robot.uniform else 0
            for controller in due:
                period = shared or robot.period_at(controller.name, k)
                out = controller.update(state, period)
                if (
                    out.commands
                    or out.publications
                    or out.logs
                    or out.feedback
                    or out.results
                    or out.base is not None
                ):  # an empty output changes nothing
                    self._apply(robot, out, controller)
        for robot in self.robots:
            for controller in robot.steps:
                entry = robot.manager.loaded.get(controller.name)
                if entry is None or entry.state != "active":
                    continue
                # an every-step update is given the time only (it interpolates a command)
                out = controller.update(robot.unread(), robot.dt_ns)
                if out.commands or out.logs or out.publications or out.base is not None:
                    self._apply(robot, out, controller, cycle=True)

    def quiet_until(self, k: int) -> int:
        """The first step boundary at or after ``k`` at which :meth:`before_step` may do
        anything, as things stand (an input or a controller's output can change it: ask
        again after one): ``k`` while an every-step controller is busy or a robot's
        controllers have different rates, else its next update cycle."""
        until: int | None = None
        for robot in self.robots:
            for controller in robot.steps:
                entry = robot.manager.loaded.get(controller.name)
                if (
                    entry is not None
                    and entry.state == "active"
                    and not getattr(controller, "idle", False)
                ):
                    return k
            if not robot.periods:
                continue
            if not robot.uniform:
                return k
            due = -(-k // robot.every) * robot.every
            until = due if until is None else min(until, due)
        return k + (1 << 62) if until is None else until

    def reset(self) -> None:
        """After a reset to the initial state: every active controller restarts (goals end)."""
        for robot in self.robots:
            self._apply(robot, robot.manager.restart())

    # ----------------------------------------------------------------------------- inputs

    def _on_message(
        self, robot: _RobotControl, name: str, topic: str
    ) -> Callable[[Mapping[str, Any], int], None]:
        where = robot.resolve(name, topic)

        def handle(msg: Mapping[str, Any], connection: int) -> None:
            entry = robot.manager.loaded.get(name)
            if entry is None:
                return
            controller = entry.controller
            state = robot.read() if getattr(controller, "reads_state", True) else robot.unread()
            out = controller.on_message(topic, msg, connection, state)
            self._apply(robot, out, controller, connection, where)

        return handle

    def _on_goal(
        self, robot: _RobotControl, name: str, action: str
    ) -> Callable[[ActionGoal], None]:
        def handle(goal: ActionGoal) -> None:
            gid = self._next_goal
            self._next_goal += 1
            robot.goals[gid] = goal
            entry = robot.manager.loaded.get(name)
            if entry is None:
                goal.finish({}, 6)
                robot.goals.pop(gid, None)
                return

            def cancel(_: ActionGoal) -> None:
                current = robot.manager.loaded.get(name)
                if current is not None:
                    out = current.controller.on_cancel(action, gid, robot.read())
                    self._apply(robot, out, current.controller)

            goal.on_cancel = cancel
            out = entry.controller.on_goal(action, gid, goal.goal, robot.read())
            self._apply(robot, out, entry.controller, goal.connection)

        return handle

    def _on_service(
        self, robot: _RobotControl, service: str
    ) -> Callable[[Mapping[str, Any]], Mapping[str, Any]]:
        def handle(request: Mapping[str, Any]) -> Mapping[str, Any]:
            response, out = robot.manager.handle(service, request)
            self._apply(robot, out)
            return response

        return handle

    # ----------------------------------------------------------------------------- outputs

    def _apply(
        self,
        robot: _RobotControl,
        out: ControllerOutput,
        controller: Controller | None = None,
        connection: int = 0,
        where: str = "",
        *,
        cycle: bool = False,
    ) -> None:
        """Apply a controller's output (``controller``: whose, None for the manager's;
        ``cycle``: from its every-step update). ``out.where``, else ``where`` (a topic),
        else the controller's name prefixes its log lines."""
        core = self.core
        name = controller.name if controller is not None else ""
        where = out.where or where or name or "controller_manager"
        if out.commands and not (
            out.logs or out.publications or out.feedback or out.results or out.base
        ):  # commands alone (a command message, a controller's cycle): the common case
            self._command(robot, out.commands, where, connection, controller, cycle)
            return
        for log in out.logs:
            text = f"{where}: {log.text}"
            if log.connection:
                core.graph.status(log.connection, "error" if log.level >= 40 else "warning", text)
            core.log(Level(log.level), text)
        if out.commands:
            self._command(robot, out.commands, where, connection, controller, cycle)
        if out.base is not None:
            self._base(out.base, where)
        for pub in out.publications:
            # to subscribers only: the frames sent are recorded (as /rosout's are), no channel
            # of its own (a session's recorded channels stay what they were)
            core.publish(
                robot.resolve(name, pub.topic),
                pub.type,
                lambda pub=pub: pub.msg,  # type: ignore[misc]
                record=False,
            )
        if out.feedback or out.results:  # stamped at sim time by the session bridge
            for fb in out.feedback:
                goal = robot.goals.get(fb.goal)
                if goal is not None:
                    goal.feedback(fb.values)
            for result in out.results:
                goal = robot.goals.pop(result.goal, None)
                if goal is not None:
                    goal.finish(result.values, result.status)

    def _base(self, base: BaseVelocity, where: str) -> None:
        """A planar base's velocity: a recorded kinematic write of its free joint."""
        try:
            self.core.sim.set_base_velocity(
                base.linear_x, base.linear_y, base.angular_z, joint=base.joint
            )
        except (CommandError, ControlConfigError) as exc:
            self.core.log(Level.ERROR, f"{where}: base velocity refused: {exc}")

    def _command(
        self,
        robot: _RobotControl,
        commands: list[Command],
        where: str,
        connection: int,
        writer: Controller | None,
        cycle: bool,
    ) -> None:
        """The one way a command reaches the simulation: each :class:`Command` of an output,
        grouped by the field it gives (the simulation checks them all before any applies),
        then the robot's multiplexer is told which joints were taken."""
        control = robot.channels.joints.control
        positions: dict[str, float] = {}
        velocities: dict[str, float] = {}
        efforts: dict[str, float] = {}
        for joint, position, velocity, effort in commands:
            # one field given (the common case): that field, whatever the joint's mode
            if velocity is None and effort is None:
                if position is not None:
                    positions[joint] = position
                continue
            if position is None and effort is None:
                velocities[joint] = velocity  # type: ignore[assignment]
                continue
            if position is None and velocity is None:
                efforts[joint] = effort  # type: ignore[assignment]
                continue
            # several given: the one the joint's mode takes, if given
            mode = control.get(joint, "position")
            if mode in ("position", "kinematic"):
                if position is not None:
                    positions[joint] = position
            elif mode == "velocity":
                if velocity is not None:
                    velocities[joint] = velocity
            elif mode == "effort" and effort is not None:
                efforts[joint] = effort
        joints = robot.channels.joints
        notices: list[Notice] = []
        try:
            if positions:
                notices += joints.set_positions(positions)
            if velocities:
                notices += joints.set_velocities(velocities)
            if efforts:
                notices += joints.set_efforts(efforts)
        except CommandError as exc:
            text = f"{where}: command refused: {exc}"
            if connection:
                self.core.graph.status(connection, "error", text)
            self.core.log(Level.ERROR, text)
            return
        for mux in robot.muxes:
            if not (cycle and mux is writer):  # its own setpoint keeps its trajectory
                mux.taken(commands, writer.name if writer is not None else "")
        if not notices:
            return
        key = getattr(writer, "notice_key", 0)
        for notice in notices:
            seen = (where, notice.joint, notice.kind, key)
            if not connection and seen in robot.warned:
                continue  # a controller's every cycle: once per joint
            robot.warned.add(seen)
            text = f"{where}: {notice.message}"
            if connection:
                self.core.graph.status(connection, "warning", text)
            self.core.log(Level.WARNING, text)
