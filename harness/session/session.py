"""`Session`: one run. A :class:`~harness.sim.Simulation` of one robot on the rosbridge bridge,
driven by one clock, recorded, observed by loggers.

Threading and the one rule
--------------------------
A session owns one background thread running an asyncio event loop. Everything happens on that
loop: the WebSocket server's I/O, the bridge protocol, every simulation step, recording and
loggers. The server runs in *queued* mode: incoming frames wait, in arrival order, until the
next step boundary, where :meth:`BridgeServer.process_pending` applies them (commands then
take effect at the next step). The methods of :class:`Session` called from other threads
(``step``, ``run_until``, ``command``, reads) are handed to that loop and wait for it, so the
simulation is only ever touched by one thread.

Clock modes (simulation time is the only clock; wall time paces ``realtime`` and nothing else):

- ``lockstep``: time moves only on request, by :meth:`Session.step`/:meth:`Session.run_until`
  from Python or by the ``/harness/step`` service (``harness_msgs/srv/Step``) from a client.
  A step request is executed when its frame is processed, all its steps at once, and answered
  when they are done: frames a client sent before it take effect before those steps, frames
  sent after it after them. Frames that arrive while no one steps are applied at once (before
  the next step).
- ``fast``: steps continuously as fast as the machine allows, applying waiting frames at every
  step boundary.
- ``realtime``: like ``fast``, paced so that simulation time follows wall time x ``rate``
  (when the simulation cannot keep up it runs as fast as it can and does not burst to catch up).

``/harness/pause`` (``std_srvs/srv/SetBool``) stops and resumes ``fast`` and ``realtime``
stepping (frames are still applied); ``/harness/reset`` (``std_srvs/srv/Trigger``) returns the
robot and world to the initial state *without* resetting step numbering (recorded time never
goes backwards); ``/harness/get_state`` (``harness_msgs/srv/GetState``) answers the step, sim
time, clock mode and joint state.

Topics (relative names live under the robot's namespace, ``/<ns>/...``; ``/clock``,
``/rosout`` and ``/harness/*`` are global): published ``joint_states``
(``sensor_msgs/msg/JointState``, every joint with a position), ``/clock``, ``tf``
(``tf2_msgs/msg/TFMessage``: each robot link's pose in ``world``), ``robot_description``
(latched ``std_msgs/msg/String``: the source URDF/SDF/MJCF text), ``/rosout`` (log events);
commands on ``joint_command``, ``joint_trajectory`` and the forward controller topics
(:mod:`harness.session.commands`).

Refused commands
----------------
A command message that names an unknown joint, has a wrong array length or a non-finite value
changes nothing. Its client receives ``{"op": "status", "level": "error", "msg": TEXT}`` and the
same TEXT is logged as an ERROR event (``/rosout``, sinks), where TEXT is
``"<topic>: command refused: <reason>"``, e.g.
``"/joint_command: command refused: unknown joint 'elbow' (controllable joints: joint1, ...)"``.
A value beyond a joint's limits is clamped (dynamic modes; kinematic mode when
``kinematic_limits="clamp"``) and reported as a ``warning`` status and a WARNING event:
``"<topic>: joint 'joint1': position 9 is beyond its limits [-2.9, 2.9]: clamped to 2.9"``.

Recording (``record_to``)
-------------------------
Every frame in and out of the bridge (incoming frames with ``step`` = the step before which they
took effect and the sim time of the boundary they were applied at; outgoing with the current
step), the applied input whenever it changes, the physics state every ``state_every`` steps
(step 0 included), every published message, and the loggers' events (collisions, ``/rosout``).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import math
import threading
import time
from collections.abc import Callable, Coroutine, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType, TracebackType
from typing import Any, Literal, TypeVar

import mujoco
import numpy as np
import numpy.typing as npt

from harness.events import (
    EventHub,
    JointSample,
    Level,
    Logger,
    LogMessage,
    RecordingSink,
    Sink,
    SinkReport,
    StepContext,
)
from harness.events.events import Event
from harness.models import ControlMode, LoadedRobot, load_robot
from harness.recording import Recorder, describe_run
from harness.rosbridge import DIRECTION_IN, TapRecord
from harness.session.commands import (
    FORWARD_TOPICS,
    Trajectory,
    apply_forward,
    apply_joint_state,
    parse_trajectory,
)
from harness.session.errors import (
    CommandRefused,
    SessionClosedError,
    SessionConfigError,
    SessionError,
    SimTimeoutError,
)
from harness.session.ports import ClientPort, Port, ServerPort
from harness.session.topics import (
    TYPE_CLOCK,
    TYPE_FORWARD,
    TYPE_JOINT_STATE,
    TYPE_LOG,
    TYPE_STRING,
    TYPE_TF,
    TYPE_TRAJECTORY,
    clock_msg,
    joint_state_msg,
    log_msg,
    period_steps,
    stamp,
    tf_msg,
)
from harness.sim import CommandField, KinematicLimits, Notice, Simulation

__all__ = ["CLOCK_MODES", "ClockMode", "LoggerFactory", "Session", "SessionTopics"]

F64 = npt.NDArray[np.float64]
T = TypeVar("T")

ClockMode = Literal["lockstep", "fast", "realtime"]
CLOCK_MODES: tuple[ClockMode, ...] = ("lockstep", "fast", "realtime")
LoggerFactory = Callable[["Session"], Logger]
"""Builds a logger once the session (and so its model) exists."""

_SERVICE_STEP = "/harness/step"
_SERVICE_RESET = "/harness/reset"
_SERVICE_PAUSE = "/harness/pause"
_SERVICE_GET_STATE = "/harness/get_state"
_ROSOUT = "/rosout"
_CLOCK = "/clock"
_LOG_NAME = "harness.session"
_BEHIND_S = 0.25  # realtime: further behind than this, re-anchor instead of bursting


@dataclass(frozen=True)
class SessionTopics:
    """The resolved names of the robot's topics."""

    joint_states: str
    joint_command: str
    joint_trajectory: str
    tf: str
    robot_description: str
    forward: Mapping[CommandField, str] = field(default_factory=dict)
    clock: str = _CLOCK
    rosout: str = _ROSOUT


def _check_name(value: str, what: str) -> str:
    parts = value.strip("/").split("/")
    if not value.strip("/") or not all(p and (p[0].isalpha() or p[0] == "_") for p in parts):
        raise SessionConfigError(f"{what} {value!r} is not a valid ROS name")
    if not all(c.isalnum() or c in "_/" for c in value):
        raise SessionConfigError(f"{what} {value!r} is not a valid ROS name")
    return value


class _BridgeLogSink:
    """Publishes every event except joint samples on ``/rosout`` over the bridge."""

    name = "bridge-rosout"

    def __init__(self, session: Session) -> None:
        self._session = session
        self._delivered = 0

    def emit(self, event: Event) -> None:
        if isinstance(event, JointSample):
            return
        name = event.name if isinstance(event, LogMessage) else f"harness.{event.kind}"
        self._session._publish(
            _ROSOUT,
            TYPE_LOG,
            lambda: log_msg(event.sim_time_ns, int(event.level), name, event.message()),
            record=False,
        )
        self._delivered += 1

    def close(self) -> SinkReport:
        return SinkReport(self.name, self._delivered, 0)


class Session:
    """One run: a simulated robot behind a rosbridge v2 server (or client), one clock,
    optional recording and loggers. Starts in the constructor; use as a context manager (or
    call :meth:`close`): teardown stops stepping, closes every connection and the server,
    joins the thread and closes the recording, also when the ``with`` body raised.

    ``robot``: ``"demo"``, a model file path or a :class:`~harness.models.LoadedRobot`.
    ``mode``: control mode of every joint or joint -> mode (only when the session loads the
    robot; default ``"position"``). ``kinematic_limits``: kinematic commands beyond limits are
    ``"clamp"``\\ ed or ``"allow"``\\ ed (the original framework's "jumping"). ``clock``:
    ``"lockstep"`` (default), ``"fast"`` or ``"realtime"`` (x ``rate``). ``namespace``: topics
    under ``/<namespace>/``. ``host``/``port``: where the embedded server listens (port 0: any
    free port, see :attr:`url`); ``connect_to``: a ``ws://`` URL of an external rosbridge server
    to use instead (client mode). ``record_to``: an MCAP path (``state_every``: physics state
    every N steps). ``joint_states_hz``, ``tf_hz``, ``clock_hz``: publication rates in
    simulation time (``tf_hz``/``clock_hz`` default to ``joint_states_hz``; 0 turns one off).
    ``loggers``: loggers or factories ``f(session) -> Logger``; ``sinks``: event sinks besides
    the recording and ``/rosout``. ``scene``, ``seed``, ``scenario``: passed to the loader and
    the recording's metadata.
    """

    def __init__(
        self,
        robot: str | Path | LoadedRobot = "demo",
        *,
        mode: ControlMode | Mapping[str, ControlMode] | None = None,
        kinematic_limits: KinematicLimits = "clamp",
        clock: ClockMode = "lockstep",
        rate: float = 1.0,
        namespace: str = "",
        host: str = "127.0.0.1",
        port: int = 0,
        connect_to: str | None = None,
        record_to: str | Path | None = None,
        state_every: int = 1,
        joint_states_hz: float = 100.0,
        tf_hz: float | None = None,
        clock_hz: float | None = None,
        joint_command_topic: str = "joint_command",
        loggers: Iterable[Logger | LoggerFactory] = (),
        sinks: Iterable[Sink] = (),
        scene: str | Path | None = None,
        seed: int = 0,
        scenario: str | bytes | None = None,
    ) -> None:
        if clock not in CLOCK_MODES:
            raise SessionConfigError(
                f"clock must be one of {', '.join(CLOCK_MODES)}, not {clock!r}"
            )
        if not (isinstance(rate, int | float) and math.isfinite(rate) and rate > 0):
            raise SessionConfigError(f"rate must be a finite number > 0, not {rate!r}")
        if not isinstance(state_every, int) or state_every < 1:
            raise SessionConfigError(f"state_every must be an integer >= 1, not {state_every!r}")
        for what, hz in (
            ("joint_states_hz", joint_states_hz),
            ("tf_hz", tf_hz),
            ("clock_hz", clock_hz),
        ):
            if hz is not None and not (math.isfinite(hz) and hz >= 0):
                raise SessionConfigError(f"{what} must be >= 0 Hz, not {hz!r}")
        self.clock: ClockMode = clock
        self.rate = float(rate)
        self.namespace = _check_name(namespace, "namespace").strip("/") if namespace else ""
        self._closed = False
        self._close_lock = threading.Lock()
        self._loop = asyncio.new_event_loop()
        self._thread: threading.Thread | None = None
        self._port: Port | None = None
        self._recorder: Recorder | None = None
        self._driver: asyncio.Task[None] | None = None
        self.sink_reports: list[SinkReport] = []
        """One report per event sink, filled by :meth:`close`."""

        if isinstance(robot, LoadedRobot):
            if mode is not None:
                raise SessionConfigError(
                    "mode applies only when the session loads the robot: this LoadedRobot "
                    "was built with its control modes (load_robot(..., control=...))"
                )
            loaded = robot
        else:
            loaded = load_robot(robot, control=mode or "position", scene=scene)
        self.robot: LoadedRobot = loaded
        """The loaded robot (description, compiled model, sources)."""
        self.sim = Simulation(loaded, kinematic_limits=kinematic_limits)
        """The simulation. Touch it only from the session's thread (loggers, predicates) or
        while nothing else can step it; prefer the session's methods."""
        self.robot_name = loaded.name
        self.topics = self._resolve_topics(joint_command_topic)
        self._dt_ns = self.sim.dt_ns
        self._js_every = period_steps(joint_states_hz, self._dt_ns)
        self._tf_every = period_steps(joint_states_hz if tf_hz is None else tf_hz, self._dt_ns)
        self._clock_every = period_steps(
            joint_states_hz if clock_hz is None else clock_hz, self._dt_ns
        )
        self._state_every = state_every
        self._joint_state_layout()
        self._links = tuple(
            link.name
            for link in loaded.description.links
            if mujoco.mj_name2id(loaded.model, mujoco.mjtObj.mjOBJ_BODY, link.name) >= 0
        )
        self._trajectory: Trajectory | None = None
        self._trajectory_topic = ""
        self._trajectory_warned: set[str] = set()
        self._paused = False
        self._failure: BaseException | None = None
        self._anchor: tuple[float, int] | None = None
        self._watchers: list[Callable[[], None]] = []
        self._hub = EventHub()
        self._host = host
        self._port_number = port
        self._connect_to = connect_to
        self.record_path = Path(record_to) if record_to is not None else None
        try:
            if self.record_path is not None:
                description = describe_run(
                    loaded,
                    seed=seed,
                    scenario=scenario,
                    extra={
                        "clock": clock,
                        "rate": repr(self.rate),
                        "kinematic_limits": kinematic_limits,
                        "namespace": self.namespace,
                        "joint_states_hz": repr(joint_states_hz),
                    },
                )
                self._recorder = Recorder(
                    self.record_path,
                    metadata=description.metadata,
                    attachments=description.attachments,
                    state_every=state_every,
                )
                self._hub.add_sink(RecordingSink(self._recorder))
            self._hub.add_sink(_BridgeLogSink(self))
            for sink in sinks:
                self._hub.add_sink(sink)
            for item in loggers:
                self._hub.add_logger(item if isinstance(item, Logger) else item(self))
            self._thread = threading.Thread(
                target=self._loop.run_forever, name="harness-session", daemon=True
            )
            self._thread.start()
            self.url: str = self._await(self._start())
            """``ws://host:port`` of the embedded server (or the external server's URL)."""
        except BaseException:
            with contextlib.suppress(Exception):
                self.close()
            raise

    # ----------------------------------------------------------------------------- set-up

    def _resolve(self, name: str) -> str:
        _check_name(name, "topic")
        if name.startswith("/"):
            return name
        return f"/{self.namespace}/{name}" if self.namespace else f"/{name}"

    def _resolve_topics(self, joint_command: str) -> SessionTopics:
        return SessionTopics(
            joint_states=self._resolve("joint_states"),
            joint_command=self._resolve(joint_command),
            joint_trajectory=self._resolve("joint_trajectory"),
            tf=self._resolve("tf"),
            robot_description=self._resolve("robot_description"),
            forward=MappingProxyType({f: self._resolve(t) for f, t in FORWARD_TOPICS.items()}),
        )

    def _joint_state_layout(self) -> None:
        model = self.sim.model
        kinematic = set(self.sim.kinematic_joints)
        names: list[str] = []
        qadr: list[int] = []
        dadr: list[int] = []
        kin: list[bool] = []
        slide_hinge = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        for joint in self.robot.description.joints:
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.name)
            if jid < 0 or int(model.jnt_type[jid]) not in slide_hinge:
                continue
            names.append(joint.name)
            qadr.append(int(model.jnt_qposadr[jid]))
            dadr.append(int(model.jnt_dofadr[jid]))
            kin.append(joint.name in kinematic)
        self._js_names = tuple(names)
        self._js_qadr = np.array(qadr, dtype=np.intp)
        self._js_dadr = np.array(dadr, dtype=np.intp)
        self._js_kin = np.array(kin, dtype=bool)

    async def _start(self) -> str:
        port: Port
        if self._connect_to is not None:
            port = ClientPort(self._connect_to)
        else:
            tap = self._tap if self._recorder is not None else None
            port = ServerPort(host=self._host, port=self._port_number, tap=tap)
        self._port = port
        url = await port.start()
        topics = self.topics
        port.subscribe(topics.joint_command, TYPE_JOINT_STATE, self._on_joint_command)
        port.subscribe(topics.joint_trajectory, TYPE_TRAJECTORY, self._on_trajectory)
        for command_field, topic in topics.forward.items():
            port.subscribe(topic, TYPE_FORWARD, self._forward_handler(command_field, topic))
        port.serve(_SERVICE_STEP, "harness_msgs/srv/Step", self._srv_step)
        port.serve(_SERVICE_RESET, "std_srvs/srv/Trigger", self._srv_reset)
        port.serve(_SERVICE_PAUSE, "std_srvs/srv/SetBool", self._srv_pause)
        port.serve(_SERVICE_GET_STATE, "harness_msgs/srv/GetState", self._srv_get_state)
        await port.settle()
        description = self._description_text()
        self._publish(
            topics.robot_description, TYPE_STRING, lambda: {"data": description}, latch=True
        )
        self._after_state()
        self._driver = asyncio.get_running_loop().create_task(self._drive())
        return url

    def _description_text(self) -> str:
        for name, blob in self.robot.sources.items():
            if name.startswith("model/"):
                return blob.decode("utf-8", errors="replace")
        return self.robot.mjcf

    # ----------------------------------------------------------------------------- threads

    def _on_loop_thread(self) -> bool:
        return self._thread is not None and threading.current_thread() is self._thread

    def _await(self, coro: Coroutine[Any, Any, T]) -> T:
        if self._on_loop_thread():
            coro.close()
            raise SessionError(
                "this session method waits for the simulation: it cannot be called from the "
                "session's own thread (a predicate, logger or callback)"
            )
        if self._thread is None or not self._thread.is_alive():
            coro.close()
            raise SessionClosedError("the session is closed")
        return asyncio.run_coroutine_threadsafe(coro, self._loop).result()

    def _call(self, fn: Callable[[], T]) -> T:
        """Run ``fn`` on the session's thread (directly when already there)."""
        if self._on_loop_thread():
            return fn()
        if self._closed or self._thread is None or not self._thread.is_alive():
            raise SessionClosedError("the session is closed")
        future: concurrent.futures.Future[T] = concurrent.futures.Future()

        def run() -> None:
            try:
                future.set_result(fn())
            except BaseException as exc:
                future.set_exception(exc)

        self._loop.call_soon_threadsafe(run)
        return future.result()

    # ----------------------------------------------------------------------------- stepping

    async def _drive(self) -> None:
        """The one place time moves by itself (fast, realtime) and where frames are applied
        while nobody steps."""
        assert self._port is not None
        wake = self._port.wake
        while True:
            try:
                if self.clock == "lockstep" or self._paused or self._failure is not None:
                    await wake.wait()
                    self._boundary()
                    continue
                self._boundary()
                if self._paused or self._failure is not None:
                    continue
                self._advance()
                if self.clock == "realtime":
                    await self._pace()
                else:
                    await asyncio.sleep(0)
            except asyncio.CancelledError:
                raise
            except Exception as exc:
                self._fail(exc)

    async def _pace(self) -> None:
        now = time.monotonic()
        k = self.sim.step_index
        if self._anchor is None:
            self._anchor = (now, k)
        wall0, k0 = self._anchor
        delay = wall0 + (k - k0) * self._dt_ns / 1e9 / self.rate - now
        if delay > 0:
            await asyncio.sleep(delay)
        else:
            if delay < -_BEHIND_S:
                self._anchor = (now, k)
            await asyncio.sleep(0)

    def _boundary(self) -> None:
        assert self._port is not None
        self._port.process_pending(self.sim.sim_time_ns)

    def _fail(self, exc: BaseException) -> None:
        if self._failure is None:
            self._failure = exc
            with contextlib.suppress(Exception):
                self._log(Level.FATAL, f"the run failed: {exc}")

    def _check_running(self) -> None:
        if self._failure is not None:
            raise SessionClosedError(
                f"the simulation failed ({self._failure}); call reset() to start again"
            )

    def _advance(self) -> None:
        """One step: trajectory setpoints, the step, then recording, loggers, publishing."""
        sim = self.sim
        trajectory = self._trajectory
        if trajectory is not None:
            t_next = sim.sim_time_ns + self._dt_ns
            positions, velocities = trajectory.commands(t_next)
            notices = sim.set_positions(positions) if positions else []
            if velocities:
                notices += sim.set_velocities(velocities)
            fresh = [n for n in notices if n.joint not in self._trajectory_warned]
            if fresh:
                self._trajectory_warned.update(n.joint for n in fresh)
                self._report_notices(self._trajectory_topic, 0, fresh)
            if t_next >= trajectory.end_ns:
                self._trajectory = None
        try:
            sim.step()
        except Exception as exc:
            self._fail(exc)
            raise
        recorder = self._recorder
        if recorder is not None and sim.input_changed:
            applied = sim.last_input
            assert applied is not None
            recorder.write_applied_input(
                step=applied.step,
                sim_time_ns=applied.sim_time_ns,
                ctrl=applied.ctrl,
                kinematic_joints=applied.kinematic_joints,
                qpos_index=applied.qpos_index,
                qpos_value=applied.qpos_value,
                qvel_index=applied.qvel_index,
                qvel_value=applied.qvel_value,
                mocap_pos=applied.mocap_pos,
                mocap_quat=applied.mocap_quat,
                qfrc_applied=applied.qfrc_applied,
                xfrc_applied=applied.xfrc_applied,
            )
        if self._hub.loggers:
            self._hub.observe(StepContext.of(sim, self.robot_name))
        self._after_state()
        for watcher in tuple(self._watchers):
            watcher()

    def _after_state(self) -> None:
        """Record the state and publish what is due at the current step."""
        sim = self.sim
        k = sim.step_index
        recorder = self._recorder
        if recorder is not None and k % self._state_every == 0:
            data = sim.data
            recorder.write_physics_state(
                step=k,
                sim_time_ns=sim.sim_time_ns,
                state_spec=sim.state_spec,
                state=sim.get_state(),
                qpos=data.qpos,
                qvel=data.qvel,
            )
        topics = self.topics
        if self._js_every and k % self._js_every == 0:
            self._publish(topics.joint_states, TYPE_JOINT_STATE, self._joint_state)
        if self._clock_every and k % self._clock_every == 0:
            self._publish(topics.clock, TYPE_CLOCK, lambda: clock_msg(self.sim.sim_time_ns))
        if self._tf_every and k % self._tf_every == 0:
            self._publish(topics.tf, TYPE_TF, self._tf)

    def _joint_state(self) -> dict[str, Any]:
        data = self.sim.data
        effort: F64 = np.where(
            self._js_kin, data.qfrc_applied[self._js_dadr], data.qfrc_actuator[self._js_dadr]
        )
        return joint_state_msg(
            self.sim.sim_time_ns,
            self._js_names,
            data.qpos[self._js_qadr],
            data.qvel[self._js_dadr],
            effort,
        )

    def _tf(self) -> dict[str, Any]:
        poses = self.sim.link_poses()
        prefix = f"{self.namespace}/" if self.namespace else ""
        return tf_msg(
            self.sim.sim_time_ns, {n: poses[n] for n in self._links if n in poses}, "world", prefix
        )

    def _publish(
        self,
        topic: str,
        type: str,
        build: Callable[[], Mapping[str, Any]],
        *,
        latch: bool = False,
        record: bool = True,
    ) -> None:
        """Publish on the bridge (when someone listens or ``latch``) and record (``record``);
        ``build`` makes the message only when needed."""
        assert self._port is not None
        recorder = self._recorder if record else None
        send = latch or self._port.has_subscribers(topic)
        if recorder is None and not send:
            return
        msg = build()
        now = self.sim.sim_time_ns
        if recorder is not None:
            recorder.write_message(topic, type, msg, sim_time_ns=now)
        if send:
            self._port.publish(topic, type, msg, now, latch=latch)

    def _tap(self, record: TapRecord) -> None:
        assert self._recorder is not None
        k = self.sim.step_index
        data = record.data
        self._recorder.write_bridge_frame(
            step=k + 1 if record.direction == DIRECTION_IN else k,
            sim_time_ns=k * self._dt_ns,
            direction=record.direction,
            connection=record.connection,
            seq=record.seq,
            op=record.op,
            topic=record.name,
            text=data if isinstance(data, str) else None,
            data=data if isinstance(data, bytes) else None,
        )

    # ----------------------------------------------------------------------------- events

    def _log(self, level: Level, text: str) -> None:
        sim = self.sim
        self._hub.emit(
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

    def _report_notices(self, topic: str, connection: int, notices: Sequence[Notice]) -> None:
        assert self._port is not None
        for notice in notices:
            text = f"{topic}: {notice.message}"
            if connection:
                self._port.status(connection, "warning", text)
            self._log(Level.WARNING, text)

    def _refuse(self, topic: str, connection: int, reason: str) -> None:
        assert self._port is not None
        text = f"{topic}: command refused: {reason}"
        if connection:
            self._port.status(connection, "error", text)
        self._log(Level.ERROR, text)

    # ----------------------------------------------------------------------------- commands

    def _command(
        self, topic: str, connection: int, apply: Callable[[], list[Notice]], joints: set[str]
    ) -> list[Notice]:
        try:
            notices = apply()
        except CommandRefused as exc:
            self._refuse(topic, connection, str(exc))
            raise
        if self._trajectory is not None:
            self._trajectory = self._trajectory.without(joints)
        self._report_notices(topic, connection, notices)
        return notices

    def _on_joint_command(self, msg: Mapping[str, Any], connection: int) -> None:
        with contextlib.suppress(CommandRefused):
            self._command(
                self.topics.joint_command,
                connection,
                lambda: apply_joint_state(self.sim, msg),
                set(msg["name"]),
            )

    def _forward_handler(
        self, command_field: CommandField, topic: str
    ) -> Callable[[Mapping[str, Any], int], None]:
        def handle(msg: Mapping[str, Any], connection: int) -> None:
            with contextlib.suppress(CommandRefused):
                self._command(
                    topic,
                    connection,
                    lambda: apply_forward(self.sim, command_field, msg),
                    set(self.sim.joint_names),
                )

        return handle

    def _on_trajectory(self, msg: Mapping[str, Any], connection: int) -> None:
        topic = self.topics.joint_trajectory
        try:
            trajectory = parse_trajectory(self.sim, msg, self.sim.sim_time_ns)
        except CommandRefused as exc:
            self._refuse(topic, connection, str(exc))
            return
        self._trajectory = trajectory
        self._trajectory_topic = topic
        self._trajectory_warned = set()

    # ----------------------------------------------------------------------------- services

    def _srv_step(self, request: Mapping[str, Any]) -> Mapping[str, Any]:
        self._check_running()
        for _ in range(int(request["steps"])):
            self._advance()
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
            "paused": self._paused,
            "joint_state": self._joint_state(),
        }

    def _reset(self) -> str:
        sim = self.sim
        k = sim.step_index
        sim.reset()
        state = sim.get_state()
        state[0] = k * self._dt_ns / 1e9  # mjSTATE_TIME first: step numbering continues
        sim.set_state(state, k)
        self._trajectory = None
        self._failure = None
        self._anchor = None
        text = f"reset to the initial state at step {k} (step numbering continues)"
        self._log(Level.WARNING, text)
        self._after_state()
        return text

    def _set_paused(self, paused: bool) -> str:
        self._paused = paused
        self._anchor = None
        assert self._port is not None
        self._port.wake.set()
        k = self.sim.step_index
        if self.clock == "lockstep":
            return f"lockstep clock: time moves only on {_SERVICE_STEP} (step {k})"
        return f"paused at step {k}" if paused else f"running from step {k}"

    # ----------------------------------------------------------------------------- public API

    def step(self, n: int = 1) -> int:
        """Take ``n`` steps (lockstep, or a paused free-running clock), applying waiting frames
        at every step boundary; returns the step index reached."""
        if not isinstance(n, int) or n < 0:
            raise SessionError(f"step count must be an integer >= 0, not {n!r}")
        return self._await(self._steps(n))

    async def _steps(self, n: int) -> int:
        self._require_stepping()
        for i in range(n):
            self._boundary()
            self._check_running()
            self._advance()
            if i + 1 < n:
                await asyncio.sleep(0)
        return self.sim.step_index

    def _require_stepping(self) -> None:
        if self.clock != "lockstep" and not self._paused:
            raise SessionError(
                f"the clock is {self.clock}: time moves by itself; pause() first to step, or "
                "wait with run_until()"
            )
        self._check_running()

    def run_until(self, predicate: Callable[[], bool], *, sim_timeout: float) -> int:
        """Wait until ``predicate()`` holds, checked after every step on the session's thread
        (lockstep: stepping as needed). Returns the step at which it held; raises
        :class:`SimTimeoutError` naming the sim time when ``sim_timeout`` seconds of simulation
        time pass first."""
        if not (math.isfinite(sim_timeout) and sim_timeout >= 0):
            raise SessionError(f"sim_timeout must be >= 0 s, not {sim_timeout!r}")
        budget = math.ceil(round(sim_timeout * 1e9) / self._dt_ns)
        if self.clock == "lockstep":
            return self._await(self._run_until_lockstep(predicate, budget, sim_timeout))
        return self._await(self._run_until_free(predicate, budget, sim_timeout))

    def _timeout(self, sim_timeout: float) -> SimTimeoutError:
        t = self.sim.sim_time_ns
        return SimTimeoutError(
            f"condition not met within {sim_timeout:g} s of simulation time "
            f"(now step {self.sim.step_index}, sim time {t / 1e9:.6f} s)"
        )

    async def _run_until_lockstep(
        self, predicate: Callable[[], bool], budget: int, sim_timeout: float
    ) -> int:
        self._check_running()
        for i in range(budget + 1):
            if predicate():
                return self.sim.step_index
            if i == budget:
                break
            self._boundary()
            self._check_running()
            self._advance()
            await asyncio.sleep(0)
        raise self._timeout(sim_timeout)

    async def _run_until_free(
        self, predicate: Callable[[], bool], budget: int, sim_timeout: float
    ) -> int:
        if predicate():
            return self.sim.step_index
        done: asyncio.Future[int] = asyncio.get_running_loop().create_future()
        deadline = self.sim.step_index + budget

        def check() -> None:
            if done.done():
                return
            try:
                if predicate():
                    done.set_result(self.sim.step_index)
                elif self.sim.step_index >= deadline:
                    done.set_exception(self._timeout(sim_timeout))
            except Exception as exc:
                done.set_exception(exc)

        self._watchers.append(check)
        try:
            return await done
        finally:
            self._watchers.remove(check)

    def command(
        self,
        joint: str,
        *,
        position: float | None = None,
        velocity: float | None = None,
        effort: float | None = None,
    ) -> list[Notice]:
        """Command one joint from Python (takes effect at the next step; see
        :meth:`harness.sim.Simulation.command`); limit notices become warning events."""
        return self._call(
            lambda: self._python_command(
                lambda: self.sim.command(
                    joint, position=position, velocity=velocity, effort=effort
                ),
                {joint},
            )
        )

    def set_positions(self, positions: Mapping[str, float]) -> list[Notice]:
        """Position commands for several joints from Python."""
        values = dict(positions)
        return self._call(
            lambda: self._python_command(lambda: self.sim.set_positions(values), set(values))
        )

    def _python_command(self, apply: Callable[[], list[Notice]], joints: set[str]) -> list[Notice]:
        notices = apply()
        if self._trajectory is not None:
            self._trajectory = self._trajectory.without(joints)
        self._report_notices("python", 0, notices)
        return notices

    def reset(self) -> None:
        """Back to the initial state (step numbering continues), as ``/harness/reset``."""
        self._call(self._reset)

    def pause(self) -> None:
        """Stop a fast or realtime clock (frames are still applied), as ``/harness/pause``."""
        self._call(lambda: self._set_paused(True))

    def resume(self) -> None:
        """Restart a paused fast or realtime clock."""
        self._call(lambda: self._set_paused(False))

    @property
    def paused(self) -> bool:
        """Whether a free-running clock is paused."""
        return self._paused

    @property
    def failure(self) -> BaseException | None:
        """Why the simulation stopped (an unstable step, a recording error), else None."""
        return self._failure

    @property
    def step_index(self) -> int:
        """Steps taken (read on the session's thread)."""
        return self._call(lambda: self.sim.step_index)

    @property
    def sim_time_ns(self) -> int:
        """``step_index * dt_ns``."""
        return self._call(lambda: self.sim.sim_time_ns)

    @property
    def dt_ns(self) -> int:
        """The timestep in nanoseconds."""
        return self._dt_ns

    @property
    def model(self) -> mujoco.MjModel:
        """The compiled MuJoCo model (read only: runtime model edits break determinism)."""
        return self.sim.model

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The controllable joints, in the order of forward commands and per-joint arrays."""
        return self.sim.joint_names

    @property
    def link_names(self) -> tuple[str, ...]:
        """The robot's links that are MuJoCo bodies (the /tf child frames)."""
        return self._links

    def joint_positions(self) -> F64:
        """Positions of :attr:`joint_names`."""
        return self._call(self.sim.joint_positions)

    def joint_velocities(self) -> F64:
        """Velocities of :attr:`joint_names`."""
        return self._call(self.sim.joint_velocities)

    def joint_efforts(self) -> F64:
        """Efforts of :attr:`joint_names` (see :meth:`harness.sim.Simulation.joint_efforts`)."""
        return self._call(self.sim.joint_efforts)

    def joint_commands(self) -> F64:
        """The current command of each joint of :attr:`joint_names`."""
        return self._call(self.sim.joint_commands)

    def get_state(self) -> F64:
        """The full ``mjSTATE_INTEGRATION`` state."""
        return self._call(self.sim.get_state)

    def add_logger(self, logger: Logger | LoggerFactory) -> None:
        """Register a logger (observed from the next step on)."""
        built = logger if isinstance(logger, Logger) else logger(self)
        self._call(lambda: self._hub.add_logger(built))

    def add_sink(self, sink: Sink) -> None:
        """Register an event sink."""
        self._call(lambda: self._hub.add_sink(sink))

    def call(self, fn: Callable[[], T]) -> T:
        """Run ``fn()`` on the session's thread between steps and return its result (for
        consistent reads of :attr:`sim` while clients may be stepping)."""
        return self._call(fn)

    # ----------------------------------------------------------------------------- teardown

    def close(self) -> None:
        """Stop stepping, finish loggers and sinks, close every connection and the server,
        join the thread, close the recording (idempotent)."""
        with self._close_lock:
            if self._closed:
                return
            self._closed = True
        errors: list[BaseException] = []
        thread = self._thread
        if thread is not None and thread.is_alive():
            try:
                asyncio.run_coroutine_threadsafe(self._shutdown(), self._loop).result()
            except Exception as exc:
                errors.append(exc)
            self._loop.call_soon_threadsafe(self._loop.stop)
            thread.join()
        if not self._loop.is_running():
            self._loop.close()
        if self._recorder is not None:
            try:
                self._recorder.close()
            except Exception as exc:
                errors.append(exc)
        if errors:
            raise errors[0]

    async def _shutdown(self) -> None:
        if self._driver is not None:
            self._driver.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._driver
        try:
            if self._hub.loggers:
                self._hub.finish(StepContext.of(self.sim, self.robot_name))
        finally:
            self.sink_reports = self._hub.close()
            if self._port is not None:
                await self._port.stop()
            current = asyncio.current_task()
            others = [t for t in asyncio.all_tasks() if t is not current]
            for task in others:
                task.cancel()
            await asyncio.gather(*others, return_exceptions=True)
            await asyncio.get_running_loop().shutdown_default_executor()

    def __enter__(self) -> Session:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._closed else getattr(self, "url", "starting")
        return f"Session({self.robot_name!r}, clock={self.clock!r}, {state})"
