"""The session's per-step logic without sockets, threads or wall clocks (sans-I/O, h11-style).

:class:`SessionCore` is everything a session does between two step boundaries: the rosbridge
protocol core (:class:`~harness.session.core.bridge.SessionBridge`), the command topics
(:mod:`harness.controllers.command_topics`), the publishing schedule, the ``/harness/*``
services, loggers and what goes to the recorder. Input arrives as rosbridge frames at a step
boundary (``bridge.receive``, called by the live server's queue or by replay); output is
outgoing frames (the bridge's outbox), applied inputs, physics states and published messages
(a :class:`RecordSink`). The live :class:`~harness.session.Session` is a thin asyncio/thread
shell around one core; ``harness replay --level full`` (:mod:`harness.replay.pipeline`)
drives a fresh core with the recorded frames, so both run the same code.

Rooms: the robots' topics and joints (:mod:`harness.session.core.channels`), the bridge, graph
and ``/rosout`` sink (:mod:`harness.session.core.bridge`), markers, the recorded inputs that are
not client frames (:mod:`harness.session.core.markers`), the controllers
(:mod:`harness.session.core.control`), the graph set-up at :meth:`SessionCore.start`
(:mod:`harness.session.core.wiring`), the ``/harness/*`` services
(:mod:`harness.session.core.services`), the recorded form of frames and markers
(:mod:`harness.session.core.frames`), resets and their epochs (:mod:`harness.session.core.epochs`).
Python loggers are not replayable from a file: what they
publish on ``/rosout`` needs the same loggers (``loggers=`` of
:func:`harness.replay.pipeline.replay_pipeline`).

The whole state
---------------
Everything the rest of a run depends on is reachable from one :class:`SessionCore` value and
is held by nothing else:

- the simulation (:attr:`SessionCore.sim`: MuJoCo's data, the step index and so the
  simulation time, each joint's control mode and command, the last applied input);
- the controllers (:attr:`SessionCore.control`: every robot's controller manager, each
  controller's state and the goals in flight; each robot's built-in command topics'
  trajectory in :attr:`SessionCore.robots`);
- the sensors (:attr:`SessionCore.sensors`: their schedules, and their noise streams, drawn
  from :attr:`CoreOptions.seed` by sensor and step, so a stream is a function of the step);
- the bridge graph (:attr:`SessionCore.bridge`: connections, advertisements, subscriptions,
  services and calls in flight, send budgets, frame numbering);
- the clock: the step index, :attr:`~SessionCore.paused`, :attr:`~SessionCore.awaiting_client`,
  :attr:`~SessionCore.pause_at`, the clock mode and rate (:attr:`~SessionCore.options`, which
  also fix the publishing schedule), the publication counts ``/harness/step`` waits on, the
  resets so far, and :attr:`~SessionCore.failure`;
- the event hub (loggers, sinks) and the recorder the core writes to.

A live shell (:class:`~harness.session.Session`) keeps only I/O and wall time: its sockets
and the frames waiting for the next step boundary (not yet input), the link to an external
server, the loop thread, the realtime pacing's wall-clock anchor, ``run_until`` watchers,
copies of the connection counts for other threads, the recording file. So a core brought to
step ``k`` by a recording's inputs (as :mod:`harness.replay.pipeline` drives one) can be
handed to a new shell and go on as the recorded run did. What a recording cannot rebuild is
what never entered it: Python loggers (pass the same ones) and a :attr:`~SessionCore.pause_at`
limit set from Python that has not fired yet.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping, Sequence
from functools import cache, partial
from typing import Any, Protocol

from harness.events import EventHub, Level, LogMessage, SinkReport, StepContext
from harness.models import LoadedRobot, LoadedWorld
from harness.recording import BridgeFrame, ClockRecord, Epoch, PhysicsStateSlot
from harness.rosbridge import DIRECTION_IN
from harness.sensors import record_metadata, session_sensors
from harness.session.core.bridge import (
    BridgePort,
    Graph,
    MessageCallback,
    RosoutSink,
    ServiceHandler,
    SessionBridge,
)
from harness.session.core.channels import (
    CLOCK,
    RobotChannels,
    SessionTopics,
    joint_state_arrays,
    joint_state_message,
    joint_state_of,
    joint_state_record,
    robot_channels,
)
from harness.session.core.control import (
    ControlHost,
    base_driven,
)
from harness.session.core.epochs import reset_epoch, restart
from harness.session.core.frames import marker_frame, tap_frame
from harness.session.core.markers import (
    MARKER_CALL_TIMEOUT,
    MARKER_CLOSE,
    MARKER_DISCONNECT,
    MARKER_PYTHON,
    MARKER_TRANSPORT_STATUS,
    MARKERS,
    is_marker,
    open_connection,
    replay_marker,
)
from harness.session.core.naming import check_session_name
from harness.session.core.options import (
    DEFAULT_MAX_STEP_REQUEST,
    START_MODES,
    CoreOptions,
    StartMode,
)
from harness.session.core.pycalls import PythonCalls
from harness.session.core.services import SERVICE_GET_STATE as SERVICE_GET_STATE
from harness.session.core.services import SERVICE_PAUSE as SERVICE_PAUSE
from harness.session.core.services import SERVICE_RESET as SERVICE_RESET
from harness.session.core.services import SERVICE_STEP, HarnessServices
from harness.session.core.stepping import PublishCounter
from harness.session.core.topics import (
    HARNESS_NODE,
    TYPE_CLOCK,
    TYPE_JOINT_STATE,
    TYPE_TF,
    clock_msg,
    period_steps,
)
from harness.session.core.wiring import (
    advertise_and_subscribe,
    publish_latched,
    published_topics,
    tf_trees,
)
from harness.session.errors import (
    SessionClosedError,
    SessionConfigError,
    SessionError,
)
from harness.sim import AppliedInput, Notice, Simulation, qpos_qvel_slices
from harness.vocabulary import CLOCK_MODES, ClockMode

__all__ = [
    "CLOCK_MODES",
    "DEFAULT_MAX_STEP_REQUEST",
    "FAILURE_PREFIX",
    "LOG_NAME",
    "MARKERS",
    "MARKER_CALL_TIMEOUT",
    "MARKER_CLOSE",
    "MARKER_DISCONNECT",
    "MARKER_PYTHON",
    "MARKER_TRANSPORT_STATUS",
    "START_MODES",
    "ClockMode",
    "CoreOptions",
    "Graph",
    "MessageCallback",
    "RecordSink",
    "RobotChannels",
    "ServiceHandler",
    "SessionBridge",
    "SessionCore",
    "SessionTopics",
    "StartMode",
    "is_marker",
]

_LOG_NAME = "harness.session"
LOG_NAME = _LOG_NAME
"""The ``name`` of the session's own log events (``/rosout``)."""
FAILURE_PREFIX = "the run failed: "
"""How the FATAL log event of a failed run (:meth:`SessionCore.fail`) begins."""


class RecordSink(Protocol):
    """What the core writes to the recording (:class:`harness.recording.Recorder` is one).

    The state after each step goes through one slot (:meth:`physics_state_slot`; a sink
    taking :class:`PhysicsState` records makes one with
    :func:`harness.recording.stateslot.forwarding_slot`). A message is a dict in rosbridge
    JSON form or, for the periodic topics, one of the record types :mod:`harness.recording`
    exports (:class:`~harness.recording.JointStateRecord`,
    :class:`~harness.recording.TfRecord`, :class:`~harness.recording.ClockRecord`: the
    recorder lays out their CDR; the core knows no file format)."""

    def write_message(self, topic: str, msgtype: str, msg: Any, *, sim_time_ns: int) -> None: ...

    def write_bridge_frame(self, frame: BridgeFrame) -> None: ...

    def write_applied_input(self, inp: AppliedInput) -> None: ...

    def physics_state_slot(
        self, state_spec: int, state_size: int, qpos: slice, qvel: slice
    ) -> PhysicsStateSlot: ...

    def write_epoch(self, epoch: Epoch) -> None: ...


class SessionCore(PythonCalls):
    """One session's logic, sans-I/O. ``robot``: a loaded robot (one robot, its topics under
    ``options.namespace``) or a :class:`~harness.models.LoadedWorld` (each robot's topics under
    its own namespace, one global ``/tf``); a fresh :class:`~harness.sim.Simulation` of it is
    made. ``options``: see :class:`CoreOptions`; ``recorder``: where bridge frames, markers,
    applied inputs, states and published messages go; ``hub``: the event hub (its sinks and
    loggers; a ``/rosout`` publishing sink is added); ``graph``: an external graph (client
    mode) instead of the core's own :class:`SessionBridge` (:attr:`bridge`, None in client
    mode).

    Call only from one thread. Driving it (sans-I/O: nothing calls back into the shell):
    :meth:`start` once, then at each step boundary hand waiting frames to :attr:`bridge`
    (``receive``, ``disconnect``, ``time_out_call``, ``transport_status``), call
    :meth:`advance` for each step, and after each of these calls take what they produced:
    the bridge's outputs (``drain``) and deadlines (``deadlines``), the frames to record
    (:meth:`record_frames`), whether the clock was reset or paused (:meth:`clock_changed`),
    and :attr:`failure` (an exception in :meth:`advance` is also raised).
    """

    def __init__(
        self,
        robot: LoadedRobot | LoadedWorld,
        options: CoreOptions,
        *,
        recorder: RecordSink | None = None,
        hub: EventHub | None = None,
        graph: Graph | None = None,
    ) -> None:
        self.robot = robot
        self.options = options
        self.clock: ClockMode = options.clock
        self.namespace = options.namespace
        if isinstance(robot, LoadedWorld) and options.namespace:
            raise SessionConfigError(
                f"namespace {options.namespace!r} applies to a session of one robot: the robots "
                "of a world take their namespaces from their RobotSpec"
            )
        self.sim = Simulation(robot, kinematic_limits=options.kinematic_limits)
        # each step's recorded state is read straight into the recorder's slot
        self._state_slot = (
            None
            if recorder is None
            else recorder.physics_state_slot(
                self.sim.state_spec, self.sim.state_size, *qpos_qvel_slices(self.sim.model)
            )
        )
        self.robot_name = robot.name
        self.recorder = recorder
        self.hub = hub if hub is not None else EventHub()
        self.hub.add_sink(RosoutSink(self))
        self.bridge: SessionBridge | None = None
        if graph is None:
            keep_frames = recorder is not None and options.record_bridge_frames
            self.bridge = SessionBridge(
                lambda: self.sim.sim_time_ns, keep_frames=keep_frames, peer_status=self._peer_status
            )
            graph = BridgePort(self.bridge, self.fail)
        self.graph: Graph = graph
        self.robots = robot_channels(
            self.sim, robot, self.namespace, options.command_topic, self, check_session_name
        )
        """Every robot's topics, joints and links, in the world's order."""
        self.topics = self.robots[0].topics
        self.links = tuple(link for r in self.robots for link in r.links)
        """MuJoCo body names of every robot's links."""
        self.dt_ns = self.sim.dt_ns
        self.sensors = session_sensors(
            robot, self.sim.model, options.sensors, namespace=self.namespace,
            seed=options.seed, dt_ns=self.dt_ns,
            base_driven=base_driven(options.controllers, robot, self.namespace),
        )  # fmt: skip
        """The simulated sensors (None without any: then no sensor code runs)."""
        if self.sensors is not None and recorder is not None:
            record_metadata(self.sensors, recorder)
        hz = options.joint_states_hz
        self._js_every = period_steps(hz, self.dt_ns)
        self._tf_every = period_steps(hz if options.tf_hz is None else options.tf_hz, self.dt_ns)
        self._clock_every = period_steps(
            hz if options.clock_hz is None else options.clock_hz, self.dt_ns
        )
        self._state_every = options.state_every
        self._epoch = 0  # resets so far: each is recorded as an epoch (harness_msgs/Epoch)
        self._tf_trees = tf_trees(self.sim.model, self.robots)
        self.published = published_topics(
            self.robots,
            joint_states=bool(self._js_every),
            tf=bool(self._tf_every),
            clock=bool(self._clock_every),
        )
        """Every topic the simulation publishes (type, node, latched), in advertising order."""
        self.publish_counts = PublishCounter()  # what /harness/step's until_topic counts
        self.paused = options.start != "now"
        self.awaiting_client = options.start == "on_client"
        """``start="on_client"``: the clock still waits for its first client
        (:meth:`start_on_client`); any resume of the clock ends the wait."""
        self.pause_at: int | None = None
        """The step at whose boundary a free-running clock pauses (:meth:`pause_if_due`),
        None for none (set from Python: :meth:`harness.session.Session.pause_at`)."""
        self.failure: BaseException | None = None
        """Why the simulation stopped (an unstable step, a logger or recording error...),
        else None."""
        self.failure_step: int | None = None
        """The step at which :attr:`failure` happened (the step being taken when it was)."""
        self._clock_changed = False  # drained by clock_changed()
        self.control = ControlHost(self, options.controllers)
        """Every robot's ros2_control controllers and controller manager."""
        self.peer_statuses: dict[str, int] = {}
        """Status frames received from connections, by level (see :class:`SessionBridge`)."""

    # ----------------------------------------------------------------------------- set-up

    def robot_channels(self, namespace: str) -> RobotChannels:
        """The robot with ``namespace`` (:class:`SessionError` naming the namespaces if none)."""
        for channels in self.robots:
            if channels.namespace == namespace:
                return channels
        raise SessionError(
            f"no robot with namespace {namespace!r} (robots: "
            f"{', '.join(repr(r.namespace) for r in self.robots)})"
        )

    def start(self) -> None:
        """Advertise every published topic, subscribe every robot's command topics and
        serve the services."""
        graph = self.graph
        advertise_and_subscribe(graph, self.published)
        if self.sensors is not None:  # on the graph from the start, not from a first message
            for topic, msgtype in self.sensors.topics():
                graph.advertise(topic, msgtype, node=HARNESS_NODE)
        HarnessServices(self, reset=self._reset, pause=self._set_paused).serve(graph)
        self.control.start()

    def publish_initial(self) -> None:
        """Publish every robot's latched description and static transforms and record/publish
        step 0 (after :meth:`start`, once the graph has settled)."""
        publish_latched(self, self.sim, self._tf_trees, self.robots, self.sensors)
        self._after_state()

    # ----------------------------------------------------------------------------- stepping

    def fail(self, exc: BaseException) -> None:
        """Stop the run: ``exc`` becomes :attr:`failure` (logged once)."""
        if self.failure is None:
            self.failure = exc
            self.failure_step = self.sim.step_index
            with contextlib.suppress(Exception):
                self.log(Level.FATAL, FAILURE_PREFIX + str(exc))

    def clock_changed(self) -> bool:
        """Whether a reset or a pause changed how time moves since the last call (the
        shell re-anchors its pacing and wakes its clock); drained: the next call says False
        until it changes again."""
        changed, self._clock_changed = self._clock_changed, False
        return changed

    def check_running(self) -> None:
        """Raise :class:`SessionClosedError` when the simulation has failed."""
        if self.failure is not None:
            raise SessionClosedError(
                f"the simulation failed ({self.failure}); call reset() to start again"
            )

    def advance(self) -> None:
        """One step: trajectory setpoints, the step, then recording, loggers, publishing.

        Any exception on the way (the step, a controller, a logger, the recorder, a sensor)
        stops the run where it happened: it becomes :attr:`failure` (logged once) and is
        raised. Live stepping and a replay call this same method, so they fail alike."""
        try:
            self._advance()
        except Exception as exc:
            self.fail(exc)
            raise

    def _advance(self) -> None:
        sim = self.sim
        self.control.before_step()
        sim.step()
        self.record_frames()
        recorder = self.recorder
        if recorder is not None and sim.input_changed:
            applied = sim.last_input
            assert applied is not None
            recorder.write_applied_input(applied)
        if self.hub.has_loggers():
            self.hub.observe(StepContext.of(sim, self.robot_name))
        self._after_state()

    def _after_state(self, *, record_state: bool = True) -> None:
        """Record the state and publish what is due at the current step."""
        self.record_frames()
        sim = self.sim
        k, t = sim.step_index, sim.sim_time_ns
        slot = self._state_slot
        if slot is not None and record_state and k % self._state_every == 0:
            sim.get_state(slot.state)
            slot.write(k, t)
        control = self.control
        paced = control.paces_joint_states
        js_due = bool(self._js_every) and k % self._js_every == 0
        # nothing records and nobody listens: count the publication, build nothing
        quiet = self.recorder is None
        has_subscribers = self.graph.has_subscribers
        if js_due or (paced and self._js_every):
            for channels in self.robots:
                if paced and not control.joint_states_due(channels, k, js_due):
                    continue  # its joint_state_broadcaster's rate (a named controller set)
                if quiet and not has_subscribers(channels.topics.joint_states):
                    self.publish_counts.note(channels.topics.joint_states)
                    continue
                # one reading of the joints serves the subscribers' message and the recording
                arrays = cache(partial(joint_state_arrays, sim, channels))
                self.publish(
                    channels.topics.joint_states,
                    TYPE_JOINT_STATE,
                    partial(joint_state_message, t, channels, arrays),
                    recorded=partial(joint_state_record, t, channels, arrays),
                )
        if self._clock_every and k % self._clock_every == 0:
            if quiet and not has_subscribers(CLOCK):
                self.publish_counts.note(CLOCK)
            else:
                self.publish(
                    CLOCK, TYPE_CLOCK, partial(clock_msg, t), recorded=partial(ClockRecord, t)
                )
        if self._tf_every and k % self._tf_every == 0:
            for topic, _, tree in self._tf_trees:
                if quiet and not has_subscribers(topic):
                    self.publish_counts.note(topic)
                    continue
                # one kinematics pass serves the subscribers' message and the recording
                relative = cache(partial(tree.moving_poses, sim.data.qpos, sim.body_poses))
                self.publish(
                    topic,
                    TYPE_TF,
                    partial(tree.moving_message, relative, t),
                    recorded=partial(tree.moving_record, relative, t),
                )
        if self.sensors is not None:
            for due in self.sensors.due(sim.data, k, t):
                out = due.output
                self.publish(out.topic, out.msgtype, due.build, record=out.record)

    def _joint_state_of(self, channels: RobotChannels, prefix: str = "") -> dict[str, Any]:
        return joint_state_of(self.sim, channels, prefix)

    def joint_state(self) -> dict[str, Any]:
        """The ``sensor_msgs/msg/JointState`` of the current step: the robot's, or with
        several robots every robot's joints by MuJoCo (prefixed) name."""
        if len(self.robots) == 1 and not self.robots[0].prefix:
            return self._joint_state_of(self.robots[0])
        parts = [self._joint_state_of(r, r.prefix) for r in self.robots]
        merged = parts[0]
        for part in parts[1:]:
            for key in ("name", "position", "velocity", "effort"):
                merged[key] = [*merged[key], *part[key]]
        return merged

    def publish(
        self,
        topic: str,
        type: str,
        build: Callable[[], Mapping[str, Any]],
        *,
        recorded: Callable[[], Any] | None = None,
        latch: bool = False,
        record: bool = True,
    ) -> None:
        """Publish on the graph (when someone listens or ``latch``) and record (``record``);
        ``build`` makes the message only when needed; ``recorded``, when given, makes the same
        message as the record the recorder takes instead of the dict (a periodic record of
        :mod:`harness.recording`: :class:`~harness.recording.JointStateRecord`, ...)."""
        self.record_frames()
        self.publish_counts.note(topic)
        recorder = self.recorder if record else None
        send = latch or self.graph.has_subscribers(topic)
        if recorder is None and not send:
            return
        now = self.sim.sim_time_ns
        msg = None
        if recorder is not None:
            if recorded is None:
                msg = build()
                recorder.write_message(topic, type, msg, sim_time_ns=now)
            else:
                recorder.write_message(topic, type, recorded(), sim_time_ns=now)
        if send:
            self.graph.publish(topic, type, build() if msg is None else msg, now, latch=latch)

    # ----------------------------------------------------------------------------- frames

    def record_frames(self) -> None:
        """Write the frames and markers the bridge kept since the last call to the
        recording, each at the step it crossed at (drained: the shells call it after their
        calls into the bridge, the core before each of its own writes, so the recording
        keeps the order in which things happened)."""
        bridge = self.bridge
        recorder = self.recorder
        if bridge is None or recorder is None:
            return
        dt_ns = self.dt_ns
        for record in bridge.frames():
            recorder.write_bridge_frame(tap_frame(record, dt_ns))

    def _marker(self, topic: str, args: Mapping[str, Any]) -> None:
        if self.recorder is None or self.bridge is None or not self.options.record_bridge_frames:
            return
        self.record_frames()
        frame = marker_frame(
            topic, args, step=self.sim.step_index, dt_ns=self.dt_ns, seq=self.bridge.seq
        )
        self.recorder.write_bridge_frame(frame)

    def replay_frame(self, connection: int, op: str, topic: str, payload: str | bytes) -> None:
        """Apply one recorded incoming frame or marker at the current step boundary, as the
        live session did: opens ``connection`` (and any lower id not yet seen) first."""
        bridge = self.bridge
        if bridge is None:
            raise SessionError("replay needs the session's own bridge (not client mode)")
        if is_marker(DIRECTION_IN, connection, op, topic):
            replay_marker(self, topic, payload)
            return
        open_connection(bridge, connection)
        bridge.receive(connection, payload, self.sim.sim_time_ns)

    # ----------------------------------------------------------------------------- events

    def log(self, level: Level, text: str) -> None:
        """Emit a session log event (``/rosout``, sinks)."""
        self.record_frames()
        sim = self.sim
        self.hub.emit(
            [
                LogMessage.of(
                    step=sim.step_index,
                    sim_time_ns=sim.sim_time_ns,
                    robot=self.robot_name,
                    text=text,
                    level=level,
                    name=_LOG_NAME,
                )
            ]
        )

    def _peer_status(self, connection: int, level: str, text: str) -> None:
        self.peer_statuses[level] = self.peer_statuses.get(level, 0) + 1
        severity = {"info": Level.INFO, "warning": Level.WARNING}.get(level, Level.ERROR)
        self.log(severity, f"connection {connection} status {level}: {text}")

    def notices(self, topic: str, connection: int, notices: Sequence[Notice]) -> None:
        """Report a command's notices: a ``warning`` status to its client (``connection``
        not 0) and a warning event."""
        for notice in notices:
            text = f"{topic}: {notice.message}"
            if connection:
                self.graph.status(connection, "warning", text)
            self.log(Level.WARNING, text)

    def refuse(self, topic: str, connection: int, reason: str) -> None:
        """Report a refused command: an ``error`` status to its client (``connection`` not
        0) and an error event."""
        text = f"{topic}: command refused: {reason}"
        if connection:
            self.graph.status(connection, "error", text)
        self.log(Level.ERROR, text)

    # ----------------------------------------------------------------------------- services

    def reset(self) -> str:
        """Back to the initial state, step numbering continuing (recorded as a marker)."""
        self._marker(MARKER_PYTHON, {"call": "reset"})
        return self._reset()

    def _reset(self) -> str:
        sim = self.sim
        k = restart(sim)
        for channels in self.robots:
            channels.commands.trajectory = None
        self.control.reset()
        self.failure = None
        self.failure_step = None
        self._clock_changed = True
        text = f"reset to the initial state at step {k} (step numbering continues)"
        self._epoch += 1
        self.record_frames()
        recorder = self.recorder
        if recorder is not None:
            # The state recorded for step k ends the epoch before; this one starts the next.
            recorder.write_epoch(reset_epoch(sim, self._epoch))
        self.log(Level.WARNING, text)
        self._after_state(record_state=False)
        return text

    def set_paused(self, paused: bool) -> str:
        """Pause or resume a free-running clock (recorded as a marker); returns the text
        ``/harness/pause`` answers."""
        self._marker(MARKER_PYTHON, {"call": "pause", "paused": paused})
        return self._set_paused(paused)

    def _set_paused(self, paused: bool) -> str:
        self.paused = paused
        if not paused:
            self.awaiting_client = False  # a recorded resume: a replay ends the wait alike
        self._clock_changed = True
        k = self.sim.step_index
        if self.clock == "lockstep":
            return f"lockstep clock: time moves only on {SERVICE_STEP} (step {k})"
        return f"paused at step {k}" if paused else f"running from step {k}"

    def start_on_client(self) -> bool:
        """At a step boundary, before the frames waiting there: start the clock of
        ``start="on_client"`` once a connection has opened (recorded as a resume marker, so
        before any of that client's frames). True when it started."""
        bridge = self.bridge
        if not self.awaiting_client or bridge is None or not bridge.opened:
            return False
        self.set_paused(False)
        return True

    def pause_if_due(self) -> bool:
        """At a step boundary: pause a free-running clock that has reached :attr:`pause_at`
        (recorded as a pause marker; the limit is then cleared). True when it paused."""
        if self.pause_at is None or self.sim.step_index < self.pause_at:
            return False
        self.pause_at = None
        self.set_paused(True)
        return True

    def record_close(self) -> None:
        """Record the ``harness/close`` marker: the run ended after the current step."""
        self._marker(MARKER_CLOSE, {"step": self.sim.step_index})

    def finish(self) -> list[SinkReport]:
        """End of run: loggers finish, sinks close; returns the sink reports."""
        self.record_frames()
        try:
            if self.hub.has_loggers():
                self.hub.finish(StepContext.of(self.sim, self.robot_name))
            self.record_frames()
        finally:
            reports = self.hub.close()
            if self.sensors is not None:
                self.sensors.close()
        return reports
