"""Scenario files: a superset of the original framework's scene config, as frozen dataclasses.

A scenario is JSON or YAML. The shipped JSON Schema (``scenario.schema.json``) is the single
description of the keys; :meth:`Scenario.load` validates against it (every problem reported,
each with its key path and value, unknown keys with a "did you mean"), then checks what a
schema cannot (files exist, built-in names, per-logger options) and builds the dataclasses.
Relative paths resolve against the scenario file's folder.

Compatibility with the original scene config: ``environment.map`` may be ``""`` (= ``empty``);
``weather`` and ``time`` are kept as metadata; ``ros.bridge.port`` may be a string; controller
``mode: dynamic`` means ``position`` (the original's dynamic mode drove position motors);
``JointStateSubscriber`` keeps the original default topic ``/joint/states``. Unlike the
original, ``position`` is in metres (not Unreal centimetres) and ``orientation`` (roll, pitch,
yaw in radians) is honoured.
"""

from __future__ import annotations

import difflib
import shlex
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from harness.controllers import ControllersConfig, ControllersConfigError, load_controllers
from harness.errors import ModelError
from harness.events import LoggerConfigError, LoggingConfig, logging_config_from_scene
from harness.models import (
    OBJECT_SIZES,
    BaseKind,
    ControlMode,
    Pose,
    SelfCollision,
    WorldObject,
    resolve_uri,
)
from harness.scenario._validation import format_path, load_document, schema_problems
from harness.scenario.errors import ScenarioError
from harness.scenario.script import ScriptCommand, script_commands
from harness.session import TransportOptions
from harness.vocabulary import (
    LIMIT_POLICY_KEY,
    LIMIT_POLICY_OLD_KEY,
    ClockMode,
    LimitPolicy,
    RobotBase,
    SelfCollisionPolicy,
)

__all__ = [
    "BUILTIN_MAPS",
    "BUILTIN_ROBOTS",
    "ClientSpec",
    "Clock",
    "CollisionLoggerSpec",
    "Controller",
    "Criteria",
    "Environment",
    "JointLoggerSpec",
    "JointModes",
    "LoggerSpec",
    "ResumeSpec",
    "Scenario",
    "ScenarioBridgeSection",
    "ScenarioRecordingSection",
    "ScenarioRobot",
    "Subscriber",
]

BUILTIN_ROBOTS: tuple[str, ...] = ("demo",)
"""Robot names ``robots[].robot`` accepts besides a file path."""
BUILTIN_MAPS: tuple[str, ...] = ("empty", "table")
"""Scene names ``environment.map`` accepts besides a world file."""
ROBOT_SUFFIXES = (".urdf", ".xacro", ".sdf", ".xml", ".mjcf")
WORLD_SUFFIXES = (".xml", ".mjcf", ".sdf", ".world")

Vector3 = tuple[float, float, float]


@dataclass(frozen=True)
class Environment:
    """``map`` is a built-in scene name or the resolved world file; ``mesh_collision`` how
    its (and the robots') non-convex collision meshes collide (``decompose`` or ``hull``, see
    :mod:`harness.models.build.decompose`); the rest is metadata."""

    map: str | Path = "empty"
    weather: str | None = None
    time: str | None = None
    mesh_collision: str = "decompose"


@dataclass(frozen=True)
class Subscriber:
    """A command input of a robot: the original's JointStateSubscriber, or a trajectory topic."""

    type: Literal["JointStateSubscriber", "JointTrajectorySubscriber"]
    topic: str


@dataclass(frozen=True)
class JointModes:
    """One entry of a robot's ``modes:``: the control mode of ``joints`` (empty = every joint
    of the robot); ``kinematic_limits``: kinematic commands beyond a limit are clamped or
    allowed (the file may spell it ``beyond_limits``, its earlier name). The robot key was
    spelled ``controllers:`` (the original framework's ``JointController``), which is also the
    scenario's ros2_control YAML key: that spelling is still read, with a warning."""

    mode: ControlMode
    joints: tuple[str, ...] = ()
    kinematic_limits: LimitPolicy = LimitPolicy.CLAMP


Controller = JointModes
"""Earlier name of :class:`JointModes` (read for one release)."""


@dataclass(frozen=True)
class CollisionLoggerSpec:
    """Options of a CollisionLogger (see harness.events)."""

    debounce_steps: int = 0
    ignore_pairs: tuple[tuple[str, str], ...] = ()
    self_contacts: bool = True
    robot_vs_world_only: bool = False
    min_force: float = 0.0
    near_miss_distance: float | None = None


@dataclass(frozen=True)
class JointLoggerSpec:
    """Options of a JointLogger: ``rate`` samples per simulation second (None: every step)."""

    rate: float | None = None
    joints: tuple[str, ...] = ()


LoggerSpec = CollisionLoggerSpec | JointLoggerSpec

_LOGGER_KEYS: dict[str, tuple[str, ...]] = {
    "CollisionLogger": (
        "debounce_steps",
        "ignore_pairs",
        "self_contacts",
        "self_collision",
        "robot_vs_world_only",
        "min_force",
        "near_miss_distance",
    ),
    "JointLogger": ("rate", "joints"),
}


@dataclass(frozen=True)
class ScenarioRobot:
    """A ``robots[]`` entry as the file gives it (the session's robot is the
    :class:`harness.models.RobotSpec` :func:`harness.scenario.world.plan_world` builds from
    it, namespace and control modes resolved against the robot's description).

    ``robot`` is a built-in name or the resolved model file. ``name``: the scenario's name
    for it (``robot``, ``robot1``, ... when not given); ``named``: whether the file gave the
    name (a given name is the robot's namespace when a run has several
    robots, see :func:`harness.scenario.world.robot_namespaces`). ``robot_args``: the
    arguments of a xacro robot (name -> value as text). ``self_collision``, ``base``,
    ``strict`` and ``srdf`` (the resolved SRDF file): as for
    :func:`harness.models.load_robot` (None: the default)."""

    robot: str | Path
    name: str
    position: Vector3 = (0.0, 0.0, 0.0)
    orientation: Vector3 = (0.0, 0.0, 0.0)
    initial_joint_positions: Mapping[str, float] = field(default_factory=dict)
    subscribers: tuple[Subscriber, ...] = ()
    modes: tuple[JointModes, ...] = ()
    loggers: tuple[LoggerSpec, ...] = ()
    named: bool = False
    robot_args: Mapping[str, str] = field(default_factory=dict)
    self_collision: SelfCollision | None = None
    base: BaseKind | None = None
    """``"fixed"``, ``"floating"`` (a mobile base) or None (the file's)."""
    strict: bool = False
    srdf: str | Path | None = None


@dataclass(frozen=True)
class ScenarioBridgeSection:
    """The ``ros.bridge`` section as the file spells it (the original's ``ip``, ``connect``);
    :meth:`transport` is the session's :class:`harness.session.core.options.TransportOptions`.
    ``port``: where a session started from the scenario listens (None: a free port; ``harness
    run`` and the pytest marker always take a free port: iterations and test workers run side
    by side). ``connect``: the URL of an external rosbridge server to connect to instead
    (client mode; a token goes in the URL). ``ros2``: put the simulation on DDS too."""

    ip: str = "127.0.0.1"
    port: int | None = None
    connect: str | None = None
    ros2: bool = False

    def transport(self) -> TransportOptions:
        """The session's transport options of this section."""
        return TransportOptions(
            host=self.ip, port=self.port or 0, connect_to=self.connect, ros2=self.ros2
        )


_LOGGING_OFF = LoggingConfig(enable=False)  # a scenario without a logging section


@dataclass(frozen=True)
class Clock:
    """Clock mode of the run; ``rate`` is the real-time factor in ``realtime`` mode."""

    mode: ClockMode = ClockMode.REALTIME
    rate: float = 1.0


@dataclass(frozen=True)
class ScenarioRecordingSection:
    """The ``recording`` section: whether each iteration records an MCAP file; its
    ``state_every`` and ``bridge_frames`` are the session's ``CoreOptions.state_every`` and
    ``CoreOptions.record_bridge_frames``."""

    enabled: bool = True
    state_every: int = 1
    bridge_frames: bool = True


@dataclass(frozen=True)
class Criteria:
    """Pass/fail criteria judged on every iteration; the defaults pass a correct run.

    ``no_collisions``: a robot's contacts fail the run, except ``allowed_collisions`` (body
    pairs, shell-style patterns), contacts between world objects only (a box resting on a
    table: recorded, judged only with ``world_collisions``) and contacts present at the start
    (a robot resting on its table: judged only with ``initial_contacts``) and a robot's
    support contacts (wheels and casters on any surface, its floor: judged only with
    ``support_contacts``; see :mod:`harness.events.support`).
    ``joint_limit_tolerance``: how far beyond a position limit a joint may go; ``None`` (the
    default) is the solver's own soft-limit zone of each joint
    (:func:`harness.events.solver_limit_tolerance`). See :func:`criteria_settings`.
    """

    no_collisions: bool = True
    allowed_collisions: tuple[tuple[str, str], ...] = ()
    world_collisions: bool = False
    initial_contacts: bool = False
    support_contacts: bool = False
    joint_limits: bool = True
    joint_limit_tolerance: float | None = None
    deterministic: bool = False
    returns_to_start: float | None = None
    """Metres: each floating-base robot ends within this horizontal distance of its start."""


@dataclass(frozen=True)
class ClientSpec:
    """The client under test: ``command`` runs in ``cwd`` with ``env`` added to the environment
    (plus ``HARNESS_ROSBRIDGE_URL``); it must connect within ``readiness_timeout`` wall seconds;
    a run still going after ``wall_timeout`` wall seconds is stopped and failed. A command whose
    program is ``python`` or ``python3`` runs with the interpreter running the harness."""

    command: tuple[str, ...]
    cwd: Path
    env: Mapping[str, str] = field(default_factory=dict)
    readiness_timeout: float = 30.0
    wall_timeout: float = 600.0


@dataclass(frozen=True)
class ResumeSpec:
    """The ``resume`` section: continue the recording ``source`` from ``step`` (or from
    ``at_time`` seconds; its last step when neither) with ``edits`` and ``preroll``
    (``Session.resume``)."""

    source: Path
    step: int | None = None
    at_time: float | None = None
    edits: tuple[str, ...] = ()
    preroll: float = 0.0


@dataclass(frozen=True)
class Scenario:
    """A validated scenario. Build it with :meth:`load` or :meth:`from_mapping`."""

    name: str
    robots: tuple[ScenarioRobot, ...]
    environment: Environment = Environment()
    description: str = ""
    bridge: ScenarioBridgeSection = ScenarioBridgeSection()
    logging: LoggingConfig = _LOGGING_OFF
    timestep: float | None = None
    """The physics step in seconds; None (no ``timestep`` key): the map's own (an SDF world's
    ``<max_step_size>``, an MJCF scene's ``<option timestep>``: see
    :func:`harness.scenario.world.effective_timestep`)."""
    duration: float = 10.0
    seed: int = 0
    sensors: tuple[Mapping[str, Any], ...] = ()
    """Sensors besides the robot files' (mappings as :class:`harness.sensors.SensorSpec`)."""
    clock: Clock | None = None
    """The ``clock`` section; None when the file has none (``harness run`` then runs
    ``realtime``, the pytest marker ``lockstep``: see :mod:`harness.scenario.session_options`)."""
    objects: tuple[WorldObject, ...] = ()
    """The ``objects`` entries; the file's ``position`` and ``orientation`` (roll, pitch, yaw)
    are each object's ``pose``."""
    recording: ScenarioRecordingSection = ScenarioRecordingSection()
    criteria: Criteria = Criteria()
    client: ClientSpec | None = None
    resume: ResumeSpec | None = None
    """Continue a recording from a step instead of starting at step 0 (``duration`` still
    counts from step 0)."""
    source: Path | None = None
    controllers: ControllersConfig | None = None
    """The ros2_control controllers (None: each robot's default set)."""
    controllers_args: Mapping[str, str] = field(default_factory=dict)
    """The values the controllers YAML's ``$(var NAME)`` took (already expanded in
    ``controllers``)."""
    script: tuple[ScriptCommand, ...] = ()
    """In-process commands on a timeline (:mod:`harness.scenario.script`), in file order
    (applied in time order, ties in file order)."""
    explore: Mapping[str, Any] | None = None
    """The ``explore`` section as written (schema-checked; :mod:`harness.explore` reads it)."""

    @classmethod
    def load(cls, path: str | Path) -> Scenario:
        """Read and validate a scenario file (JSON or YAML); raises :class:`ScenarioError`
        listing every problem found."""
        path = Path(path).resolve()
        return cls.from_mapping(load_document(path), base_dir=path.parent, source=path)

    @classmethod
    def from_mapping(
        cls,
        data: Any,
        *,
        base_dir: Path | None = None,
        source: Path | None = None,
        schema: bool = True,
    ) -> Scenario:
        """Validate an already parsed document; relative paths resolve against ``base_dir``.
        ``schema=False``: the caller has checked ``data`` against the scenario schema (the
        semantic checks still run)."""
        where = str(source) if source is not None else "<scenario>"
        problems = schema_problems(data, "scenario", where) if schema else []
        builder = _Builder(where, base_dir or Path.cwd())
        if problems:
            # Still report the missing files and unknown names, so one pass shows everything.
            builder.references(data)
            raise ScenarioError(problems + builder.problems)
        scenario = builder.scenario(data, source)
        if builder.problems:
            raise ScenarioError(builder.problems)
        return scenario


def _arg_text(value: Any) -> str:
    """A scenario's xacro argument value as xacro reads it (booleans ``true``/``false``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def _resolve_choice(
    value: str, base: Path, builtins: tuple[str, ...], suffixes: tuple[str, ...]
) -> str | Path:
    """A built-in name stays a str; anything that looks like a path becomes a resolved Path."""
    if value in builtins:
        return value
    if "/" in value or "\\" in value or Path(value).suffix.lower() in suffixes:
        return (base / value).resolve()
    return value


class _Builder:
    """Builds dataclasses from a schema-valid document, collecting the semantic problems."""

    def __init__(self, where: str, base: Path) -> None:
        self.where = where
        self.base = base
        self.problems: list[str] = []

    def problem(self, path: list[str | int], value: Any, text: str) -> None:
        self.problems.append(f"{self.where}: {format_path(path)}: {value!r} {text}")

    def scenario(self, data: dict[str, Any], source: Path | None) -> Scenario:
        env = data.get("environment", {})
        ros_bridge = data.get("ros", {}).get("bridge", {})
        crit = data.get("criteria", {})
        clock = data.get("clock")
        rec = data.get("recording", {})
        default_name = source.stem if source is not None else "scenario"
        robots = tuple(self.robot(r, i) for i, r in enumerate(data["robots"]))
        objects = tuple(self.object(o, i) for i, o in enumerate(data.get("objects", [])))
        self.unique("robots", [r.name for r in robots])
        self.unique("objects", [o.name for o in objects])
        return Scenario(
            name=data.get("name", default_name),
            description=data.get("description", ""),
            robots=robots,
            environment=Environment(
                map=self.map(env.get("map", "")),
                weather=env.get("weather"),
                time=env.get("time"),
                mesh_collision=str(env.get("mesh_collision", "decompose")),
            ),
            bridge=ScenarioBridgeSection(
                ip=ros_bridge.get("ip", "127.0.0.1"),
                port=None if "port" not in ros_bridge else self.port(ros_bridge["port"]),
                connect=ros_bridge.get("connect"),
                ros2=ros_bridge.get("ros2", False),
            ),
            logging=self.logging(data.get("logging")),
            timestep=None if data.get("timestep") is None else float(data["timestep"]),
            duration=float(data.get("duration", 10.0)),
            seed=int(data.get("seed", 0)),
            controllers=self.controllers(
                data.get("controllers"), data.get("controllers_args") or {}
            ),
            controllers_args={
                str(k): _arg_text(v) for k, v in (data.get("controllers_args") or {}).items()
            },
            sensors=self.sensors(data.get("sensors", [])),
            clock=None
            if clock is None
            else Clock(
                mode=ClockMode(clock.get("mode", "realtime")), rate=float(clock.get("rate", 1.0))
            ),
            objects=objects,
            recording=ScenarioRecordingSection(
                enabled=rec.get("enabled", True),
                state_every=rec.get("state_every", 1),
                bridge_frames=rec.get("bridge_frames", True),
            ),
            criteria=Criteria(
                no_collisions=crit.get("no_collisions", True),
                allowed_collisions=tuple((a, b) for a, b in crit.get("allowed_collisions", [])),
                world_collisions=crit.get("world_collisions", False),
                initial_contacts=crit.get("initial_contacts", False),
                support_contacts=crit.get("support_contacts", False),
                joint_limits=crit.get("joint_limits", True),
                joint_limit_tolerance=(
                    None
                    if crit.get("joint_limit_tolerance") is None
                    else float(crit["joint_limit_tolerance"])
                ),
                deterministic=crit.get("deterministic", False),
                returns_to_start=(
                    None
                    if crit.get("returns_to_start") is None
                    else float(crit["returns_to_start"])
                ),
            ),
            client=self.client(data["client"], ["client"]) if "client" in data else None,
            resume=self.resume(data["resume"]) if "resume" in data else None,
            source=source,
            script=self.script(data),
            explore=data.get("explore"),
        )

    def script(self, data: dict[str, Any]) -> tuple[ScriptCommand, ...]:
        """The ``script`` timeline; refused beside a ``client`` (one drives the run)."""
        items = data.get("script", [])
        if items and "client" in data:
            self.problem(
                ["script"], f"[{len(items)} command(s)]", "cannot be given with a client command"
            )
        return script_commands(items)

    def references(self, data: Any) -> None:
        """Check the robot and world references of a document that failed the schema."""
        if not isinstance(data, dict):
            return
        env = data.get("environment")
        if isinstance(env, dict) and isinstance(env.get("map"), str):
            self.map(env["map"])
        robots = data.get("robots")
        for index, robot in enumerate(robots if isinstance(robots, list) else []):
            if isinstance(robot, dict) and isinstance(robot.get("robot"), str) and robot["robot"]:
                self.robot_source(robot["robot"], ["robots", index, "robot"])

    def robot_source(self, value: str, path: list[str | int]) -> str | Path:
        if value.startswith("package://"):
            try:
                return resolve_uri(value, base_dir=self.base, what="robot file")
            except ModelError as exc:
                self.problem(path, value, f"is not found: {exc}")
                return value
        robot = _resolve_choice(value, self.base, BUILTIN_ROBOTS, ROBOT_SUFFIXES)
        if isinstance(robot, Path):
            if not robot.is_file():
                self.problem(path, value, f"not found (looked for {robot})")
        elif robot not in BUILTIN_ROBOTS:
            self.problem(
                path, value, self.not_builtin("robot", robot, BUILTIN_ROBOTS, ROBOT_SUFFIXES)
            )
        return robot

    def srdf(self, value: str, path: list[str | int]) -> Path | str:
        """A robot's ``srdf:``: a path relative to the scenario file or ``package://``
        (a MoveIt config package), which must exist."""
        if value.startswith("package://"):
            try:
                return resolve_uri(value, base_dir=self.base, what="srdf")
            except ModelError as exc:
                self.problem(path, value, f"is not found: {exc}")
                return value
        srdf = (self.base / value).resolve()
        if not srdf.is_file():
            self.problem(path, value, f"not found (looked for {srdf})")
        return srdf

    def unique(self, key: str, names: list[str]) -> None:
        for i, name in enumerate(names):
            if name in names[:i]:
                self.problem(
                    [key, i, "name"], name, f"is already the name of {key}[{names.index(name)}]"
                )

    def controllers(
        self, value: str | Mapping[str, Any] | list[Any] | None, args: Mapping[str, Any]
    ) -> ControllersConfig | None:
        if value is None:
            return None
        sources: list[str | Path | Mapping[str, Any]] = []
        for i, one in enumerate(value if isinstance(value, list) else [value]):
            path: list[str | int] = (
                ["controllers", i] if isinstance(value, list) else ["controllers"]
            )
            if isinstance(one, str):
                file = self.base / one
                if not file.is_file():
                    self.problem(path, one, f"not found (looked for {file})")
                    return None
                sources.append(file)
            else:
                sources.append(one)
        try:
            return load_controllers(sources if isinstance(value, list) else sources[0], args)
        except ControllersConfigError as exc:
            shown = (
                value if isinstance(value, str) else "[...]" if isinstance(value, list) else "{...}"
            )
            self.problem(["controllers"], shown, str(exc))
            return None

    def map(self, value: str) -> str | Path:
        path: list[str | int] = ["environment", "map"]
        if value == "":
            return "empty"
        resolved = _resolve_choice(value, self.base, BUILTIN_MAPS, WORLD_SUFFIXES)
        if isinstance(resolved, Path):
            if not resolved.is_file():
                self.problem(path, value, f"not found (looked for {resolved})")
            return resolved
        if resolved not in BUILTIN_MAPS:
            self.problem(
                path, value, self.not_builtin("scene", resolved, BUILTIN_MAPS, WORLD_SUFFIXES)
            )
        return resolved

    @staticmethod
    def not_builtin(
        kind: str, value: str, builtins: tuple[str, ...], suffixes: tuple[str, ...]
    ) -> str:
        guess = difflib.get_close_matches(value, builtins, n=1)
        hint = f"did you mean {guess[0]!r}? " if guess else ""
        return (
            f"is not a built-in {kind} ({hint}built-ins: {', '.join(builtins)}) "
            f"nor a file path (use a {'/'.join(suffixes)} file)"
        )

    def sensors(self, items: list[Any]) -> tuple[Mapping[str, Any], ...]:
        """The ``sensors:`` list, each entry checked as a sensor declaration."""
        from harness.sensors import SensorConfigError, SensorSpec

        for i, item in enumerate(items):
            try:
                SensorSpec.from_mapping(item, "sensor")
            except SensorConfigError as exc:
                self.problem(["sensors", i], item.get("name", item), f"is not valid: {exc}")
        return tuple(dict(item) for item in items)

    def port(self, value: int | str) -> int:
        port = int(value)
        if not 0 <= port <= 65535:
            self.problem(["ros", "bridge", "port"], value, "is not a TCP port (0-65535)")
        return port

    def modes(self, data: dict[str, Any], path: list[str | int]) -> list[dict[str, Any]]:
        """A robot's ``modes:`` entries; its earlier spelling ``controllers:`` is read with a
        warning (that word names the scenario's ros2_control YAML)."""
        if "controllers" not in data:
            return list(data.get("modes", []))
        warnings.warn(
            f"{self.where}: {format_path([*path, 'controllers'])}: a robot's control modes are "
            "spelled 'modes:' now ('controllers:' is the scenario's ros2_control YAML); the old "
            "spelling is read until the next release",
            FutureWarning,
            stacklevel=2,
        )
        return list(data["controllers"])

    def robot(self, data: dict[str, Any], index: int) -> ScenarioRobot:
        path: list[str | int] = ["robots", index]
        robot = self.robot_source(data["robot"], [*path, "robot"])
        default_name = "robot" if index == 0 else f"robot{index}"
        return ScenarioRobot(
            robot=robot,
            name=data.get("name", default_name),
            position=_vec3(data.get("position")),
            orientation=_vec3(data.get("orientation")),
            initial_joint_positions={
                k: float(v) for k, v in data.get("initial_joint_positions", {}).items()
            },
            subscribers=tuple(
                Subscriber(
                    type=s["type"],
                    topic=s.get(
                        "topic",
                        "/joint/states"
                        if s["type"] == "JointStateSubscriber"
                        else "/joint_trajectory",
                    ),
                )
                for s in data.get("subscribers", [])
            ),
            modes=tuple(
                JointModes(
                    mode=ControlMode.parse(c["mode"]),
                    joints=tuple(c.get("joints", ())),
                    kinematic_limits=LimitPolicy(
                        c.get(LIMIT_POLICY_KEY, c.get(LIMIT_POLICY_OLD_KEY, "clamp"))
                    ),
                )
                for c in self.modes(data, path)
            ),
            loggers=tuple(
                self.logger(lg, [*path, "loggers", i])
                for i, lg in enumerate(data.get("loggers", []))
            ),
            named="name" in data,
            robot_args={str(k): _arg_text(v) for k, v in data.get("robot_args", {}).items()},
            # the schema's enums are harness.vocabulary's: parsed to their plain spellings
            self_collision=(
                None
                if "self_collision" not in data
                else SelfCollisionPolicy(data["self_collision"]).value
            ),
            base=None if "base" not in data else RobotBase(data["base"]).value,
            strict=bool(data.get("strict", False)),
            srdf=None if "srdf" not in data else self.srdf(data["srdf"], [*path, "srdf"]),
        )

    def logger(self, data: dict[str, Any], path: list[str | int]) -> LoggerSpec:
        kind = data["type"]
        for key in data:
            if key != "type" and key not in _LOGGER_KEYS[kind]:
                self.problem(
                    [*path, key],
                    data[key],
                    f"is not an option of {kind} (its options: {', '.join(_LOGGER_KEYS[kind])})",
                )
        if kind == "JointLogger":
            rate = data.get("rate")
            return JointLoggerSpec(
                rate=None if rate is None else float(rate), joints=tuple(data.get("joints", ()))
            )
        near = data.get("near_miss_distance")
        return CollisionLoggerSpec(
            debounce_steps=data.get("debounce_steps", 0),
            ignore_pairs=tuple((a, b) for a, b in data.get("ignore_pairs", [])),
            self_contacts=self.self_contacts(data, path),
            robot_vs_world_only=data.get("robot_vs_world_only", False),
            min_force=float(data.get("min_force", 0.0)),
            near_miss_distance=None if near is None else float(near),
        )

    def self_contacts(self, data: dict[str, Any], path: list[str | int]) -> bool:
        """A CollisionLogger's ``self_contacts``; its earlier spelling ``self_collision`` (the
        robot's link-pair policy has that name) is read with a warning."""
        if "self_collision" not in data:
            return bool(data.get("self_contacts", True))
        warnings.warn(
            f"{self.where}: {format_path([*path, 'self_collision'])}: a collision logger's "
            "flag is spelled 'self_contacts' now ('self_collision' is the robot's link-pair "
            "policy); the old spelling is read until the next release",
            FutureWarning,
            stacklevel=2,
        )
        return bool(data["self_collision"])

    def logging(self, data: dict[str, Any] | None) -> LoggingConfig:
        """The ``logging`` section (schema-valid already): logging off without one."""
        if data is None:
            return _LOGGING_OFF
        try:
            return logging_config_from_scene(data, base_dir=self.base)
        except LoggerConfigError as exc:
            self.problems.append(f"{self.where}: {exc}")
            return _LOGGING_OFF

    def object(self, data: dict[str, Any], index: int) -> WorldObject:
        want = OBJECT_SIZES[data["shape"]]
        if len(data["size"]) != want:
            self.problem(
                ["objects", index, "size"],
                data["size"],
                f"needs {want} number(s) for a {data['shape']}",
            )
        mass = data.get("mass")
        rgba = data.get("rgba")
        friction = data.get("friction")
        return WorldObject(
            name=data["name"],
            shape=data["shape"],
            size=tuple(float(s) for s in data["size"]),
            pose=Pose.from_xyz_rpy(_vec3(data.get("position")), _vec3(data.get("orientation"))),
            mass=None if mass is None else float(mass),
            rgba=None
            if rgba is None
            else (float(rgba[0]), float(rgba[1]), float(rgba[2]), float(rgba[3])),
            friction=None if friction is None else tuple(float(f) for f in friction),
        )

    def client(self, data: dict[str, Any], path: list[str | int]) -> ClientSpec:
        return ClientSpec(
            command=command_tuple(data["command"]),
            cwd=(self.base / data["cwd"]).resolve() if "cwd" in data else self.base,
            env=dict(data.get("env", {})),
            readiness_timeout=float(data.get("readiness_timeout", 30.0)),
            wall_timeout=float(data.get("wall_timeout", 600.0)),
        )

    def resume(self, data: dict[str, Any]) -> ResumeSpec:
        return ResumeSpec(
            source=(self.base / data["from"]).resolve(),
            step=data.get("at"),
            at_time=None if data.get("at_time") is None else float(data["at_time"]),
            edits=tuple(data.get("edits", ())),
            preroll=float(data.get("preroll", 0.0)),
        )


def command_tuple(value: str | list[str]) -> tuple[str, ...]:
    """A command given as a string (split like a POSIX shell, no shell features) or a list."""
    return tuple(shlex.split(value)) if isinstance(value, str) else tuple(value)


def _vec3(value: list[float] | None) -> Vector3:
    if value is None:
        return (0.0, 0.0, 0.0)
    return (float(value[0]), float(value[1]), float(value[2]))
