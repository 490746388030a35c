"""A session's options as frozen dataclasses, one per concern, and their recording codec.

``Session(robot, options=CoreOptions(...), transport=TransportOptions(...),
record=RecordOptions(...), load=LoadOptions(...), loggers=..., sinks=...)``:

- :class:`CoreOptions`: what the sans-I/O core does (clock, rates, topics, limits, seed...);
  it travels through a recording's metadata (:meth:`CoreOptions.to_metadata`,
  :meth:`CoreOptions.from_metadata`), each field by the codec its declaration carries;
- :class:`TransportOptions`: where the session's bridge is (embedded server, client of an
  external server, the ROS 2 side);
- :class:`RecordOptions`: the MCAP file and the scenario attached to it;
- :class:`LoadOptions`: what the session loads besides ``robot`` (several robots, objects,
  control modes, the scene, a xacro robot's arguments, load policies).

The session's keyword arguments (``Session(clock="fast", port=9090, record_to=...)``) are
these fields, spelled the same (:data:`SESSION_KEYWORDS`: field name -> group); the pytest
marker's keys derive from them too.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from types import MappingProxyType
from typing import Any, Literal, NamedTuple, TypedDict

from harness.controllers import ControllersConfig
from harness.models import (
    BaseKind,
    ControlMode,
    LoadedWorld,
    MeshCollision,
    PoseLike,
    RobotSpec,
    SelfCollision,
    WorldObject,
)
from harness.sensors import SensorSpec
from harness.session.core.control import (
    ControllersOption,
    controllers_from_metadata,
    controllers_metadata,
    controllers_option,
)
from harness.session.core.naming import check_session_name
from harness.session.errors import SessionConfigError
from harness.vocabulary import CLOCK_MODES, ClockMode, LimitPolicy

__all__ = [
    "DEFAULT_MAX_STEP_REQUEST",
    "SESSION_KEYWORDS",
    "START_MODES",
    "CoreOptions",
    "LoadOptions",
    "RecordOptions",
    "SessionKeywords",
    "StartMode",
    "TransportOptions",
    "group_keywords",
]

DEFAULT_MAX_STEP_REQUEST = 100_000
"""Default cap of one ``/harness/step`` request (steps run while the loop is blocked)."""

StartMode = Literal["now", "paused", "on_client"]
START_MODES: tuple[StartMode, ...] = ("now", "paused", "on_client")
"""How a free-running clock starts (:attr:`CoreOptions.start`)."""


class _Codec(NamedTuple):
    """How one :class:`CoreOptions` field is written to and read from the metadata:
    ``key`` (None: the field's name); ``encode`` (None: the field is written by someone
    else, the recorder or ``describe_run``); ``missing``: the value of a recording that
    lacks the key (None: the field's default)."""

    decode: Callable[[str, str], Any]
    encode: Callable[[Any], str | None] | None
    key: str | None = None
    missing: Any = None


def _text(value: Any) -> str:
    return str(value)


def _as_text(text: str, key: str) -> str:
    return text


def _number(text: str, key: str) -> float | None:
    if text == "":
        return None
    try:
        return float(text)
    except ValueError:
        raise SessionConfigError(f"metadata {key!r} is {text!r}, not a number") from None


def _integer(text: str, key: str) -> int:
    if not text.isdigit():
        raise SessionConfigError(f"metadata {key!r} is {text!r}, not an integer")
    return int(text)


def _hz(value: float | None) -> str:
    return "" if value is None else repr(float(value))


def _topics(value: str | Mapping[str, str]) -> str:
    return value if isinstance(value, str) else json.dumps(dict(value), sort_keys=True)


def _topics_from(text: str, key: str) -> str | dict[str, str]:
    if not text.startswith("{"):
        return text
    try:
        return dict(json.loads(text))
    except (ValueError, TypeError):
        raise SessionConfigError(
            f"metadata {key!r} is {text!r}, not a topic name or a JSON object of namespace -> topic"
        ) from None


def _sensors(value: Sequence[Mapping[str, Any]]) -> str | None:
    return json.dumps(list(value), sort_keys=True) if value else None


def _codec(
    decode: Callable[[str, str], Any],
    encode: Callable[[Any], str | None] | None = _text,
    *,
    key: str | None = None,
    missing: Any = None,
) -> dict[str, _Codec]:
    return {"codec": _Codec(decode, encode, key, missing)}


_STRING = _codec(_as_text)
_HZ = _codec(_number, _hz)


@dataclass(frozen=True)
class CoreOptions:
    """Everything besides the robot that decides what a core does (validated on creation);
    :meth:`to_metadata`/:meth:`from_metadata` carry it through a recording's metadata.

    ``clock``: ``lockstep``, ``fast`` or ``realtime`` (x ``rate``, the real-time factor).
    ``start``: a free-running clock (``fast``, ``realtime``) steps from the start (``"now"``),
    starts paused (``"paused"``: :meth:`SessionCore.set_paused`), or starts paused until its
    first client connects (``"on_client"``, the shell's job); lockstep takes only ``"now"``.
    ``record_bridge_frames``: whether bridge frames and markers are recorded (without them a
    recording cannot be replayed at ``--level full``). ``joint_command_topic``: one name for
    every robot, or robot namespace -> name (robots not listed: ``"joint_command"``).
    ``max_step_request``: the most steps one ``/harness/step`` request may ask for (a larger
    request fails, nothing stepped)."""

    clock: ClockMode = field(default=ClockMode.LOCKSTEP, metadata=_STRING)
    rate: float = field(default=1.0, metadata=_codec(_number, repr))
    namespace: str = field(default="", metadata=_STRING)
    kinematic_limits: LimitPolicy = field(default=LimitPolicy.CLAMP, metadata=_STRING)
    state_every: int = field(default=1, metadata=_codec(_integer, None))
    joint_states_hz: float = field(default=100.0, metadata=_HZ)
    tf_hz: float | None = field(default=None, metadata=_HZ)
    clock_hz: float | None = field(default=None, metadata=_HZ)
    joint_command_topic: str | Mapping[str, str] = field(
        default="joint_command", metadata=_codec(_topics_from, _topics)
    )
    start: StartMode = field(default="now", metadata=_STRING)
    record_bridge_frames: bool = field(
        default=True,
        metadata=_codec(
            lambda text, key: text != "false",
            lambda value: "true" if value else "false",
            key="bridge_frames",
        ),
    )
    max_step_request: int = field(default=DEFAULT_MAX_STEP_REQUEST, metadata=_codec(_integer))
    controllers: ControllersConfig | str = field(
        default="default",
        metadata=_codec(
            lambda text, key: controllers_from_metadata(text),
            controllers_metadata,
            missing="none",  # a recording made before controllers existed
        ),
    )
    sensors: Sequence[Mapping[str, Any]] = field(
        default=(), metadata=_codec(lambda text, key: tuple(json.loads(text)), _sensors)
    )
    """Sensors besides those the robot files declare (see :class:`harness.sensors.SensorSpec`)."""
    seed: int = field(default=0, metadata=_codec(lambda text, key: int(text or 0), None))
    """The session seed (sensor noise); recorded as the ``seed`` metadata key."""

    def __post_init__(self) -> None:
        if not isinstance(self.controllers, ControllersConfig) and self.controllers not in (
            "default",
            "none",
        ):
            raise SessionConfigError(
                "controllers must be a ControllersConfig, 'default' or 'none', not "
                f"{self.controllers!r} (read a YAML with harness.controllers.load_controllers)"
            )
        if self.clock not in CLOCK_MODES:
            raise SessionConfigError(
                f"clock must be one of {', '.join(CLOCK_MODES)}, not {self.clock!r}"
            )
        object.__setattr__(self, "clock", ClockMode(self.clock))
        rate = self.rate
        if not (isinstance(rate, int | float) and math.isfinite(rate) and rate > 0):
            raise SessionConfigError(f"rate must be a finite number > 0, not {rate!r}")
        object.__setattr__(self, "rate", float(rate))
        if self.start not in START_MODES:
            raise SessionConfigError(
                f"start must be one of {', '.join(START_MODES)}, not {self.start!r}"
            )
        if self.clock == "lockstep" and self.start != "now":
            raise SessionConfigError(
                f"start={self.start!r} applies to the fast and realtime clocks: a lockstep "
                "clock moves only when asked"
            )
        sensors = []
        for i, item in enumerate(self.sensors):
            if isinstance(item, SensorSpec):
                item = item.to_json()
            if not isinstance(item, Mapping):
                raise SessionConfigError(
                    f"sensors[{i}] must be a mapping of sensor keys, not {item!r}"
                )
            sensors.append(dict(item))
        object.__setattr__(self, "sensors", tuple(sensors))
        if not isinstance(self.record_bridge_frames, bool):
            raise SessionConfigError(
                f"record_bridge_frames must be True or False, not {self.record_bridge_frames!r}"
            )
        if (
            not isinstance(self.max_step_request, int)
            or isinstance(self.max_step_request, bool)
            or self.max_step_request < 1
        ):
            raise SessionConfigError(
                f"max_step_request must be an integer >= 1, not {self.max_step_request!r}"
            )
        if not isinstance(self.state_every, int) or self.state_every < 1:
            raise SessionConfigError(
                f"state_every must be an integer >= 1, not {self.state_every!r}"
            )
        for what, hz in (
            ("joint_states_hz", self.joint_states_hz),
            ("tf_hz", self.tf_hz),
            ("clock_hz", self.clock_hz),
        ):
            if hz is not None and not (
                isinstance(hz, int | float) and math.isfinite(hz) and hz >= 0
            ):
                raise SessionConfigError(f"{what} must be >= 0 Hz, not {hz!r}")
        if self.namespace:
            object.__setattr__(
                self,
                "namespace",
                check_session_name(self.namespace, "namespace", "namespace").strip("/"),
            )
        try:
            object.__setattr__(self, "kinematic_limits", LimitPolicy.parse(self.kinematic_limits))
        except ValueError as exc:
            raise SessionConfigError(str(exc)) from None
        topics = self.joint_command_topic
        if isinstance(topics, Mapping):
            for namespace, topic in topics.items():
                if not isinstance(namespace, str) or not isinstance(topic, str):
                    raise SessionConfigError(
                        f"joint_command_topic[{namespace!r}] must map a namespace to a topic "
                        f"name, not {topic!r}"
                    )
                check_session_name(topic, f"joint_command_topic[{namespace!r}]")
            object.__setattr__(self, "joint_command_topic", MappingProxyType(dict(topics)))
        elif not isinstance(topics, str):
            raise SessionConfigError(
                f"joint_command_topic must be a topic name or namespace -> name, not {topics!r}"
            )
        else:
            check_session_name(topics, "joint_command_topic")

    def command_topic(self, namespace: str) -> str:
        """The joint command topic name of the robot with ``namespace``."""
        topics = self.joint_command_topic
        if isinstance(topics, str):
            return topics
        return topics.get(namespace, "joint_command")

    def to_metadata(self) -> dict[str, str]:
        """The recording metadata keys of these options (all strings; ``state_every`` and
        ``seed`` are written by the recorder and ``describe_run``)."""
        out: dict[str, str] = {}
        for f in fields(self):
            codec: _Codec = f.metadata["codec"]
            if codec.encode is None:
                continue
            text = codec.encode(getattr(self, f.name))
            if text is not None:
                out[codec.key or f.name] = text
        return out

    @classmethod
    def from_metadata(cls, metadata: Mapping[str, str]) -> CoreOptions:
        """The options of a recorded session (keys a recording lacks keep their defaults)."""
        values: dict[str, Any] = {}
        for f in fields(cls):
            codec: _Codec = f.metadata["codec"]
            key = codec.key or f.name
            text = metadata.get(key)
            if text is None:
                if codec.missing is not None:
                    values[f.name] = codec.missing
                continue
            value = codec.decode(text, key)
            if value is not None:
                values[f.name] = value
        return cls(**values)


@dataclass(frozen=True)
class TransportOptions:
    """Where the session's bridge is. ``host``/``port``: where the embedded server listens
    (port 0: any free port; a non-loopback host issues an ``ExposedServerWarning``);
    ``token``: clients must present it (``?token=`` on the URL or ``Authorization: Bearer``);
    ``connect_to``: a ``ws://`` URL of an external rosbridge server to use instead (client
    mode; ``connect_allow_refused``: start even when that server refuses some of the
    simulation's topics or services); ``ros2``: also put the simulation on DDS."""

    host: str = "127.0.0.1"
    port: int = 0
    token: str | None = None
    connect_to: str | None = None
    connect_allow_refused: bool = False
    ros2: bool = False

    def __post_init__(self) -> None:
        if self.token is not None and self.connect_to is not None:
            raise SessionConfigError(
                "token protects the embedded server; for an external server put its token "
                "in connect_to (ws://host:port/?token=...)"
            )
        if self.ros2 and self.connect_to is not None:
            raise SessionConfigError(
                "ros2 puts the session's own graph on DDS; with connect_to the external "
                "rosbridge server's ROS 2 side does that"
            )


@dataclass(frozen=True)
class RecordOptions:
    """``record_to``: the MCAP file (None: no recording); ``scenario``: the scenario text
    attached to it."""

    record_to: str | Path | None = None
    scenario: str | bytes | None = None


@dataclass(frozen=True)
class LoadOptions:
    """What the session loads besides ``robot``: ``robots`` (several robots in one world:
    RobotSpecs or a LoadedWorld, instead of ``robot``), ``objects`` (added to that world),
    ``mode`` (the control mode of ``robot``'s joints, or joint -> mode), ``scene`` (a built-in
    name, an MJCF scene or an SDF world; ``world=`` is the same keyword, as Gazebo users name
    it), ``robot_args`` (a xacro robot's arguments), ``self_collision``, ``srdf``, ``base``
    and ``strict`` (as for :func:`harness.models.load_robot`), ``controllers_args`` (the
    controllers YAML's launch arguments), ``mesh_collision`` (``decompose`` or ``hull``, see
    :mod:`harness.models.build.decompose`), ``pose`` (where ``robot``'s model frame is in the
    world: x y z, or x y z roll pitch yaw, as a Gazebo launch's ``create -x -y -z -R -P -Y``; see
    :data:`harness.models.PoseLike`)."""

    robots: Sequence[RobotSpec] | LoadedWorld | None = None
    objects: Sequence[WorldObject] = ()
    mode: ControlMode | str | Mapping[str, ControlMode | str] | None = None
    scene: str | Path | None = None
    robot_args: Mapping[str, Any] | None = None
    self_collision: SelfCollision | None = None
    srdf: str | Path | None = None
    base: BaseKind | None = None
    strict: bool = False
    controllers_args: Mapping[str, Any] | None = None
    """The values of the controllers YAML's ``$(var NAME)`` launch substitutions (name ->
    value; read with ``controllers=`` given as a keyword)."""
    mesh_collision: MeshCollision = "decompose"
    pose: PoseLike = None


class SessionKeywords(TypedDict, total=False):
    """The keyword spelling of the options objects' fields (for type checkers; the fields
    themselves decide: :data:`SESSION_KEYWORDS`)."""

    clock: ClockMode | str
    rate: float
    namespace: str
    kinematic_limits: LimitPolicy | str
    state_every: int
    joint_states_hz: float
    tf_hz: float | None
    clock_hz: float | None
    joint_command_topic: str | Mapping[str, str]
    start: StartMode
    record_bridge_frames: bool
    max_step_request: int
    controllers: ControllersOption
    sensors: Sequence[Mapping[str, Any]]
    seed: int
    host: str
    port: int
    token: str | None
    connect_to: str | None
    connect_allow_refused: bool
    ros2: bool
    record_to: str | Path | None
    scenario: str | bytes | None
    robots: Sequence[RobotSpec] | LoadedWorld | None
    objects: Sequence[WorldObject]
    mode: ControlMode | str | Mapping[str, ControlMode | str] | None
    scene: str | Path | None
    world: str | Path | None
    robot_args: Mapping[str, Any] | None
    self_collision: SelfCollision | None
    srdf: str | Path | None
    base: BaseKind | None
    strict: bool
    controllers_args: Mapping[str, Any] | None
    mesh_collision: MeshCollision
    pose: PoseLike


_GROUPS: dict[str, type[Any]] = {
    "options": CoreOptions,
    "transport": TransportOptions,
    "record": RecordOptions,
    "load": LoadOptions,
}
SESSION_KEYWORDS: Mapping[str, str] = MappingProxyType(
    {f.name: group for group, cls in _GROUPS.items() for f in fields(cls)}
)
"""Every keyword argument of :class:`~harness.session.Session` besides ``robot``, ``loggers``
and ``sinks`` (field name -> the options group it belongs to), plus ``world`` (= ``scene``)."""


def group_keywords(keywords: Mapping[str, Any], given: Mapping[str, Any]) -> dict[str, Any]:
    """The options objects of ``Session``'s keyword arguments: ``given`` holds the objects
    passed as ``options=``/``transport=``/``record=``/``load=`` (None: not given);
    ``keywords`` the flat keywords. A keyword of a group given as an object is refused."""
    keywords = dict(keywords)
    if "world" in keywords:  # the map as a Gazebo user names it: the same option as scene
        world = keywords.pop("world")
        if world is not None:
            if keywords.get("scene") is not None:
                raise SessionConfigError("world and scene name the same option (the map): give one")
            keywords["scene"] = world
    unknown = sorted(set(keywords) - set(SESSION_KEYWORDS))
    if unknown:
        raise TypeError(f"Session() got an unexpected keyword argument {unknown[0]!r}")
    out: dict[str, Any] = {}
    load = given.get("load")
    args = keywords.get("controllers_args", getattr(load, "controllers_args", None))
    for group, cls in _GROUPS.items():
        mine = {k: v for k, v in keywords.items() if SESSION_KEYWORDS[k] == group}
        if "controllers" in mine:  # a YAML (file, text, mapping) or True/False/None
            mine["controllers"] = controllers_option(mine["controllers"], args)
        obj = given.get(group)
        if obj is not None and mine:
            raise SessionConfigError(
                f"give {', '.join(sorted(mine))} inside {group}= or as keywords, not both"
            )
        out[group] = obj if obj is not None else cls(**mine)
    return out
