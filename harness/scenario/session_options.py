"""The one translation of a scenario into a :class:`harness.session.Session`'s options.

``harness run`` (:mod:`harness.scenario.session_runner`), the pytest marker
``@pytest.mark.harness(scenario=...)`` and ``harness demo`` (through ``harness run``'s
:func:`harness.scenario.run_scenarios`) all start their sessions from
:func:`scenario_session`, so one file simulates one world whichever way it is run:

- the world (:func:`harness.scenario.world.plan_world`): every ``robots[]`` entry with its
  pose, control modes, initial joint positions, xacro arguments, load options and namespace;
  ``environment.map`` with the ``objects`` and the ``timestep`` (a generated ``scene.xml``
  when something is added to the map);
- the session's options: ``clock`` (mode and rate; a free-running clock starts paused:
  :meth:`harness.session.Session.resume` or a client starts it), the kinematic limit
  policy, each robot's command topic (``subscribers``), ``recording`` (``state_every``,
  ``bridge_frames``), ``seed``, ``controllers``, ``sensors``, ``ros.bridge`` (``ip`` and
  ``port`` where the session listens, ``connect``, ``ros2``) and the scenario file itself
  (recorded as an attachment);
- the events: the ``logging`` section's sinks and each robot's ``loggers``
  (:meth:`ScenarioSession.loggers`, built once the world is loaded).

``harness run`` and the marker give every iteration/test a free port instead of
``ros.bridge.port`` (iterations and xdist workers run side by side); a ``Session`` started
from :meth:`ScenarioSession.keywords` as is listens on the file's port.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import mujoco

from harness.events import (
    CollisionLogger,
    JointLimitLogger,
    JointLogger,
    Logger,
    LoggerConfigError,
    Sink,
    velocity_limits,
)
from harness.models import LoadedWorld
from harness.models.build.decompose import check_mesh_collision
from harness.scenario._validation import format_path
from harness.scenario.errors import ScenarioError
from harness.scenario.scenario import Clock, CollisionLoggerSpec, JointLoggerSpec, Scenario
from harness.scenario.world import kinematic_limits, plan_world
from harness.session import (
    CoreOptions,
    LoadOptions,
    RecordOptions,
    SessionConfigError,
    TransportOptions,
    controllers_option,
)

__all__ = [
    "DEFAULT_DEBOUNCE_STEPS",
    "RUN_CLOCK",
    "ScenarioSession",
    "scenario_loggers",
    "scenario_session",
]

DEFAULT_DEBOUNCE_STEPS = 5
"""The debounce of the collision logger a scenario gets when it lists none."""


@dataclass(frozen=True)
class ScenarioSession:
    """What a Session gets from a scenario (see the module docstring): the options objects
    ``Session(options=..., transport=..., record=..., load=...)`` takes (:meth:`keywords`:
    the same as keyword arguments, for callers that override some); :meth:`loggers` the
    scenario's loggers once the session's world is loaded; :meth:`sinks` its ``logging``
    sinks. ``command_topics``: each robot namespace's joint command topic."""

    scenario: Scenario
    options: CoreOptions
    transport: TransportOptions
    record: RecordOptions
    load: LoadOptions
    command_topics: Mapping[str, str] = field(default_factory=dict)

    def keywords(self) -> dict[str, Any]:
        """``Session(**keywords)`` runs the scenario's world with its options (every field of
        the four options objects, by its keyword name)."""
        out: dict[str, Any] = {}
        for obj in (self.options, self.transport, self.record, self.load):
            out.update({f.name: getattr(obj, f.name) for f in fields(obj)})
        return out

    def loggers(self, world: LoadedWorld) -> list[Logger]:
        """The scenario's loggers over ``world`` (:func:`scenario_loggers`)."""
        return scenario_loggers(self.scenario, world)

    def sinks(self) -> list[Sink]:
        """The ``logging`` section's destination sinks (none when logging is off)."""
        where = _where(self.scenario)
        try:
            return self.scenario.logging.create_sinks()
        except LoggerConfigError as exc:
            raise ScenarioError([f"{where}: logging: {exc}"]) from None


def _where(scenario: Scenario) -> str:
    return str(scenario.source) if scenario.source is not None else "<scenario>"


RUN_CLOCK = Clock()
"""``harness run``'s clock for a scenario without a ``clock`` section: ``realtime`` x 1."""


def scenario_session(
    scenario: Scenario, folder: Path, *, default_clock: Clock = RUN_CLOCK
) -> ScenarioSession:
    """The session of ``scenario``: its world planned (a generated scene goes to ``folder``)
    and its options; ``default_clock``: the clock when the file has no ``clock`` section.
    Errors name the scenario file and the key path."""
    plan = plan_world(scenario, folder)
    clock = scenario.clock or default_clock
    try:
        options = CoreOptions(
            clock=clock.mode,
            rate=clock.rate,
            start="now" if clock.mode == "lockstep" else "paused",
            kinematic_limits=kinematic_limits(scenario.robots[0]),
            joint_command_topic=dict(plan.command_topics),
            state_every=scenario.recording.state_every,
            record_bridge_frames=scenario.recording.bridge_frames,
            seed=scenario.seed,
            controllers=controllers_option(scenario.controllers),
            sensors=tuple(scenario.sensors),
        )
        transport = scenario.bridge.transport()
    except SessionConfigError as exc:
        raise ScenarioError([f"{_where(scenario)}: {exc}"]) from None
    record = RecordOptions(
        scenario=scenario.source.read_bytes() if scenario.source is not None else None
    )
    load = LoadOptions(
        robots=plan.robots,
        scene=plan.scene,
        mesh_collision=check_mesh_collision(
            scenario.environment.mesh_collision, "environment.mesh_collision"
        ),
    )
    return ScenarioSession(scenario, options, transport, record, load, plan.command_topics)


def scenario_loggers(scenario: Scenario, world: LoadedWorld) -> list[Logger]:
    """The scenario's loggers over ``world``: each robot's ``CollisionLogger``/``JointLogger``
    entries (bodies and joints by MuJoCo name), a default collision logger over every robot
    when none is listed and the criteria judge collisions, a joint logger at
    ``logging.frequency`` when ``logging.enable``, and a ``JointLimitLogger`` over every
    robot's joints with the criteria's tolerance. Errors name the key path."""
    model = world.model
    where = _where(scenario)
    loggers: list[Logger] = []
    every_link: list[str] = []
    has_collision = has_joint = False
    several = len(world.robots) > 1
    for index, (robot, view) in enumerate(zip(scenario.robots, world.robots, strict=True)):
        links = [
            view.mujoco_name(link.name)
            for link in view.description.links
            if is_body(model, view.mujoco_name(link.name))
        ]
        every_link += links
        for i, spec in enumerate(robot.loggers):
            path = format_path(["robots", index, "loggers", i])
            name = f"robots[{index}].loggers[{i}]" if several else None
            try:
                if isinstance(spec, CollisionLoggerSpec):
                    has_collision = True
                    loggers.append(
                        CollisionLogger(
                            model,
                            robot_bodies=links,
                            self_contacts=spec.self_contacts,
                            robot_vs_world_only=spec.robot_vs_world_only,
                            ignore=[
                                (_body(view, model, a), _body(view, model, b))
                                for a, b in spec.ignore_pairs
                            ],
                            min_force=spec.min_force,
                            debounce_steps=max(1, spec.debounce_steps),
                            near_miss_distance=spec.near_miss_distance,
                            name=name or f"collisions[{i}]",
                        )
                    )
                elif isinstance(spec, JointLoggerSpec):
                    has_joint = True
                    joints = [view.mujoco_name(j) for j in spec.joints]
                    if not joints and several:
                        joints = [view.mujoco_name(j) for j in view.control]
                    loggers.append(
                        JointLogger(
                            model,
                            joints=joints or None,
                            rate_hz=spec.rate,
                            name=name or f"joints[{i}]",
                        )
                    )
            except LoggerConfigError as exc:
                raise ScenarioError([f"{where}: {path}: {exc}"]) from None
    if not has_collision and scenario.criteria.no_collisions:
        loggers.append(
            CollisionLogger(model, robot_bodies=every_link, debounce_steps=DEFAULT_DEBOUNCE_STEPS)
        )
    logging = scenario.logging
    if logging.enable and not has_joint:
        loggers.append(JointLogger(model, rate_hz=logging.frequency_hz))
    description = world.combined_description()
    joints = [j.name for j in description.controllable_joints]
    speed = velocity_limits(description)
    loggers.append(
        JointLimitLogger(
            model,
            joints=joints,
            velocity_limits={j: v for j, v in speed.items() if j in joints},
            tolerance=scenario.criteria.joint_limit_tolerance,  # None: the solver's
        )
    )
    return loggers


def _body(view: Any, model: mujoco.MjModel, name: str) -> str:
    """A body a robot's logger names: the robot's own link (prefixed), else a world body."""
    own = view.mujoco_name(name)
    return own if is_body(model, own) else name


def is_body(model: mujoco.MjModel, name: str) -> bool:
    """Whether ``model`` has a body named ``name`` (the world body excluded)."""
    return bool(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) > 0)
