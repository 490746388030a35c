"""The product's iteration runner: one :class:`harness.session.Session` per iteration.

For one :class:`~harness.scenario.results.IterationSpec` it plans the world
(:func:`harness.scenario.world.plan_world`: every robot with its pose, control modes, initial
positions and namespace), starts a Session of those robots on a free port of the scenario's
bridge address, recording to the iteration's ``recording.mcap``, with

- loggers: each robot's ``CollisionLogger``/``JointLogger`` entries mapped onto
  :mod:`harness.events` (its bodies and joints by MuJoCo name, ``<namespace>/<link>`` when
  the run has several robots; a default collision logger over every robot when the scenario
  lists none and the criteria judge collisions), a ``JointLimitLogger`` over every robot's
  joints (position and URDF velocity limits, with the criteria's tolerance), a joint logger
  at ``logging.frequency`` when ``logging.enable``;
- sinks: the ``logging`` section's destinations (``scenario.logging``, a
  :class:`harness.events.LoggingConfig`);
- an observer that hashes every step's ``mjSTATE_INTEGRATION`` state (initial state first),
  tracks joint ranges against limits and samples joint traces for the report.

The Session runs in the scenario's own clock mode (the recording's metadata says which) and
records bridge frames unless ``recording.bridge_frames`` is false. Then, by clock and client:

- with a client command: the client starts once the bridge listens, with
  ``HARNESS_ROSBRIDGE_URL`` (:func:`harness.scenario.client.run_client`). ``lockstep``: the client
  moves time with ``/harness/step``; ``fast`` and ``realtime`` (x ``clock.rate``): the Session's
  clock starts when the client connects (``start="on_client"``). The iteration ends when the
  client exits, or at the sim-time limit (the client is then stopped), or at the readiness or
  wall-time limit; the client's whole process group is stopped with escalation.
- without a client command: the world runs the sim-time limit with the robot holding its
  initial command (``lockstep``: the runner steps; ``fast``/``realtime``: the Session's clock
  runs): a settling and stability check of the world.

A free-running clock pauses exactly at the limit (:meth:`harness.session.Session.pause_at`);
frames are applied at every step boundary in every mode.

A client command whose program is ``python`` or ``python3`` runs with the interpreter running
the harness (so clients shipped in ``scenarios/clients`` find roslibpy and harness).
"""

from __future__ import annotations

import hashlib
import math
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from urllib.parse import urlsplit

import mujoco
import numpy as np
import numpy.typing as npt

from harness.errors import ConfigError
from harness.events import (
    CollectingSink,
    CollisionBegin,
    CollisionEnd,
    Event,
    Level,
    Logger,
    Sink,
    SinkReport,
    StepContext,
    index_of,
    solver_limit_tolerance,
    velocity_limits,
)
from harness.models import LoadedWorld
from harness.scenario.client import run_client
from harness.scenario.errors import ScenarioError
from harness.scenario.results import (
    ClientOutcome,
    CollisionSummary,
    IterationResult,
    IterationSpec,
    JointLimitSummary,
    JointTrace,
    Traces,
    Verdict,
    criteria_settings,
    judge,
)
from harness.scenario.scenario import ClientSpec, ResumeSpec, Scenario
from harness.scenario.script import run_script
from harness.scenario.session_options import ScenarioSession, is_body, scenario_session
from harness.scenario.travel import BaseTracker, travel_verdict
from harness.scenario.world import effective_timestep
from harness.session import Session, SessionError

__all__ = ["SessionHost", "SessionIterationRunner", "check_script", "robot_links", "steps_for"]

F64 = npt.NDArray[np.float64]
_PYTHON = ("python", "python3")
_DEFAULT_DEBOUNCE_STEPS = 5


def steps_for(sim_time: float, dt_ns: int) -> int:
    """Steps needed to reach ``sim_time`` seconds (at least; whole steps)."""
    return max(0, math.ceil(round(sim_time * 1e9) / dt_ns))


class SessionHost:
    """A :class:`~harness.scenario.client.BridgeHost` over a running Session."""

    def __init__(self, session: Session) -> None:
        self._session = session

    @property
    def url(self) -> str:
        """The session's bridge URL."""
        return self._session.url

    def client_connected(self) -> bool:
        """True once any client connected to the session's bridge."""
        return self._session.clients_seen > 0

    def sim_time(self) -> float:
        """Simulation seconds reached (infinite once the simulation failed: nothing more can
        happen, so the client is stopped at once)."""
        if self._session.failure is not None:
            return math.inf
        return self._session.sim_time_ns / 1e9


class _Observer:
    """Every step, on the session's thread: the state digest, joint ranges against limits, and
    trace samples every ``every`` steps. A logger that emits nothing."""

    name = "scenario-observer"
    period_ns = 0

    def __init__(self, session: Session, every: int, tolerance: float | None) -> None:
        sim = session.sim
        model = sim.model
        self._sim = sim
        self.every = every
        self.joints = sim.joint_names
        ids = [model.joint(j).id for j in self.joints]
        self._qadr = np.array([model.jnt_qposadr[i] for i in ids], dtype=np.intp)
        self._qat = index_of(self._qadr)
        self._dadr = np.array([model.jnt_dofadr[i] for i in ids], dtype=np.intp)
        self._dat = index_of(self._dadr)
        limited = np.array([bool(model.jnt_limited[i]) for i in ids], dtype=bool)
        ranges = np.asarray(model.jnt_range)[ids].reshape(-1, 2)
        self.lower = np.where(limited, ranges[:, 0], -np.inf)
        self.upper = np.where(limited, ranges[:, 1], np.inf)
        self.tolerance = np.array(
            [solver_limit_tolerance(model, i) if tolerance is None else tolerance for i in ids],
            dtype=np.float64,
        )
        modes = sim.control
        self._commanded = np.array(
            [modes[j] in ("position", "kinematic") for j in self.joints], dtype=bool
        )
        self._state = np.zeros(sim.state_size)
        self._spec = sim.state_spec
        self.digest = hashlib.sha256()
        mujoco.mj_getState(model, sim.data, self._state, self._spec)
        self.digest.update(self._state.tobytes())
        n = len(self.joints)
        self.qmin = np.full(n, np.inf)
        self.qmax = np.full(n, -np.inf)
        self.violations = np.zeros(n, dtype=np.int64)
        self.time: list[float] = []
        self.pos: list[F64] = []
        self.vel: list[F64] = []
        self.cmd: list[F64] = []
        self.step = sim.step_index
        self.first = sim.step_index + 1
        self.bases = BaseTracker(session.world, model, sim.data)
        self._sample(sim.step_index, sim.sim_time_ns)

    @property
    def excess(self) -> F64:
        """Per joint, the largest excess beyond a limit so far (0 when none): what the
        maximum of every step's ``max(lower - q, q - upper)`` is, from the range seen (a
        rounded difference is monotonic in ``q``: the same bits, without a pass per step)."""
        beyond = np.maximum(self.lower - self.qmin, self.qmax - self.upper)
        excess: F64 = np.maximum(np.zeros(len(self.joints)), beyond)
        return excess

    def _sample(self, step: int, sim_time_ns: int) -> None:
        data = self._sim.data
        self.time.append(sim_time_ns / 1e9)
        self.pos.append(data.qpos[self._qat].copy())  # a view's copy: one pass
        self.vel.append(data.qvel[self._dat].copy())
        self.cmd.append(np.where(self._commanded, self._sim.joint_commands(), np.nan))

    def observe(self, ctx: StepContext) -> list[Event]:
        mujoco.mj_getState(ctx.model, ctx.data, self._state, self._spec)
        self.digest.update(self._state.data)  # its bytes, without a copy
        q = ctx.data.qpos[self._qat]
        np.minimum(self.qmin, q, out=self.qmin)
        np.maximum(self.qmax, q, out=self.qmax)
        beyond = np.maximum(self.lower - q, q - self.upper)
        over = beyond > self.tolerance
        if np.count_nonzero(over):
            self.violations += over
        self.step = ctx.step
        if ctx.step % self.every == 0:
            self._sample(ctx.step, ctx.sim_time_ns)
        return []

    def finish(self, ctx: StepContext) -> list[Event]:
        return []

    def state_columns(self) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
        """Where the observed joints' positions and velocities are in a row of the states
        :meth:`absorb` takes (``mj_getState`` with the simulation's state spec)."""
        model, spec = self._sim.model, self._spec
        qpos = mujoco.mj_stateSize(model, spec & (mujoco.mjtState.mjSTATE_QPOS - 1))
        qvel = mujoco.mj_stateSize(model, spec & (mujoco.mjtState.mjSTATE_QVEL - 1))
        return (
            np.asarray(self._qadr + qpos, dtype=np.intp),
            np.asarray(self._dadr + qvel, dtype=np.intp),
        )

    def absorb(
        self,
        states: F64,
        step: int,
        samples: Sequence[tuple[int, int, F64]] = (),
    ) -> None:
        """What :meth:`observe` does at each of the steps ending at ``step``, from their
        states (one row per step, in order: what ``mj_getState`` with the simulation's state
        spec gave after each): the digest, the range seen, the steps beyond a limit, and the
        trace ``samples`` (row, simulation time, the joints' commands then: each taken when
        :meth:`observe` would take it, ``step % every == 0``)."""
        self.digest.update(np.ascontiguousarray(states).data)
        pos_at, vel_at = self.state_columns()
        q = states[:, pos_at]
        if len(q):
            np.minimum(self.qmin, q.min(axis=0), out=self.qmin)
            np.maximum(self.qmax, q.max(axis=0), out=self.qmax)
            beyond = np.maximum(self.lower - q, q - self.upper)
            self.violations += np.count_nonzero(beyond > self.tolerance, axis=0)
        if samples:
            rows = np.array([row for row, _, _ in samples], dtype=np.intp)
            self.time += [sim_time_ns / 1e9 for _, sim_time_ns, _ in samples]
            self.pos += list(q[rows])
            self.vel += list(states[np.ix_(rows, vel_at)])
            commands = np.array([c for _, _, c in samples], dtype=np.float64)
            self.cmd += list(np.where(self._commanded, commands, np.nan))
        self.step = step

    def limits(self) -> tuple[JointLimitSummary, ...]:
        excess = self.excess
        return tuple(
            JointLimitSummary(
                joint,
                None if math.isinf(self.lower[i]) else float(self.lower[i]),
                None if math.isinf(self.upper[i]) else float(self.upper[i]),
                float(self.qmin[i]) if self.step else float(self.pos[0][i]),
                float(self.qmax[i]) if self.step else float(self.pos[0][i]),
                float(excess[i]),
                int(self.violations[i]),
                float(self.tolerance[i]),
            )
            for i, joint in enumerate(self.joints)
        )

    def traces(self, velocity: dict[str, float]) -> Traces:
        n = len(self.time)
        pos, vel, cmd = (np.array(r).reshape(n, -1) for r in (self.pos, self.vel, self.cmd))
        return Traces(
            time=tuple(self.time),
            joints=tuple(
                JointTrace(
                    joint,
                    tuple(pos[:, i].tolist()),
                    tuple(vel[:, i].tolist()),
                    tuple(cmd[:, i].tolist()) if self._commanded[i] else None,
                    None if math.isinf(self.lower[i]) else float(self.lower[i]),
                    None if math.isinf(self.upper[i]) else float(self.upper[i]),
                    velocity.get(joint),
                )
                for i, joint in enumerate(self.joints)
            ),
        )


def _client_command(client: ClientSpec) -> ClientSpec:
    if client.command and client.command[0] in _PYTHON:
        return replace(client, command=(sys.executable, *client.command[1:]))
    return client


def _resumed(
    resume: ResumeSpec,
    planned: ScenarioSession,
    spec: IterationSpec,
    loggers: list[Callable[[Session], Logger]],
    sinks: list[Sink],
) -> Session:
    """The iteration's session continuing ``resume``'s recording (the scenario's ``resume``
    section): the recording's world and options, the iteration's port and recording path,
    a free-running clock started (a resumed one waits paused)."""
    session = Session.resume(
        resume.source,
        step=resume.step,
        at_time=resume.at_time,
        edits=resume.edits,
        preroll=resume.preroll,
        transport=replace(planned.transport, host=spec.host, port=spec.port),
        record_to=spec.recording_path if spec.scenario.recording.enabled else None,
        loggers=loggers,
        sinks=sinks,
    )
    if session.world is None:
        session.close()
        raise ConfigError(
            f"resume: {resume.source} is a one-robot session's recording: a scenario resumes "
            "a scenario's recording (a world)"
        )
    if session.clock != "lockstep":
        session.resume()
    return session


def _run_world(session: Session, limit: int, chunk: int) -> None:
    """Without a client: run the world to ``limit`` steps (lockstep: in chunks from here; a
    free-running clock: its own, paused at the limit)."""
    if session.clock == "lockstep":
        k = session.step_index
        while k < limit:
            k = session.step(min(chunk, limit - k))
        return
    session.resume()
    budget = (limit - session.step_index) * session.dt_ns / 1e9
    session.run_until(lambda: session.sim.step_index >= limit, sim_timeout=budget)


@dataclass(frozen=True)
class SessionIterationRunner:
    """Runs one iteration in a Session (see the module docstring). ``grace``: seconds a
    client gets between SIGTERM and SIGKILL; ``trace_samples``: about how many samples the
    report's joint plots get; ``chunk``: steps handed to the session at once when the runner
    drives a lockstep clock without a client."""

    grace: float = 3.0
    trace_samples: int = 500
    chunk: int = 10
    watchers: tuple[Callable[[Session], Logger], ...] = ()
    """Extra logger factories, called once the world is loaded (``harness explore``'s margin
    loggers); they must emit no events, or the recording would differ from ``harness run``'s."""

    def __call__(self, spec: IterationSpec) -> IterationResult:
        started = time.monotonic()
        scenario = spec.scenario
        robot_spec = scenario.robots[0] if scenario.robots else None
        if robot_spec is None:
            raise ConfigError("the scenario lists no robot")
        spec.out_dir.mkdir(parents=True, exist_ok=True)
        spec.recording_path.parent.mkdir(parents=True, exist_ok=True)
        planned = scenario_session(scenario, spec.out_dir)
        expected = steps_for(spec.sim_time_limit, round(effective_timestep(scenario) * 1e9))
        every = max(1, math.ceil(expected / max(1, self.trace_samples)))
        observers: list[_Observer] = []

        def observer(session: Session) -> Logger:
            built = _Observer(session, every, scenario.criteria.joint_limit_tolerance)
            observers.append(built)
            return built

        collect = CollectingSink(min_level=Level.INFO)
        sinks: list[Sink] = [*planned.sinks(), collect]
        options = replace(planned.options, seed=spec.seed)
        if options.clock != "lockstep" and spec.client is not None:
            options = replace(options, start="on_client")
        if scenario.resume is not None:
            session = _resumed(scenario.resume, planned, spec, [observer], sinks)
        else:
            session = Session(
                options=options,
                # a free port per iteration: iterations run side by side
                transport=replace(planned.transport, host=spec.host, port=spec.port),
                record=replace(
                    planned.record,
                    record_to=spec.recording_path if scenario.recording.enabled else None,
                ),
                load=planned.load,
                loggers=[observer],
                sinks=sinks,
            )
            try:
                assert session.world is not None
                for logger in planned.loggers(session.world):
                    session.add_logger(logger)  # before the first step: as if given above
                for watcher in self.watchers:
                    session.add_logger(watcher(session))
            except BaseException:
                session.close()
                raise
        dt_ns = session.dt_ns
        limit = steps_for(spec.sim_time_limit, dt_ns)
        outcome: ClientOutcome | None = None
        stepper_error: BaseException | None = None
        try:
            host = SessionHost(session)
            port = urlsplit(session.url).port or 0  # the URL may end in /?token=...
            if session.clock != "lockstep":
                session.pause_at(limit)  # before the clock starts
            if spec.client is None:
                try:
                    if scenario.script:
                        check_script(scenario, session.joint_names)
                        run_script(session, scenario.script, dt_ns, limit, self.chunk)
                    else:
                        _run_world(session, limit, self.chunk)
                except SessionError as exc:
                    stepper_error = exc
            else:
                outcome = run_client(
                    _client_command(spec.client),
                    host,
                    spec.sim_time_limit,
                    spec.out_dir / "client.log",
                    self.grace,
                )
            failure = session.failure
        finally:
            session.close()
        obs = observers[0]
        collisions = _collisions(
            collect.events, dt_ns, robot_links(session.world), obs.first, session.model
        )
        limits = obs.limits()
        verdicts = run_verdicts(
            scenario, outcome, collisions, limits, obs, session.sim.data, failure or stepper_error
        )
        notes = sink_notes(session.sink_reports)
        return IterationResult(
            simulation=spec.simulation,
            iteration=spec.iteration,
            verdicts=tuple(verdicts),
            sim_time=obs.step * dt_ns / 1e9,
            steps=obs.step,
            recording=session.record_path,
            collisions=collisions,
            joint_limits=limits,
            traces=obs.traces(velocity_limits(session.description)),
            state_digest=obs.digest.hexdigest(),
            client=outcome,
            port=port,
            wall_seconds=time.monotonic() - started,
            notes=notes,
            settings=criteria_settings(scenario.criteria),
        )


def run_verdicts(
    scenario: Scenario,
    client: ClientOutcome | None,
    collisions: tuple[CollisionSummary, ...],
    limits: tuple[JointLimitSummary, ...],
    observer: _Observer,
    data: mujoco.MjData,
    problem: BaseException | None,
) -> list[Verdict]:
    """The verdicts of one run: the criteria's (:func:`judge`), ``returns_to_start``'s
    travel (from ``observer`` and the run's last ``data``) and, when the run stopped on
    ``problem``, the simulation's."""
    verdicts = list(judge(scenario.criteria, client, collisions, limits))
    if scenario.criteria.returns_to_start is not None:
        travels = observer.bases.travels(data)
        verdicts.append(travel_verdict(scenario.criteria.returns_to_start, travels))
    if problem is not None:
        verdicts.append(Verdict("simulation", False, f"the simulation stopped: {problem}"))
    return verdicts


def sink_notes(reports: Iterable[SinkReport]) -> tuple[str, ...]:
    """One line per log sink that dropped events or has a note."""
    return tuple(
        f"log sink {r.name}: {r.delivered} delivered, {r.dropped} dropped"
        + (f" ({r.note})" if r.note else "")
        for r in reports
        if r.dropped or r.note
    )


def check_script(scenario: Scenario, joints: tuple[str, ...]) -> None:
    """Refuse a ``script`` command naming a joint the world does not have."""
    where = str(scenario.source) if scenario.source is not None else "<scenario>"
    problems = [
        f"{where}: script[{i}]: joint {joint!r} is not a joint of the world "
        f"(its joints: {', '.join(joints)})"
        for i, command in enumerate(scenario.script)
        for joint in command.joints()
        if joint not in joints
    ]
    if problems:
        raise ScenarioError(problems)


def robot_links(world: LoadedWorld | None) -> list[str]:
    """The MuJoCo body names of every robot's links (``<namespace>/<link>`` with several)."""
    if world is None:
        return []
    model = world.model
    return [
        view.mujoco_name(link.name)
        for view in world.robots
        for link in view.description.links
        if is_body(model, view.mujoco_name(link.name))
    ]


def resting_depth(model: mujoco.MjModel, geom1: str, geom2: str) -> float:
    """The penetration a contact between two geoms has at rest by the solver's design: the
    larger contact margin plus the larger soft-contact width ``solimp[2]`` (MuJoCo's default
    0.001 m), as for joint limits (:func:`harness.events.solver_limit_tolerance`)."""
    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in (geom1, geom2)]
    ids = [i for i in ids if i >= 0]
    if not ids:
        return 0.0
    return float(max(model.geom_margin[i] for i in ids) + max(model.geom_solimp[i][2] for i in ids))


def _collisions(
    events: list[Event], dt_ns: int, robot: list[str], first_step: int, model: mujoco.MjModel
) -> tuple[CollisionSummary, ...]:
    """Contact episodes, the robot's body first. ``initial``: in contact at ``first_step``
    (the first step observed: its contacts are those of the initial state) no deeper than
    :func:`resting_depth` (a robot placed *inside* a table is not resting on it)."""
    bodies = set(robot)
    resting = {
        (e.body1, e.body2, e.step)
        for e in events
        if isinstance(e, CollisionBegin)
        and e.step <= first_step
        and e.penetration <= resting_depth(model, e.geom1, e.geom2)
    }
    episodes = []
    for e in events:
        if not isinstance(e, CollisionEnd):
            continue
        body1, body2 = e.body1, e.body2
        if body2 in bodies and body1 not in bodies:
            body1, body2 = body2, body1
        episodes.append(
            CollisionSummary(
                body1,
                body2,
                e.begin_step * dt_ns / 1e9,
                None if e.at_finish else e.end_step * dt_ns / 1e9,
                e.penetration,
                e.normal_force,
                world=body1 not in bodies,
                initial=(e.body1, e.body2, e.begin_step) in resting,
                support=e.support,
            )
        )
    episodes.sort(key=lambda c: (c.begin, c.body1, c.body2))
    return tuple(episodes)
