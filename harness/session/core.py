"""The session's per-step logic without sockets, threads or wall clocks (sans-I/O, h11-style).

:class:`SessionCore` is everything a session does between two step boundaries: the rosbridge
protocol core (:class:`SessionBridge`), the command topics, the publishing schedule, the
``/harness/*`` services, loggers and what goes to the recorder. Input arrives as rosbridge
frames at a step boundary (``bridge.receive``, called by the live server's queue or by replay);
output is outgoing frames (the bridge's outbox and tap), applied inputs, physics states and
published messages (a :class:`RecordSink`). The live :class:`~harness.session.Session` is a
thin asyncio/thread shell around one core; ``harness replay --level full``
(:mod:`harness.replay.pipeline`) drives a fresh core with the recorded frames, so both run
the same code.

Markers
-------
A few inputs are not frames a client sent, yet change what the core does. They are recorded
as ``/harness/bridge`` frames with ``direction`` 0 (in), ``connection`` 0 (real connections
count from 1), ``op`` ``""``, ``topic`` one of :data:`MARKERS` and a JSON ``text``; ``seq``
is the sequence number the next real frame gets (markers do not consume one), ``step`` and
``sim_time_ns`` as for incoming frames (the step before which it took effect):

- ``harness/disconnect`` ``{"connection": c}``: a client's socket closed;
- ``harness/call_timeout`` ``{"call": key}``: a service call routed to a client timed out on
  the wall clock (the transport's timer);
- ``harness/transport_status`` ``{"connection": c, "level": l, "msg": m}``: a ``status``
  frame the transport sent by itself (subscription frames dropped for a slow reader);
- ``harness/python`` ``{"call": "command" | "set_positions" | "reset" | "pause", ...}``:
  a call of the session's Python API that changes the run (stepping from Python needs no
  marker: replay steps to the recorded steps); a free-running clock started by its first
  client (``start="on_client"``) is recorded as ``{"call": "pause", "paused": false}``;
- ``harness/close`` ``{"step": k}``: the session closed after step ``k``, once every frame
  it received was processed; only ``harness/disconnect`` markers of connections still open
  follow it. It changes nothing (replay re-records it).

A connection opening needs no marker: a connection has no effect until its first frame, and
ids are given in order, so replay opens connection ``c`` when its first frame (or marker)
appears. Python loggers are not replayable from a file: what they publish on ``/rosout``
needs the same loggers (``loggers=`` of :func:`harness.replay.pipeline.replay_pipeline`).
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from types import MappingProxyType
from typing import Any, ClassVar, Literal, Protocol

import mujoco
import numpy as np
import numpy.typing as npt

from harness.events import (
    EventHub,
    JointSample,
    Level,
    LogMessage,
    SinkReport,
    StepContext,
)
from harness.events.events import Event
from harness.models import LoadedRobot, LoadedWorld, RobotModel
from harness.names import NameKind, check_name
from harness.recording.records import BridgeFrame, Epoch, PhysicsState
from harness.rosbridge import DIRECTION_IN, ActionGoal, Bridge, Output, TapRecord
from harness.sensors import TOPIC_TF_STATIC
from harness.sensors.hook import record_metadata, session_sensors
from harness.session.commands import (
    FORWARD_TOPICS,
    Trajectory,
    apply_forward,
    apply_joint_state,
    parse_trajectory,
)
from harness.session.control import (
    ControlHost,
)
from harness.session.errors import (
    CommandRefused,
    SessionClosedError,
    SessionConfigError,
    SessionError,
)
from harness.session.listed import ListedJoints
from harness.session.options import DEFAULT_MAX_STEP_REQUEST, CoreOptions
from harness.session.stepping import PublishCounter, parse_step_request, run_step
from harness.session.tf import RobotFrames, TfTree
from harness.session.topics import (
    HARNESS_NODE,
    TYPE_CLOCK,
    TYPE_FORWARD,
    TYPE_JOINT_STATE,
    TYPE_LOG,
    TYPE_STRING,
    TYPE_TF,
    TYPE_TRAJECTORY,
    TopicDef,
    clock_msg,
    joint_state_msg,
    log_msg,
    node_name,
    period_steps,
    robot_topic_defs,
    stamp,
)
from harness.session.urdf_text import description_text
from harness.sim import CommandField, Notice, RobotJoints, Simulation
from harness.sim.inputs import AppliedInput
from harness.vocabulary import CLOCK_MODES, ClockMode

__all__ = [
    "CLOCK_MODES",
    "DEFAULT_MAX_STEP_REQUEST",
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
    "RecordSink",
    "RobotChannels",
    "SessionBridge",
    "SessionCore",
    "SessionTopics",
    "StartMode",
    "is_marker",
]

F64 = npt.NDArray[np.float64]

StartMode = Literal["now", "paused", "on_client"]
START_MODES: tuple[StartMode, ...] = ("now", "paused", "on_client")

MARKER_DISCONNECT = "harness/disconnect"
MARKER_CALL_TIMEOUT = "harness/call_timeout"
MARKER_TRANSPORT_STATUS = "harness/transport_status"
MARKER_PYTHON = "harness/python"
MARKER_CLOSE = "harness/close"
MARKERS = (
    MARKER_DISCONNECT,
    MARKER_CALL_TIMEOUT,
    MARKER_TRANSPORT_STATUS,
    MARKER_PYTHON,
    MARKER_CLOSE,
)
"""The ``topic`` of every marker frame (see the module docstring)."""

SERVICE_STEP = "/harness/step"
SERVICE_RESET = "/harness/reset"
SERVICE_PAUSE = "/harness/pause"
SERVICE_GET_STATE = "/harness/get_state"
_ROSOUT = "/rosout"
_CLOCK = "/clock"
_TF = "/tf"
_TF_STATIC = "/tf_static"
_LOG_NAME = "harness.session"


def is_marker(direction: int, connection: int, op: str, topic: str) -> bool:
    """Whether a recorded ``/harness/bridge`` frame is a marker, not a frame a client sent."""
    return direction == DIRECTION_IN and connection == 0 and op == "" and topic in MARKERS


class RecordSink(Protocol):
    """What the core writes to the recording (:class:`harness.recording.Recorder` is one)."""

    def write_message(self, topic: str, msgtype: str, msg: Any, *, sim_time_ns: int) -> None: ...

    def write_bridge_frame(self, frame: BridgeFrame) -> None: ...

    def write_applied_input(self, inp: AppliedInput) -> None: ...

    def write_physics_state(self, record: PhysicsState) -> None: ...

    def write_epoch(self, epoch: Epoch) -> None: ...


MessageCallback = Callable[[Mapping[str, Any], int], None]
ServiceHandler = Callable[[Mapping[str, Any]], Mapping[str, Any]]


class Graph(Protocol):
    """The core's view of the ROS graph it publishes on (an in-process bridge or a client of
    an external server): synchronous, called only between steps."""

    def has_subscribers(self, topic: str) -> bool: ...

    def advertise(self, topic: str, type: str, *, node: str, latch: bool = False) -> None:
        """Put ``topic`` on the graph with its type before anything is published, as a
        publisher belonging to ``node`` (``latch``: transient local)."""
        ...

    def publish(
        self, topic: str, type: str, msg: Mapping[str, Any], now_ns: int, *, latch: bool = False
    ) -> None: ...

    def subscribe(
        self, topic: str, type: str, callback: MessageCallback, *, node: str = HARNESS_NODE
    ) -> None:
        """Call ``callback`` with each message on ``topic``, as a subscriber of ``node``."""
        ...

    def serve(
        self, service: str, type: str, handler: ServiceHandler, *, node: str = HARNESS_NODE
    ) -> None:
        """Answer ``service`` with ``handler``, as a service of ``node``."""
        ...

    def status(self, connection: int, level: str, text: str) -> None:
        """Tell one client something (a ``status`` frame), where the transport can."""
        ...


def _check_name(value: str, what: str, kind: NameKind = "topic") -> str:
    return check_name(value, what, kind, SessionConfigError)


@dataclass(frozen=True)
class SessionTopics:
    """The resolved names of the robot's topics."""

    joint_states: str
    joint_command: str
    joint_trajectory: str
    tf: str
    robot_description: str
    forward: Mapping[CommandField, str] = field(default_factory=dict)
    tf_static: str = _TF_STATIC
    clock: str = _CLOCK
    rosout: str = _ROSOUT


class SessionBridge(Bridge):
    """The session's rosbridge protocol core: every frame is processed at the simulation's
    current time, and inputs that are not client frames (a socket closing, a wall-clock call
    timeout, a status the transport sends by itself) are reported to ``on_marker`` before they
    take effect, so that a recording can hold them."""

    def __init__(self, clock: Callable[[], int]) -> None:
        super().__init__()
        self._clock = clock
        self._inside = 0
        self.on_marker: Callable[[str, dict[str, Any]], None] | None = None
        self.on_connect: Callable[[int], None] | None = None
        """Called with the id of every connection opened (the shell counts clients)."""
        self.on_disconnect: Callable[[int], None] | None = None
        """Called with the id of every connection closed."""
        self.on_peer_status: Callable[[int, str, str], None] | None = None
        """Called with ``(connection, level, msg)`` of every ``status`` frame a connection
        sends (an external rosbridge server's answers in client mode, the ROS 2 gateway's
        warnings): the core turns them into events, live and in a replay alike."""

    @contextlib.contextmanager
    def _core(self) -> Any:
        self._inside += 1
        try:
            yield
        finally:
            self._inside -= 1

    def _marker(self, topic: str, args: dict[str, Any]) -> None:
        if self.on_marker is not None:
            self.on_marker(topic, args)

    def receive(self, connection: int, data: str | bytes, now_ns: int) -> list[Output]:
        """Process one frame at the simulation's time (``now_ns`` is ignored: a step request
        earlier in the same batch may have moved time)."""
        with self._core():
            return super().receive(connection, data, self._clock())

    def connect(self, peer: str = "") -> int:
        cid = super().connect(peer)
        if self.on_connect is not None:
            self.on_connect(cid)
        return cid

    def disconnect(self, connection: int) -> list[Output]:
        was_open = connection in self.connections
        if was_open:
            self._marker(MARKER_DISCONNECT, {"connection": connection})
        with self._core():
            outputs = super().disconnect(connection)
        if was_open and self.on_disconnect is not None:
            self.on_disconnect(connection)
        return outputs

    def time_out_call(self, key: int) -> list[Output]:
        self._marker(MARKER_CALL_TIMEOUT, {"call": key})
        with self._core():
            return super().time_out_call(key)

    def status(self, connection: int, level: str, msg: str, id: Any = None) -> None:
        if not self._inside:
            self._marker(
                MARKER_TRANSPORT_STATUS, {"connection": connection, "level": level, "msg": msg}
            )
        super().status(connection, level, msg, id)

    def core_status(self, connection: int, level: str, msg: str) -> None:
        """A status the session itself sends (not a transport's)."""
        with self._core():
            super().status(connection, level, msg)

    def _op_peer_status(self, c: int, obj: Mapping[str, Any]) -> None:
        Bridge._OPS["status"](self, c, obj)  # validates level and msg
        if self.on_peer_status is not None:
            self.on_peer_status(c, str(obj.get("level", "info")), str(obj.get("msg", "")))

    _OPS: ClassVar[dict[str, Callable[[Bridge, int, Mapping[str, Any]], None]]] = {
        **Bridge._OPS,
        "status": _op_peer_status,  # type: ignore[dict-item]
    }


class BridgePort:
    """The in-process graph of a :class:`SessionBridge` (the embedded server's side)."""

    def __init__(self, bridge: SessionBridge) -> None:
        self.bridge = bridge

    def has_subscribers(self, topic: str) -> bool:
        return bool(self.bridge.subscribers_of(topic))

    def advertise(self, topic: str, type: str, *, node: str, latch: bool = False) -> None:
        self.bridge.advertise(topic, type, latch=latch, node=node)

    def publish(
        self, topic: str, type: str, msg: Mapping[str, Any], now_ns: int, *, latch: bool = False
    ) -> None:
        self.bridge.publish(topic, type, msg, now_ns, latch=latch)

    def subscribe(
        self, topic: str, type: str, callback: MessageCallback, *, node: str = HARNESS_NODE
    ) -> None:
        self.bridge.subscribe(topic, lambda m: callback(m.msg, m.connection), type, node=node)

    def serve(
        self, service: str, type: str, handler: ServiceHandler, *, node: str = HARNESS_NODE
    ) -> None:
        self.bridge.advertise_service(service, type, lambda call: handler(call.args), node=node)

    def serve_action(
        self,
        action: str,
        type: str,
        handler: Callable[[ActionGoal], None],
        *,
        node: str = HARNESS_NODE,
    ) -> None:
        """Serve an action in-process as ``node`` (the controllers' actions)."""
        self.bridge.advertise_action(action, type, handler, node=node)

    def status(self, connection: int, level: str, text: str) -> None:
        self.bridge.core_status(connection, level, text)


class _BridgeLogSink:
    """Publishes every event except joint samples on ``/rosout`` over the bridge."""

    name = "bridge-rosout"

    def __init__(self, core: SessionCore) -> None:
        self._core = core
        self._delivered = 0

    def emit(self, event: Event) -> None:
        if isinstance(event, JointSample):
            return
        name = event.name if isinstance(event, LogMessage) else f"harness.{event.kind}"
        self._core.publish(
            _ROSOUT,
            TYPE_LOG,
            lambda: log_msg(event.sim_time_ns, int(event.level), name, event.message()),
            record=False,
        )
        self._delivered += 1

    def close(self) -> SinkReport:
        return SinkReport(self.name, self._delivered, 0)


class RobotChannels:
    """One robot of a session, as its topics see it: ``namespace`` (ROS), ``prefix`` (of its
    MuJoCo names), its own ``description`` (unprefixed names), its controllable ``joints``
    (:class:`~harness.sim.RobotJoints`), resolved ``topics``, ``links`` (MuJoCo body names of
    its links: the ``/tf`` child frames are ``<namespace>/<link>``) and the latched
    ``robot_description`` text. Holds the robot's trajectory in progress."""

    def __init__(
        self,
        sim: Simulation,
        namespace: str,
        prefix: str,
        description: RobotModel,
        control: Iterable[str],
        topics: SessionTopics,
        description_text: str,
    ) -> None:
        self.namespace = namespace
        self.prefix = prefix
        self.description = description
        self.joints = RobotJoints(sim, control, prefix)
        self.topics = topics
        self.description_text = description_text
        model = sim.model
        self.links = tuple(
            prefix + link.name
            for link in description.links
            if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, prefix + link.name) >= 0
        )
        frame_prefix = f"{namespace}/" if namespace else ""
        self.frames = tuple(frame_prefix + link.removeprefix(prefix) for link in self.links)
        kinematic = set(sim.kinematic_joints)
        names: list[str] = []
        qadr: list[int] = []
        dadr: list[int] = []
        kin: list[bool] = []
        slide_hinge = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        for joint in description.joints:
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, prefix + joint.name)
            if jid < 0 or int(model.jnt_type[jid]) not in slide_hinge:
                continue
            names.append(joint.name)
            qadr.append(int(model.jnt_qposadr[jid]))
            dadr.append(int(model.jnt_dofadr[jid]))
            kin.append(prefix + joint.name in kinematic)
        self.js_names = tuple(names)
        """The joints in its ``joint_states`` (every hinge and slide joint, unprefixed)."""
        self.js_qadr = np.array(qadr, dtype=np.intp)
        self.js_dadr = np.array(dadr, dtype=np.intp)
        self.js_kin = np.array(kin, dtype=bool)
        self.listed = ListedJoints(description, self.js_names, self.joints.joint_names)
        """Listed on ``joint_states`` but not controllable: dropped from ``joint_command``."""
        self.trajectory: Trajectory | None = None
        self.trajectory_topic = ""
        self.trajectory_warned: set[str] = set()

    def drop_from_trajectory(self, joints: Iterable[str]) -> None:
        """Stop the trajectory driving ``joints`` (the robot's own names)."""
        if self.trajectory is not None:
            self.trajectory = self.trajectory.without(set(joints))


def _frames(channels: RobotChannels) -> RobotFrames:
    prefix = f"{channels.namespace}/" if channels.namespace else ""
    return RobotFrames(channels.description, channels.prefix, prefix)


class SessionCore:
    """One session's logic, sans-I/O. ``robot``: a loaded robot (one robot, its topics under
    ``options.namespace``) or a :class:`~harness.models.LoadedWorld` (each robot's topics under
    its own namespace, one global ``/tf``); a fresh :class:`~harness.sim.Simulation` of it is
    made. ``options``: see :class:`CoreOptions`; ``recorder``: where bridge frames, markers,
    applied inputs, states and published messages go; ``hub``: the event hub (its sinks and
    loggers; a ``/rosout`` publishing sink is added); ``graph``: an external graph (client
    mode) instead of the core's own :class:`SessionBridge` (:attr:`bridge`, None in client
    mode).

    Call only from one thread. Driving it: :meth:`start` once, then at each step boundary
    hand waiting frames to :attr:`bridge` (``receive``, ``disconnect``, ``time_out_call``) and
    take its outputs (``drain``), and call :meth:`advance` for each step.
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
        self.robot_name = robot.name
        self.recorder = recorder
        self.hub = hub if hub is not None else EventHub()
        self.hub.add_sink(_BridgeLogSink(self))
        self.bridge: SessionBridge | None = None
        if graph is None:
            self.bridge = SessionBridge(lambda: self.sim.sim_time_ns)
            graph = BridgePort(self.bridge)
            if recorder is not None and options.record_bridge_frames:
                self.bridge.tap = self._tap
                self.bridge.on_marker = self._marker
            self.bridge.on_peer_status = self._peer_status
        self.graph: Graph = graph
        self.robots = self._robot_channels(robot)
        """Every robot's topics, joints and links, in the world's order."""
        self.topics = self.robots[0].topics
        self.links = tuple(link for r in self.robots for link in r.links)
        """MuJoCo body names of every robot's links."""
        self.dt_ns = self.sim.dt_ns
        self.sensors = session_sensors(
            robot, self.sim.model, options.sensors, namespace=self.namespace,
            seed=options.seed, dt_ns=self.dt_ns,
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
        tf_topics: dict[tuple[str, str], list[RobotChannels]] = {}
        for channels in self.robots:
            key = (channels.topics.tf, channels.topics.tf_static)
            tf_topics.setdefault(key, []).append(channels)
        self._tf_trees = tuple(
            (tf, tf_static, TfTree(self.sim.model, (_frames(r) for r in rs)))
            for (tf, tf_static), rs in tf_topics.items()
        )
        self.published = self._published_topics()
        """Every topic the simulation publishes (type, node, latched), in advertising order."""
        self._next_seq = 0
        self.publish_counts = PublishCounter()  # what /harness/step's until_topic counts
        self.paused = options.start != "now"
        self.failure: BaseException | None = None
        """Why the simulation stopped (an unstable step, a recording error), else None."""
        self.after_step: list[Callable[[], None]] = []
        """Called after every step (the shell's ``run_until`` watchers)."""
        self.on_clock_change: Callable[[], None] | None = None
        """Called when a reset or pause changes how time should move (the shell re-paces)."""
        self.control = ControlHost(self, options.controllers)
        """Every robot's ros2_control controllers and controller manager."""
        self.peer_statuses: dict[str, int] = {}
        """Status frames received from connections, by level (see ``on_peer_status``)."""

    # ----------------------------------------------------------------------------- set-up

    @staticmethod
    def _resolve(name: str, namespace: str) -> str:
        _check_name(name, "topic")
        if name.startswith("/"):
            return name
        return f"/{namespace}/{name}" if namespace else f"/{name}"

    def _topics(self, namespace: str, tf: str | None) -> SessionTopics:
        def resolve(name: str) -> str:
            return self._resolve(name, namespace)

        return SessionTopics(
            joint_states=resolve("joint_states"),
            joint_command=resolve(self.options.command_topic(namespace)),
            joint_trajectory=resolve("joint_trajectory"),
            tf=resolve("tf") if tf is None else tf,
            robot_description=resolve("robot_description"),
            forward=MappingProxyType({f: resolve(t) for f, t in FORWARD_TOPICS.items()}),
            tf_static=resolve("tf_static") if tf is None else _TF_STATIC,
        )

    def _published_topics(self) -> tuple[TopicDef, ...]:
        defs: list[TopicDef] = []
        for channels in self.robots:
            topics = channels.topics
            defs += robot_topic_defs(
                channels.namespace,
                joint_states=topics.joint_states if self._js_every else None,
                tf=topics.tf if self._tf_every else None,
                tf_static=topics.tf_static,
                robot_description=topics.robot_description,
            )
        if self._clock_every:
            defs.append(TopicDef(_CLOCK, TYPE_CLOCK, HARNESS_NODE))
        defs.append(TopicDef(_ROSOUT, TYPE_LOG, HARNESS_NODE))
        return tuple(defs)

    def _robot_channels(self, robot: LoadedRobot | LoadedWorld) -> tuple[RobotChannels, ...]:
        sim = self.sim
        if isinstance(robot, LoadedRobot):
            return (
                RobotChannels(
                    sim,
                    self.namespace,
                    "",
                    robot.description,
                    robot.control,
                    self._topics(self.namespace, None),
                    description_text(robot.description, robot.sources, robot.mjcf),
                ),
            )
        out = tuple(
            RobotChannels(
                sim,
                view.namespace,
                view.prefix,
                view.description,
                view.control,
                self._topics(view.namespace, _TF),
                description_text(view.description, view.sources, robot.mjcf),
            )
            for view in robot.robots
        )
        owner: dict[str, str] = {}
        for channels in out:
            topics = channels.topics
            for topic in (
                topics.joint_states,
                topics.joint_command,
                topics.joint_trajectory,
                topics.robot_description,
                *topics.forward.values(),
            ):
                if topic in owner:
                    raise SessionConfigError(
                        f"topic {topic} is robot {channels.namespace or '(no namespace)'!r}'s and "
                        f"robot {owner[topic] or '(no namespace)'!r}'s: give each robot its own "
                        "(a relative joint_command_topic lives under each namespace)"
                    )
                owner[topic] = channels.namespace
        return out

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
        for published in self.published:
            graph.advertise(
                published.name, published.type, node=published.node, latch=published.latched
            )
        for channels in self.robots:
            topics = channels.topics
            graph.subscribe(
                topics.joint_command, TYPE_JOINT_STATE, self._joint_command_handler(channels)
            )
            graph.subscribe(
                topics.joint_trajectory, TYPE_TRAJECTORY, self._trajectory_handler(channels)
            )
            for command_field, topic in topics.forward.items():
                if self.control.claims(topic):
                    continue  # served by the forward command controller of that name
                controller = FORWARD_TOPICS[command_field].split("/")[0]
                graph.subscribe(
                    topic,
                    TYPE_FORWARD,
                    self._forward_handler(channels, command_field, topic),
                    node=node_name(channels.namespace, controller),
                )
        graph.serve(SERVICE_STEP, "harness_msgs/srv/Step", self._srv_step)
        graph.serve(SERVICE_RESET, "std_srvs/srv/Trigger", self._srv_reset)
        graph.serve(SERVICE_PAUSE, "std_srvs/srv/SetBool", self._srv_pause)
        graph.serve(SERVICE_GET_STATE, "harness_msgs/srv/GetState", self._srv_get_state)
        self.control.start()

    def publish_initial(self) -> None:
        """Publish every robot's latched description and static transforms and record/publish
        step 0 (after :meth:`start`, once the graph has settled)."""
        poses = self.sim.link_poses()
        sensor_frames = self.sensors is not None
        for _, tf_static, tree in self._tf_trees:
            # one latched message per topic: a late subscriber gets only the last one
            with_sensors = sensor_frames and tf_static == TOPIC_TF_STATIC
            sensor_frames = sensor_frames and not with_sensors
            build = partial(self._static_tf, tree, poses, with_sensors)
            self.publish(tf_static, TYPE_TF, build, latch=True)
        for channels in self.robots:
            text = channels.description_text
            self.publish(
                channels.topics.robot_description,
                TYPE_STRING,
                lambda text=text: {"data": text},  # type: ignore[misc]
                latch=True,
            )
        if sensor_frames and self.sensors is not None:
            self.publish(TOPIC_TF_STATIC, TYPE_TF, self.sensors.static_tf, latch=True)
        self._after_state()

    def _static_tf(
        self, tree: TfTree, poses: Mapping[str, Any], with_sensors: bool
    ) -> dict[str, Any]:
        msg = tree.message(tree.static, poses, self.sim.sim_time_ns)
        if with_sensors and self.sensors is not None:
            sensors = self.sensors.static_tf(self.sim.sim_time_ns)
            msg["transforms"] = [*msg["transforms"], *sensors["transforms"]]
        return msg

    # ----------------------------------------------------------------------------- stepping

    def fail(self, exc: BaseException) -> None:
        """Stop the run: ``exc`` becomes :attr:`failure` (logged once)."""
        if self.failure is None:
            self.failure = exc
            with contextlib.suppress(Exception):
                self.log(Level.FATAL, f"the run failed: {exc}")

    def check_running(self) -> None:
        """Raise :class:`SessionClosedError` when the simulation has failed."""
        if self.failure is not None:
            raise SessionClosedError(
                f"the simulation failed ({self.failure}); call reset() to start again"
            )

    def advance(self) -> None:
        """One step: trajectory setpoints, the step, then recording, loggers, publishing."""
        sim = self.sim
        self.control.before_step()
        for channels in self.robots:
            if channels.trajectory is not None:
                self._trajectory_setpoint(channels)
        try:
            sim.step()
        except Exception as exc:
            self.fail(exc)
            raise
        recorder = self.recorder
        if recorder is not None and sim.input_changed:
            applied = sim.last_input
            assert applied is not None
            recorder.write_applied_input(applied)
        if self.hub.loggers:
            self.hub.observe(StepContext.of(sim, self.robot_name))
        self._after_state()
        for watcher in tuple(self.after_step):
            watcher()

    def _trajectory_setpoint(self, channels: RobotChannels) -> None:
        trajectory = channels.trajectory
        assert trajectory is not None
        t_next = self.sim.sim_time_ns + self.dt_ns
        positions, velocities = trajectory.commands(t_next)
        joints = channels.joints
        notices = joints.set_positions(positions) if positions else []
        if velocities:
            notices += joints.set_velocities(velocities)
        fresh = [n for n in notices if n.joint not in channels.trajectory_warned]
        if fresh:
            channels.trajectory_warned.update(n.joint for n in fresh)
            self._report_notices(channels.trajectory_topic, 0, fresh)
        if t_next >= trajectory.end_ns:
            channels.trajectory = None

    def _after_state(self, *, record_state: bool = True) -> None:
        """Record the state and publish what is due at the current step."""
        sim = self.sim
        k = sim.step_index
        recorder = self.recorder
        if recorder is not None and record_state and k % self._state_every == 0:
            data = sim.data
            recorder.write_physics_state(
                PhysicsState(
                    k, sim.sim_time_ns, sim.state_spec, sim.get_state(), data.qpos, data.qvel
                )
            )
        if self._js_every and k % self._js_every == 0:
            for channels in self.robots:
                self.publish(
                    channels.topics.joint_states,
                    TYPE_JOINT_STATE,
                    lambda channels=channels: self._joint_state_of(channels),  # type: ignore[misc]
                )
        if self._clock_every and k % self._clock_every == 0:
            self.publish(_CLOCK, TYPE_CLOCK, lambda: clock_msg(self.sim.sim_time_ns))
        if self._tf_every and k % self._tf_every == 0:
            for topic, _, tree in self._tf_trees:
                self.publish(topic, TYPE_TF, partial(self._moving_tf, tree))
        if self.sensors is not None:
            for due in self.sensors.due(sim.data, k, sim.sim_time_ns):
                out = due.output
                self.publish(out.topic, out.msgtype, due.build, record=out.record)

    def _moving_tf(self, tree: TfTree) -> dict[str, Any]:
        return tree.message(tree.moving, self.sim.link_poses(), self.sim.sim_time_ns)

    def _joint_state_of(self, channels: RobotChannels, prefix: str = "") -> dict[str, Any]:
        data = self.sim.data
        effort: F64 = np.where(
            channels.js_kin,
            data.qfrc_applied[channels.js_dadr],
            data.qfrc_actuator[channels.js_dadr],
        )
        names = channels.js_names if not prefix else [prefix + n for n in channels.js_names]
        return joint_state_msg(
            self.sim.sim_time_ns,
            names,
            data.qpos[channels.js_qadr],
            data.qvel[channels.js_dadr],
            effort,
        )

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
        latch: bool = False,
        record: bool = True,
    ) -> None:
        """Publish on the graph (when someone listens or ``latch``) and record (``record``);
        ``build`` makes the message only when needed."""
        self.publish_counts.note(topic)
        recorder = self.recorder if record else None
        send = latch or self.graph.has_subscribers(topic)
        if recorder is None and not send:
            return
        msg = build()
        now = self.sim.sim_time_ns
        if recorder is not None:
            recorder.write_message(topic, type, msg, sim_time_ns=now)
        if send:
            self.graph.publish(topic, type, msg, now, latch=latch)

    # ----------------------------------------------------------------------------- frames

    def _tap(self, record: TapRecord) -> None:
        assert self.recorder is not None
        k = self.sim.step_index
        data = record.data
        self._next_seq = record.seq + 1
        binary = isinstance(data, bytes)
        text, payload = ("", data) if isinstance(data, bytes) else (data, b"")
        self.recorder.write_bridge_frame(
            BridgeFrame(
                step=k + 1 if record.direction == DIRECTION_IN else k,
                sim_time_ns=k * self.dt_ns,
                direction=record.direction,
                connection=record.connection,
                seq=record.seq,
                op=record.op,
                topic=record.name,
                binary=binary,
                text=text,
                data=payload,
            )
        )

    def _marker(self, topic: str, args: Mapping[str, Any]) -> None:
        if self.recorder is None or self.bridge is None or not self.options.record_bridge_frames:
            return
        k = self.sim.step_index
        self.recorder.write_bridge_frame(
            BridgeFrame(
                step=k + 1,
                sim_time_ns=k * self.dt_ns,
                direction=DIRECTION_IN,
                connection=0,
                seq=self._next_seq,
                op="",
                topic=topic,
                binary=False,
                text=json.dumps(args, sort_keys=True),
                data=b"",
            )
        )

    def replay_frame(self, connection: int, op: str, topic: str, payload: str | bytes) -> None:
        """Apply one recorded incoming frame or marker at the current step boundary, as the
        live session did: opens ``connection`` (and any lower id not yet seen) first."""
        bridge = self.bridge
        if bridge is None:
            raise SessionError("replay needs the session's own bridge (not client mode)")
        if is_marker(DIRECTION_IN, connection, op, topic):
            self._replay_marker(bridge, topic, payload)
            return
        self._open(bridge, connection)
        bridge.receive(connection, payload, self.sim.sim_time_ns)

    @staticmethod
    def _open(bridge: SessionBridge, connection: int) -> None:
        while connection not in bridge.connections and bridge.connect() < connection:
            pass

    def _replay_marker(self, bridge: SessionBridge, topic: str, payload: str | bytes) -> None:
        try:
            args = json.loads(payload)
            if not isinstance(args, dict):
                raise TypeError("not an object")
            if topic == MARKER_DISCONNECT:
                self._open(bridge, int(args["connection"]))
                bridge.disconnect(int(args["connection"]))
            elif topic == MARKER_CALL_TIMEOUT:
                bridge.time_out_call(int(args["call"]))
            elif topic == MARKER_TRANSPORT_STATUS:
                bridge.status(int(args["connection"]), str(args["level"]), str(args["msg"]))
            elif topic == MARKER_CLOSE:
                self.record_close()
            else:
                self._replay_python(args)
        except (ValueError, TypeError, KeyError) as exc:
            raise SessionError(f"marker {topic} {payload!r} is malformed: {exc}") from None

    def _replay_python(self, args: Mapping[str, Any]) -> None:
        call = args["call"]
        if call == "command":
            self.command(
                str(args["joint"]),
                position=args.get("position"),
                velocity=args.get("velocity"),
                effort=args.get("effort"),
            )
        elif call == "set_positions":
            self.set_positions({str(k): float(v) for k, v in args["positions"].items()})
        elif call == "reset":
            self.reset()
        elif call == "pause":
            self.set_paused(bool(args["paused"]))
        else:
            raise ValueError(f"unknown call {call!r}")

    # ----------------------------------------------------------------------------- events

    def log(self, level: Level, text: str) -> None:
        """Emit a session log event (``/rosout``, sinks)."""
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

    def _report_notices(self, topic: str, connection: int, notices: Sequence[Notice]) -> None:
        for notice in notices:
            text = f"{topic}: {notice.message}"
            if connection:
                self.graph.status(connection, "warning", text)
            self.log(Level.WARNING, text)

    def _refuse(self, topic: str, connection: int, reason: str) -> None:
        text = f"{topic}: command refused: {reason}"
        if connection:
            self.graph.status(connection, "error", text)
        self.log(Level.ERROR, text)

    # ----------------------------------------------------------------------------- commands

    def _command(
        self,
        channels: RobotChannels,
        topic: str,
        connection: int,
        apply: Callable[[], list[Notice]],
        joints: Iterable[str],
    ) -> list[Notice]:
        try:
            notices = apply()
        except CommandRefused as exc:
            self._refuse(topic, connection, str(exc))
            raise
        channels.drop_from_trajectory(joints)
        self._report_notices(topic, connection, notices)
        return notices

    def _joint_command_handler(
        self, channels: RobotChannels
    ) -> Callable[[Mapping[str, Any], int], None]:
        def handle(msg: Mapping[str, Any], connection: int) -> None:
            with contextlib.suppress(CommandRefused):
                self._command(
                    channels,
                    channels.topics.joint_command,
                    connection,
                    lambda: self._joint_state_command(channels, msg),
                    msg["name"],
                )

        return handle

    def _joint_state_command(self, channels: RobotChannels, msg: Mapping[str, Any]) -> list[Notice]:
        stripped, notices = channels.listed.strip(msg, self.sim.data.qpos[channels.js_qadr])
        return notices + apply_joint_state(channels.joints, stripped)

    def _forward_handler(
        self, channels: RobotChannels, command_field: CommandField, topic: str
    ) -> Callable[[Mapping[str, Any], int], None]:
        def handle(msg: Mapping[str, Any], connection: int) -> None:
            with contextlib.suppress(CommandRefused):
                self._command(
                    channels,
                    topic,
                    connection,
                    lambda: apply_forward(channels.joints, command_field, msg),
                    channels.joints.joint_names,
                )

        return handle

    def _trajectory_handler(
        self, channels: RobotChannels
    ) -> Callable[[Mapping[str, Any], int], None]:
        def handle(msg: Mapping[str, Any], connection: int) -> None:
            topic = channels.topics.joint_trajectory
            try:
                trajectory = parse_trajectory(channels.joints, msg, self.sim.sim_time_ns)
            except CommandRefused as exc:
                self._refuse(topic, connection, str(exc))
                return
            channels.trajectory = trajectory
            channels.trajectory_topic = topic
            channels.trajectory_warned = set()

        return handle

    def command(
        self,
        joint: str,
        *,
        position: float | None = None,
        velocity: float | None = None,
        effort: float | None = None,
    ) -> list[Notice]:
        """A Python command of one joint by its MuJoCo name (recorded as a ``harness/python``
        marker)."""
        values = {
            "position": None if position is None else float(position),
            "velocity": None if velocity is None else float(velocity),
            "effort": None if effort is None else float(effort),
        }
        self._marker(MARKER_PYTHON, {"call": "command", "joint": joint, **values})
        return self._python_command(
            lambda: self.sim.command(
                joint,
                position=values["position"],
                velocity=values["velocity"],
                effort=values["effort"],
            ),
            {joint},
        )

    def set_positions(self, positions: Mapping[str, float]) -> list[Notice]:
        """Python position commands by MuJoCo joint names (recorded as a ``harness/python``
        marker)."""
        values = {str(name): float(value) for name, value in positions.items()}
        self._marker(MARKER_PYTHON, {"call": "set_positions", "positions": values})
        return self._python_command(lambda: self.sim.set_positions(values), set(values))

    def _python_command(self, apply: Callable[[], list[Notice]], joints: set[str]) -> list[Notice]:
        notices = apply()
        for channels in self.robots:
            own = [j.removeprefix(channels.prefix) for j in joints if channels.joints.owns(j)]
            if own:
                channels.drop_from_trajectory(own)
        self._report_notices("python", 0, notices)
        return notices

    # ----------------------------------------------------------------------------- services

    def _srv_step(self, request: Mapping[str, Any]) -> Mapping[str, Any]:
        step = parse_step_request(request, self.options.max_step_request)
        self.check_running()
        run_step(step, self.advance, self.publish_counts)
        return {"sim_time": stamp(self.sim.sim_time_ns)}

    def _srv_reset(self, request: Mapping[str, Any]) -> Mapping[str, Any]:
        return {"success": True, "message": self._reset()}

    def _srv_pause(self, request: Mapping[str, Any]) -> Mapping[str, Any]:
        return {"success": True, "message": self._set_paused(bool(request["data"]))}

    def _srv_get_state(self, request: Mapping[str, Any]) -> Mapping[str, Any]:
        return {
            "step": self.sim.step_index,
            "sim_time": stamp(self.sim.sim_time_ns),
            "clock": self.clock,
            "paused": self.paused,
            "joint_state": self.joint_state(),
            "controllable_joints": list(self.sim.joint_names),
        }

    def reset(self) -> str:
        """Back to the initial state, step numbering continuing (recorded as a marker)."""
        self._marker(MARKER_PYTHON, {"call": "reset"})
        return self._reset()

    def _reset(self) -> str:
        sim = self.sim
        k = sim.step_index
        sim.reset()
        state = sim.get_state()
        state[0] = k * self.dt_ns / 1e9  # mjSTATE_TIME first: step numbering continues
        sim.set_state(state, k)
        for channels in self.robots:
            channels.trajectory = None
        self.control.reset()
        self.failure = None
        if self.on_clock_change is not None:
            self.on_clock_change()
        text = f"reset to the initial state at step {k} (step numbering continues)"
        self._epoch += 1
        recorder = self.recorder
        if recorder is not None:
            # The state recorded for step k ends the epoch before; this one starts the next.
            recorder.write_epoch(
                Epoch(
                    step=k,
                    sim_time_ns=sim.sim_time_ns,
                    epoch=self._epoch,
                    reason="reset",
                    state_spec=sim.state_spec,
                    state=sim.get_state(),
                    qpos=sim.data.qpos,
                    qvel=sim.data.qvel,
                )
            )
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
        if self.on_clock_change is not None:
            self.on_clock_change()
        k = self.sim.step_index
        if self.clock == "lockstep":
            return f"lockstep clock: time moves only on {SERVICE_STEP} (step {k})"
        return f"paused at step {k}" if paused else f"running from step {k}"

    def record_close(self) -> None:
        """Record the ``harness/close`` marker: the run ended after the current step."""
        self._marker(MARKER_CLOSE, {"step": self.sim.step_index})

    def finish(self) -> list[SinkReport]:
        """End of run: loggers finish, sinks close; returns the sink reports."""
        try:
            if self.hub.loggers:
                self.hub.finish(StepContext.of(self.sim, self.robot_name))
        finally:
            reports = self.hub.close()
            if self.sensors is not None:
                self.sensors.close()
        return reports
