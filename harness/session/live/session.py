"""`Session`: one run. A :class:`~harness.sim.Simulation` of one robot, or of several robots in
one world, on the rosbridge bridge, driven by one clock, recorded, observed by loggers.

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

Start control (``start``): a ``fast`` or ``realtime`` clock steps from the constructor on
(``"now"``), starts paused (``"paused"``: :meth:`Session.resume` starts it), or starts paused
until its first client connects (``"on_client"``: the clock starts at step 0, at the first
step boundary after the connection opened, before any of that client's frames is applied;
recorded as a ``harness/python`` resume marker). Readiness: :attr:`Session.client_count`
(open connections), :attr:`Session.clients_seen` (connections ever accepted) and
:meth:`Session.wait_for_client` (a wall-clock timeout: readiness, not simulation).

A ``/harness/step`` request asks for at most ``max_step_request`` steps (default 100000):
all of a request's steps run before any other frame is processed (that is what makes a
client's step request deterministic), so the cap bounds how long one request can block the
others; a larger request fails (``result: false``, the reason in ``values``) without stepping.

``/harness/pause`` (``std_srvs/srv/SetBool``) stops and resumes ``fast`` and ``realtime``
stepping (frames are still applied); ``/harness/reset`` (``std_srvs/srv/Trigger``) returns the
robot and world to the initial state *without* resetting step numbering (recorded time never
goes backwards); ``/harness/get_state`` (``harness_msgs/srv/GetState``) answers the step, sim
time, clock mode and joint state.

Topics (relative names live under the robot's namespace, ``/<ns>/...``; ``/clock``,
``/rosout`` and ``/harness/*`` are global): published ``joint_states``
(``sensor_msgs/msg/JointState``, every joint with a position), ``/clock``, ``tf``
(``tf2_msgs/msg/TFMessage``: each moving link's pose in its parent link's frame, following
the description's joints; a floating or mocap root's in ``world``), ``tf_static`` (latched
``tf2_msgs/msg/TFMessage``, once: fixed joints, sensor mounts, a base fixed to ``world``;
:mod:`harness.session.core.tf`), ``robot_description`` (latched ``std_msgs/msg/String``: the
source URDF/SDF/MJCF text), ``/rosout`` (log events); commands on ``joint_command``,
``joint_trajectory`` and the forward controller topics (:mod:`harness.controllers.command_topics`).
Every published topic is on the graph with its type from the start (a client that advertises
or subscribes to one with another type gets a status error), under the node a real robot
shows: ``robot_state_publisher`` (``tf``, ``tf_static``, ``robot_description``) and
``joint_state_broadcaster`` (``joint_states``) in the robot's namespace, ``/harness``
(``/clock``, ``/rosout``, ``/harness/*``); :attr:`SessionCore.published` lists them.

Several robots (``robots=[RobotSpec(...), ...]``, :func:`harness.models.load_world`)
------------------------------------------------------------------------------------
Every robot's topics live under its own namespace: ``/<ns>/joint_states``,
``/<ns>/joint_command`` (or its ``joint_command_topic``), ``/<ns>/joint_trajectory``,
``/<ns>/forward_{position,velocity,effort}_controller/commands`` and the latched
``/<ns>/robot_description`` (that robot's source file). Joint names in these messages are the
robot's own, unprefixed (``joint1``); forward commands take the robot's joints in its order
(:meth:`Session.joint_names_of`). One global ``/tf`` and one latched ``/tf_static`` carry
every robot's tree with frame ids ``<ns>/<link>`` (the tf_prefix convention, the same string
as the link's MuJoCo body name), each robot's root in ``world``; a robot in the empty
namespace keeps plain link names. ``/clock``,
``/rosout`` and ``/harness/*`` stay global, and ``/harness/get_state`` answers every joint by
its MuJoCo name (``<ns>/joint1``). The Python API (:meth:`Session.command`,
:meth:`Session.set_positions`, :attr:`Session.joint_names`) uses MuJoCo names too; the reads
take ``namespace=`` for one robot's joints in its order. Control modes are per joint of each
robot (``RobotSpec.control``); ``kinematic_limits`` is the session's. A one-robot session
(``robot=``) is unchanged: its ``namespace`` puts all of its topics, ``tf`` and ``tf_static``
included, under ``/<namespace>/`` and prefixes its frame ids.

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

Recording and closing
---------------------
What a recording holds and :meth:`Session.snapshot`: :mod:`harness.session.live.recordfile`.
:meth:`Session.close` ends a recording the same way for the same client behaviour (every frame
a client sent before it received the server's close frame is processed as at a step
boundary): :mod:`harness.session.live.teardown`.

Structure
---------
The per-step logic is :class:`~harness.session.core.SessionCore` (sans-I/O); this class is
the shell around it: the thread, the asyncio loop, the WebSocket server or client, the clock
modes, and the Python API handing calls to the loop. ``harness replay --level full`` drives a
fresh core with a recording's frames; ``Session.resume(path, step=K)`` (:mod:`harness.resume`)
puts this shell on a core those frames brought to step K (its recorded clients ghost peers).
The shell's pieces outside its hot path have modules of their own: building
(:mod:`harness.session.live.startup`, :mod:`harness.session.live.assembly`), the thread and its
loop (:mod:`harness.session.live.loopthread`), the recording file
(:mod:`harness.session.live.recordfile`), ``step``/``run_until`` from Python
(:mod:`harness.session.live.waiting`) and closing (:mod:`harness.session.live.teardown`).
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from functools import partial
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, Protocol, TypeVar, overload

import mujoco
import numpy as np
import numpy.typing as npt

from harness.events import Logger, Sink, SinkReport
from harness.models import LoadedRobot, LoadedWorld, RobotModel
from harness.recording import Recorder
from harness.resume import Edit, close_fork, install_preroll, open_fork
from harness.session.core.engine import (
    CLOCK_MODES,
    ClockMode,
    SessionCore,
    SessionTopics,
    StartMode,
)
from harness.session.core.options import (
    CoreOptions,
    LoadOptions,
    RecordOptions,
    SessionKeywords,
    TransportOptions,
)
from harness.session.errors import (
    ClientTimeoutError,
    SessionError,
)
from harness.session.live import heap
from harness.session.live.assembly import build_core, resolve_run, ros2_domain, start_ros2
from harness.session.live.loopthread import LoopThread
from harness.session.live.pacing import Anchor, frames_until, pace, waiting_until
from harness.session.live.ports import Port, ServerPort
from harness.session.live.recordfile import flush_at_boundary, start_recorder, write_snapshot
from harness.session.live.startup import option_groups
from harness.session.live.teardown import cancel_other_tasks, close_port, stop_driver
from harness.session.live.upstream import UpstreamStats
from harness.session.live.waiting import run_steps, run_until_free, run_until_lockstep
from harness.sim import Notice, Simulation

if TYPE_CHECKING:
    from typing_extensions import Unpack

__all__ = ["CLOCK_MODES", "ClockMode", "LoggerFactory", "Session", "SessionTopics", "StartMode"]

F64 = npt.NDArray[np.float64]
T = TypeVar("T")

LoggerFactory = Callable[["Session"], Logger]
"""Builds a logger once the session (and so its model) exists."""


class _ResumeFrom(Protocol):
    def __call__(
        self,
        path: str | Path,
        *,
        step: int | None = None,
        at_time: float | None = None,
        **keywords: Any,
    ) -> Session: ...


def _resume_from(
    path: str | Path,
    *,
    step: int | None = None,
    at_time: float | None = None,
    record_to: str | Path | None = None,
    edits: Sequence[Edit | str] = (),
    preroll: float = 0.0,
    transport: TransportOptions | None = None,
    loggers: Iterable[Logger | LoggerFactory] = (),
    sinks: Iterable[Sink] = (),
    **transport_keywords: Any,
) -> Session:
    """A live session continuing the recording at ``path`` from ``step`` (or from the step
    at ``at_time`` seconds; the last step when neither is given). ``record_to``: the child
    recording (:mod:`harness.resume.child`). ``edits``: fork edits (:mod:`harness.resume.edits`,
    e.g. ``"joint.joint1=0.4"``). ``preroll``: seconds of sim time of recorded traffic played
    to each client that attaches, before its live traffic (:mod:`harness.resume.preroll`).
    ``transport`` (or its fields as keywords: ``host``, ``port``, ``token``, ``connect_to``,
    ``ros2``): where the session's bridge is. ``loggers``/``sinks``: as for
    :class:`~harness.session.Session`, from the step on.

    Raises :class:`~harness.resume.ResumeError` (one line) when the recording cannot be
    resumed at that step."""
    fork = open_fork(path, step=step, at_time=at_time, record_to=record_to, edits=edits)
    try:
        if preroll:
            install_preroll(fork, path, preroll)
        return Session(
            transport=transport,
            loggers=loggers,
            sinks=sinks,
            _resumed=(fork.core, fork.recorder),
            **transport_keywords,
        )
    except BaseException:
        close_fork(fork, discard=True)  # a shell that failed to start closed the core too
        raise


class _Resume:
    """``Session.resume``: on the class, a session resumed from a recording; on a session,
    restart its paused clock (the older meaning, kept)."""

    @overload
    def __get__(self, obj: None, owner: type[Session]) -> _ResumeFrom: ...

    @overload
    def __get__(self, obj: Session, owner: type[Session] | None = None) -> Callable[[], None]: ...

    def __get__(
        self, obj: Session | None, owner: type[Session] | None = None
    ) -> _ResumeFrom | Callable[[], None]:
        if obj is None:
            return _resume_from
        return obj._restart_clock


class Session:
    """One run: a simulated robot behind a rosbridge v2 server (or client), one clock,
    optional recording and loggers. Starts in the constructor; use as a context manager (or
    call :meth:`close`): teardown stops stepping, closes every connection and the server,
    joins the thread and closes the recording, also when the ``with`` body raised.

    Options come as objects, one per concern (:mod:`harness.session.core.options`):
    ``options`` (:class:`~harness.session.core.options.CoreOptions`: clock, rate, rates, topics,
    limits, seed, ...), ``transport`` (:class:`~harness.session.core.options.TransportOptions`),
    ``record`` (:class:`~harness.session.core.options.RecordOptions`, or the MCAP path) and ``load``
    (:class:`~harness.session.core.options.LoadOptions`); or as keyword arguments spelled as those
    fields (``Session(clock="fast", port=9090, record_to="run.mcap")``), the fields of a group
    given as an object not repeated as keywords. The keywords:

    ``robot``: ``"demo"`` (the default), a model file path or a
    :class:`~harness.models.LoadedRobot`. ``robots``: instead of ``robot``, several robots in
    one world: :class:`~harness.models.RobotSpec`\\ s (loaded with ``scene`` and ``objects``
    by :func:`~harness.models.load_world`) or a :class:`~harness.models.LoadedWorld` (see the
    module docstring for their topics).
    ``mode``: control mode of every joint or joint -> mode (only when the session loads the
    robot; default ``"position"``; ``"dynamic"`` is accepted as ``"position"``, see
    :class:`harness.vocabulary.ControlMode`; with ``robots`` each RobotSpec has its ``control``).
    ``kinematic_limits``: kinematic commands beyond limits are ``"clamp"``\\ ed or ``"allow"``\\ ed
    (the original framework's "jumping"). ``clock``: ``"lockstep"`` (default), ``"fast"`` or
    ``"realtime"`` (x ``rate``). ``namespace``: topics under ``/<namespace>/`` (one robot; with
    ``robots`` each has its own). ``host``/``port``: where the embedded server listens (port 0: any
    free port, see :attr:`url`; a non-loopback host issues an ``ExposedServerWarning``); ``token``:
    clients must present it (``?token=`` on the URL or ``Authorization: Bearer``; :attr:`url`
    carries it); ``connect_to``: a ``ws://`` URL of an external rosbridge server to use instead
    (client mode: see :mod:`harness.session.live.upstream`; ``connect_allow_refused``: start even
    when that server refuses some of the simulation's topics or services). ``record_to``: an
    MCAP path (``state_every``: physics state every N steps). ``ros2``: also put the
    simulation on DDS for ROS 2 nodes (:mod:`harness.ros2`; :attr:`ros_domain_id`).
    ``joint_states_hz``, ``tf_hz``, ``clock_hz``: publication rates in simulation time
    (``tf_hz``/``clock_hz`` default to ``joint_states_hz``; 0 turns one off).
    ``joint_command_topic``: the JointState command topic, relative to each robot's namespace or
    absolute; or namespace -> topic per robot. ``loggers``: loggers or factories ``f(session) ->
    Logger``; ``sinks``: event sinks besides the recording and ``/rosout``. ``scene``, ``seed``,
    ``scenario``: passed to the loader and the recording's metadata (``scene``: a built-in
    name, an MJCF scene or an SDF world; ``world`` is the same option, as Gazebo users name
    it). ``start``: ``"now"``, ``"paused"`` or ``"on_client"`` (free-running clocks only, see
    the module docstring).
    ``record_bridge_frames``: record the bridge frames and markers (default True).
    ``max_step_request``: the most steps one ``/harness/step`` request may ask for.
    ``robot_args``: the arguments of a xacro ``robot`` (name -> value; with ``robots`` each
    RobotSpec has its own); ``robot`` may be ``package://pkg/path``. ``self_collision``
    (``auto|off|on|srdf``), ``base`` (``fixed|floating``) and ``strict``: as for
    :func:`harness.models.load_robot` (``robot=`` only; with ``robots`` each RobotSpec has its own).
    ``controllers``: the robot's ros2_control controllers: a controllers YAML (file, text or
    mapping, :func:`harness.controllers.load_controllers`), None for the default set
    (:func:`harness.controllers.default_controllers`) or False for none.
    ``sensors``: sensors besides those the robot files declare (mappings with the keys of
    :class:`harness.sensors.SensorSpec`; noise drawn from ``seed``).
    """

    def __init__(
        self,
        robot: str | Path | LoadedRobot | None = None,
        *,
        options: CoreOptions | None = None,
        transport: TransportOptions | None = None,
        record: RecordOptions | str | Path | None = None,
        load: LoadOptions | None = None,
        loggers: Iterable[Logger | LoggerFactory] = (),
        sinks: Iterable[Sink] = (),
        _resumed: tuple[SessionCore, Recorder | None] | None = None,
        **keywords: Unpack[SessionKeywords],
    ) -> None:
        # ``_resumed``: a core already started and brought to a step, with its recorder
        # (:mod:`harness.resume`; use ``Session.resume(path, step=...)``)
        if _resumed is not None:
            options = _resumed[0].options
        options, transport, record, load = option_groups(keywords, options, transport, record, load)
        self.options: CoreOptions = options
        """The core's options (the ``controllers`` default resolved once the robot is loaded)."""
        self.transport: TransportOptions = transport
        self.ros_domain_id: int | None = ros2_domain(transport)
        """The ROS_DOMAIN_ID of the ROS 2 side (``ros2=True``), else None."""
        self._ros2: Any = None
        clock = options.clock
        start = options.start
        self.clock: ClockMode = clock
        self.start: StartMode = start
        self._resumed = _resumed is not None
        ghost_bridge = None if _resumed is None else _resumed[0].bridge
        self._ghosts: frozenset[int] = frozenset(
            () if ghost_bridge is None else ghost_bridge.connections
        )
        self._ghosts_opened = 0 if ghost_bridge is None else ghost_bridge.opened
        self._clients = threading.Condition()
        self._clients_seen = 0
        self._clients_open = 0
        self._watchers: list[Callable[[], None]] = []  # run_until checks (free-running clock)
        self._watched_step = -1
        self.rate = options.rate
        self.namespace = options.namespace
        self._close_lock = threading.Lock()
        self._runner = LoopThread()
        # bound once: a call into the loop is one call, as when these were methods
        self._await = self._runner.run
        self._call = self._runner.call
        self._port: Port | None = None
        self._recorder: Recorder | None = None
        self._driver: asyncio.Task[None] | None = None
        self._heap_held = False
        self._waiting = False  # a realtime clock waits for its next step's time
        self.sink_reports: list[SinkReport] = []
        """One report per event sink, filled by :meth:`close`."""

        loaded, options = (
            resolve_run(robot, load, options)
            if _resumed is None
            else (_resumed[0].robot, _resumed[0].options)
        )
        self.options = options
        self._loaded: LoadedRobot | LoadedWorld = loaded
        self.world: LoadedWorld | None = loaded if isinstance(loaded, LoadedWorld) else None
        """The loaded world of a session of ``robots`` (None for ``robot=``)."""
        self.robot_name = loaded.name
        self._anchor: Anchor | None = None
        record_to = record.record_to
        self.record_path = Path(record_to) if record_to is not None else None
        try:
            if _resumed is None:
                self._recorder, hub = start_recorder(
                    self.record_path, loaded, options, transport, record, load, self.ros_domain_id
                )
                core, self._port, upstream = build_core(
                    loaded, options, self._recorder, hub, transport, sinks
                )
            else:
                core, self._recorder = _resumed
                hub = core.hub
                self.record_path = None if self._recorder is None else self._recorder.path
                _, self._port, upstream = build_core(
                    loaded, options, self._recorder, hub, transport, sinks, core=core
                )
            self.core: SessionCore = core
            """The sans-I/O core (touch it only from the session's thread)."""
            self.upstream: UpstreamStats | None = upstream
            """Client mode: what the link to the external server counted (else None)."""
            self.sim: Simulation = self.core.sim
            """The simulation. Touch it only from the session's thread (loggers, predicates) or
            while nothing else can step it; prefer the session's methods."""
            self.topics: SessionTopics = self.core.topics
            for item in loggers:
                hub.add_logger(item if isinstance(item, Logger) else item(self))
            self._runner.after_call = self._port.flush
            self._runner.selector.should_poll = self._idle  # lockstep clients: busy-poll
            self._runner.start()
            self.url: str = self._await(self._start())
            """``ws://host:port`` of the embedded server (or the external server's URL)."""
            if clock == "realtime":  # no full collection stalls the pace (heap.py)
                heap.hold()
                self._heap_held = True
            if self.ros_domain_id is not None:
                assert self.core.bridge is not None
                self._ros2 = start_ros2(self.url, self.core.bridge, self.ros_domain_id, self._call)
        except BaseException:
            with contextlib.suppress(Exception):
                self.close()
            raise

    # ----------------------------------------------------------------------------- set-up

    async def _start(self) -> str:
        port = self._port
        assert port is not None
        url = await port.start()
        if not self._resumed:  # a resumed core was started by the run it continues
            self.core.start()
        await port.settle()
        if not self._resumed:
            self.core.publish_initial()
        port.flush()
        self._driver = asyncio.get_running_loop().create_task(self._drive())
        if isinstance(port, ServerPort):
            port.server.on_input = self._on_input
        return url

    @property
    def ros2_refused(self) -> tuple[str, ...]:
        """What the ROS 2 side could not put on DDS (``name (type): reason``; also warning
        events), empty without ``ros2``."""
        return self._ros2.refused if self._ros2 is not None else ()

    def _settle(self) -> None:
        """Take what the core reports after a call into it (drained, as a sans-I/O protocol's
        output is): a reset or pause (re-anchor the pacing, wake the clock), clients opened
        and closed, steps taken (the ``run_until`` watchers look), and the frames it
        produced (recorded and sent)."""
        core = self.core
        core.record_frames()
        if core.clock_changed():
            self._anchor = None
            if self._port is not None:
                self._port.wake.set()
        bridge = core.bridge
        if bridge is not None:
            seen, now_open = bridge.opened - self._ghosts_opened, bridge.open_count
            if self._ghosts:  # a resumed run's recorded clients (ghost peers) are not clients
                now_open -= len(self._ghosts.intersection(bridge.connections))
            if seen != self._clients_seen or now_open != self._clients_open:
                with self._clients:
                    self._clients_seen, self._clients_open = seen, now_open
                    self._clients.notify_all()
        if self._watchers and self.sim.step_index != self._watched_step:
            self._watched_step = self.sim.step_index
            for watcher in tuple(self._watchers):
                watcher()
        if self._port is not None:
            self._port.flush()  # what the core produced for the clients

    def _settled(self, fn: Callable[[], T]) -> T:
        """``fn()`` (a call into the core), then :meth:`_settle`."""
        try:
            return fn()
        finally:
            self._settle()

    # ----------------------------------------------------------------------------- stepping

    async def _drive(self) -> None:
        """The one place time moves by itself (fast, realtime) and where frames are applied
        while nobody steps."""
        assert self._port is not None
        wake = self._port.wake
        core = self.core
        while True:
            try:
                if self._idle():
                    await wake.wait()
                    self._boundary()
                    continue
                self._boundary(self._frames_until() if self.clock == "realtime" else None)
                if core.pause_if_due():
                    self._settle()
                if core.paused or core.failure is not None:
                    continue
                core.advance()
                self._settle()
                if self.clock == "realtime":
                    await self._pace()
                else:
                    await asyncio.sleep(0)
            except asyncio.CancelledError:
                raise
            except Exception as exc:
                self._failed(exc)

    def _idle(self) -> bool:
        """Whether time stands still (lockstep, paused, failed): input is applied as it
        comes."""
        core = self.core
        return self.clock == "lockstep" or core.paused or core.failure is not None

    def _failed(self, exc: Exception) -> None:
        self.core.fail(exc)
        with contextlib.suppress(Exception):  # a recorder error is the failure already
            self._settle()
        for watcher in tuple(self._watchers):
            watcher()  # a run_until waiting for a step that will not come

    def _on_input(self) -> bool:
        """Input was read while time stands still: apply it now, in the read's callback,
        as :meth:`_drive` would once woken (one loop iteration less per request); so too
        while a realtime clock waits for its next step, until a quarter step before it is
        due (the boundary it waits at is where the input takes effect either way; a relayed
        message is not held for up to a step). False otherwise: the next step boundary
        applies the input."""
        until = None
        if self._waiting:
            until = waiting_until(self._anchor, self.sim.step_index, self.dt_ns, self.rate)
            if until is None or time.monotonic() >= until:
                return False
        elif not self._idle():
            return False
        try:
            self._boundary(until)
        except Exception as exc:
            self._failed(exc)
        return True

    async def _pace(self) -> None:
        delay, self._anchor = pace(
            self._anchor, time.monotonic(), self.sim.step_index, self.dt_ns, self.rate
        )
        self._waiting = True
        try:
            await asyncio.sleep(delay)
        finally:
            self._waiting = False

    def _frames_until(self) -> float:
        """Realtime: how long this boundary may apply frames (a :func:`time.monotonic` time;
        :func:`harness.session.live.pacing.frames_until`)."""
        return frames_until(
            self._anchor, time.monotonic(), self.sim.step_index, self.dt_ns, self.rate
        )

    def _boundary(self, until: float | None = None) -> None:
        assert self._port is not None
        self._settle()
        self.core.start_on_client()  # before the client's first frame
        self._port.process_pending(self.sim.sim_time_ns, until)
        self._settle()

    # ----------------------------------------------------------------------------- public API

    def step(self, n: int = 1) -> int:
        """Take ``n`` steps (lockstep, or a paused free-running clock), applying waiting frames
        at every step boundary; returns the step index reached."""
        if not isinstance(n, int) or n < 0:
            raise SessionError(f"step count must be an integer >= 0, not {n!r}")
        advance = partial(self._settled, self.core.advance)
        return self._await(run_steps(self.core, self.clock, n, self._boundary, advance))

    def run_until(self, predicate: Callable[[], bool], *, sim_timeout: float) -> int:
        """Wait until ``predicate()`` holds, checked after every step on the session's thread
        (lockstep: stepping as needed). Returns the step at which it held; raises
        :class:`SimTimeoutError` naming the sim time when ``sim_timeout`` seconds of simulation
        time pass first."""
        if not (math.isfinite(sim_timeout) and sim_timeout >= 0):
            raise SessionError(f"sim_timeout must be >= 0 s, not {sim_timeout!r}")
        budget = math.ceil(round(sim_timeout * 1e9) / self.dt_ns)
        if self.clock == "lockstep":
            advance = partial(self._settled, self.core.advance)
            return self._await(
                run_until_lockstep(
                    self.core, predicate, budget, sim_timeout, self._boundary, advance
                )
            )
        return self._await(
            run_until_free(self.core, self._watchers, predicate, budget, sim_timeout)
        )

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
            lambda: self.core.command(joint, position=position, velocity=velocity, effort=effort)
        )

    def set_positions(self, positions: Mapping[str, float]) -> list[Notice]:
        """Position commands for several joints from Python."""
        values = dict(positions)
        return self._call(lambda: self.core.set_positions(values))

    def reset(self) -> None:
        """Back to the initial state (step numbering continues), as ``/harness/reset``."""
        self._call(lambda: self._settled(self.core.reset))

    def pause(self) -> None:
        """Stop a fast or realtime clock (frames are still applied), as ``/harness/pause``."""
        self._call(lambda: self._settled(lambda: self.core.set_paused(True)))

    def _restart_clock(self) -> None:
        """Restart a paused fast or realtime clock (``session.resume()``)."""
        self._call(lambda: self._settled(lambda: self.core.set_paused(False)))

    resume = _Resume()
    """``session.resume()``: restart a paused fast or realtime clock. ``Session.resume(path,
    step=K)`` (on the class): a live session continuing the recording at ``path`` from step
    ``K`` (:func:`_resume_from`: its keywords)."""

    def pause_at(self, step: int | None) -> None:
        """Pause a fast or realtime clock when it reaches ``step`` (exactly: at that step
        boundary, recorded as a ``pause`` marker; None cancels). A run that must end at a
        simulation-time limit sets it before the clock starts (``start="paused"`` or
        ``"on_client"``)."""
        if step is not None and (not isinstance(step, int) or step < 0):
            raise SessionError(f"pause_at step must be an integer >= 0 or None, not {step!r}")

        def set_limit() -> None:
            self.core.pause_at = step
            if self._port is not None:
                self._port.wake.set()

        self._call(set_limit)

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self._runner.closed

    @property
    def paused(self) -> bool:
        """Whether a free-running clock is paused."""
        return self.core.paused

    @property
    def failure(self) -> BaseException | None:
        """Why the simulation stopped (an unstable step, a recording error), else None."""
        return self.core.failure

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
        return self.core.dt_ns

    @property
    def model(self) -> mujoco.MjModel:
        """The compiled MuJoCo model (read only: runtime model edits break determinism)."""
        return self.sim.model

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The controllable joints (MuJoCo names), in the order of the per-joint arrays (and of
        a one-robot session's forward commands)."""
        return self.sim.joint_names

    @property
    def link_names(self) -> tuple[str, ...]:
        """The robots' links that are MuJoCo bodies, by MuJoCo name (``<ns>/<link>`` in a
        world)."""
        return self.core.links

    @property
    def robot(self) -> LoadedRobot:
        """The loaded robot of a one-robot session (``robot=``); a session of ``robots`` has
        :attr:`world` instead."""
        if isinstance(self._loaded, LoadedRobot):
            return self._loaded
        raise SessionError(
            "this session runs a world (robots= or a scenario file): use session.world "
            "(session.world.robots[0] for its first robot; session.description for one "
            "description of every robot)"
        )

    @property
    def description(self) -> RobotModel:
        """The run's robot description: the robot's, or for a world every robot's with MuJoCo
        (prefixed) names and world-frame poses."""
        loaded = self._loaded
        if isinstance(loaded, LoadedRobot):
            return loaded.description
        return loaded.combined_description()

    @property
    def namespaces(self) -> tuple[str, ...]:
        """Every robot's namespace, in the world's order (``("",)`` or the one robot's
        ``namespace`` for a one-robot session)."""
        return tuple(r.namespace for r in self.core.robots)

    @property
    def robot_topics(self) -> Mapping[str, SessionTopics]:
        """Namespace -> that robot's resolved topics."""
        return {r.namespace: r.topics for r in self.core.robots}

    def joint_names_of(self, namespace: str) -> tuple[str, ...]:
        """The controllable joints of the robot with ``namespace``, unprefixed, in the order of
        its forward commands and of the reads with ``namespace=``."""
        return self.core.robot_channels(namespace).joints.joint_names

    def _read(self, what: str, namespace: str | None) -> F64:
        if namespace is None:
            return self._call(getattr(self.sim, what))
        joints = self.core.robot_channels(namespace).joints
        return self._call(getattr(joints, what))

    def joint_positions(self, namespace: str | None = None) -> F64:
        """Positions of :attr:`joint_names` (or of :meth:`joint_names_of` ``namespace``)."""
        return self._read("joint_positions", namespace)

    def joint_velocities(self, namespace: str | None = None) -> F64:
        """Velocities of :attr:`joint_names` (or of :meth:`joint_names_of` ``namespace``)."""
        return self._read("joint_velocities", namespace)

    def joint_efforts(self, namespace: str | None = None) -> F64:
        """Efforts of :attr:`joint_names` (or of one robot's; see
        :meth:`harness.sim.Simulation.joint_efforts`)."""
        return self._read("joint_efforts", namespace)

    def joint_commands(self, namespace: str | None = None) -> F64:
        """The current command of each joint of :attr:`joint_names` (or of one robot's)."""
        return self._read("joint_commands", namespace)

    def get_state(self) -> F64:
        """The full ``mjSTATE_INTEGRATION`` state."""
        return self._call(self.sim.get_state)

    def add_logger(self, logger: Logger | LoggerFactory) -> None:
        """Register a logger (observed from the next step on)."""
        built = logger if isinstance(logger, Logger) else logger(self)
        self._call(lambda: self.core.hub.add_logger(built))

    def add_sink(self, sink: Sink) -> None:
        """Register an event sink."""
        self._call(lambda: self.core.hub.add_sink(sink))

    def call(self, fn: Callable[[], T]) -> T:
        """Run ``fn()`` on the session's thread between steps and return its result (for
        consistent reads of :attr:`sim` while clients may be stepping)."""
        return self._call(fn)

    # ----------------------------------------------------------------------------- clients

    @property
    def client_count(self) -> int:
        """Clients connected now (sockets accepted whose closing the session has not yet
        processed; in client mode the link to the external server is the one client; a
        resumed run's ghost peers are not counted)."""
        return self._clients_open

    @property
    def clients_seen(self) -> int:
        """Clients that connected since the session started (never decreases)."""
        return self._clients_seen

    def wait_for_client(self, timeout: float = 10.0, *, count: int = 1) -> int:
        """Wait until ``count`` clients have connected since the session started (a
        wall-clock ``timeout`` in seconds: readiness, not simulation); returns
        :attr:`clients_seen`. Raises :class:`ClientTimeoutError` naming the URL."""
        if self._port is not None and not isinstance(self._port, ServerPort):
            raise SessionError("wait_for_client: a session in client mode has no clients")
        with self._clients:
            if not self._clients.wait_for(lambda: self._clients_seen >= count, timeout):
                raise ClientTimeoutError(
                    f"{self._clients_seen} of {count} client(s) connected to "
                    f"{getattr(self, 'url', '?')} within {timeout:g} s"
                )
            return self._clients_seen

    # ----------------------------------------------------------------------------- snapshot

    def snapshot(self, path: str | Path) -> int:
        """Write the recording so far to ``path`` as a complete MCAP file, without stopping
        the session; returns the step it ends at. Taken at a step boundary: frames waiting
        there are applied first (as the next step would), so the copy ends with every frame
        the session had received (recorded at ``step + 1``), like a recording closed at that
        step minus its close and disconnect markers and its loggers' finish events."""
        recorder = self._recorder
        if recorder is None:
            raise SessionError("snapshot: this session records nothing (record_to=None)")

        step, size = self._call(lambda: flush_at_boundary(recorder, self._boundary, self.sim))
        write_snapshot(recorder, size, path)
        return step

    # ----------------------------------------------------------------------------- teardown

    def close(self) -> None:
        """Stop stepping, finish loggers and sinks, close every connection and the server,
        join the thread, close the recording (idempotent)."""
        with self._close_lock:
            if self._runner.closed:
                return
            self._runner.closed = True
        if self._ros2 is not None:
            self._ros2.stop()  # its connection closes like any client's
        errors = self._runner.stop(self._shutdown)
        if self._heap_held:
            self._heap_held = False
            heap.release()
        if self._recorder is not None:
            try:
                self._recorder.close()
            except Exception as exc:
                errors.append(exc)
        if errors:
            raise errors[0]

    async def _shutdown(self) -> None:
        if isinstance(self._port, ServerPort):
            self._port.server.on_input = None  # closing applies input as it always did
        await stop_driver(self._driver)
        try:
            try:
                if self._port is not None:
                    await close_port(self.core, self._port, self._boundary)
            finally:
                self.sink_reports = self.core.finish()
        finally:
            await cancel_other_tasks()

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
        state = "closed" if self._runner.closed else getattr(self, "url", "starting")
        return f"Session({self.robot_name!r}, clock={self.clock!r}, {state})"
