"""What every controller takes and gives (sans-I/O records and the :class:`Controller` protocol).

A controller never touches a socket, a clock or the simulation: the session hands it the joints'
:class:`JointReadings` and the simulation time at a step boundary (a message, a goal, a cancel,
an update) and applies the :class:`ControllerOutput` it returns: joint commands, messages to
publish, action feedback and results, log lines. A controller that reads a sensor (a broadcaster) is
given the robot's :class:`SensorInterfaces` when it is built.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal, NamedTuple, Protocol

__all__ = [
    "GOAL_ABORTED",
    "GOAL_CANCELED",
    "GOAL_SUCCEEDED",
    "NOTHING",
    "ActionEndpoint",
    "BaseVelocity",
    "Command",
    "Controller",
    "ControllerBase",
    "ControllerOutput",
    "Feedback",
    "JointReadings",
    "LogLine",
    "Publication",
    "Result",
    "SensorInterfaces",
    "TopicEndpoint",
]

GOAL_SUCCEEDED = 4
GOAL_CANCELED = 5
GOAL_ABORTED = 6

LifecycleState = Literal["unconfigured", "inactive", "active", "finalized"]

_NOTHING: Mapping[str, float] = MappingProxyType({})


class JointReadings(NamedTuple):
    """The state interfaces of a robot's joints at one instant (``sim_time_ns``), and the
    value each joint's command interface holds (``command``: what was last commanded, in the
    unit of its mode's field; empty where a caller gives none). A tuple: the session makes
    one at every step for a controller updated every step. The session's mappings also give
    their whole array (:class:`~harness.controllers.values.JointArray`): a controller over
    many joints takes them with a :class:`~harness.controllers.values.JointIndex`."""

    sim_time_ns: int
    position: Mapping[str, float]
    velocity: Mapping[str, float]
    effort: Mapping[str, float]
    command: Mapping[str, float] = _NOTHING


class Command(NamedTuple):
    """A command for one joint, the one form every command takes on its way to the
    simulation (whatever topic, action or controller it came from). With one field given
    (the common case) that field is written; with several, the one the joint's control
    mode takes (``position`` for position and kinematic joints, ``velocity``, ``effort``).
    A tuple, so that a controller may emit one per joint per message cheaply."""

    joint: str
    position: float | None = None
    velocity: float | None = None
    effort: float | None = None


@dataclass(frozen=True)
class BaseVelocity:
    """A body velocity for a floating base driven as a planar base (its free joint ``joint``):
    ``linear_x``, ``linear_y`` (m/s, heading frame), ``angular_z`` (rad/s)."""

    joint: str
    linear_x: float
    linear_y: float
    angular_z: float


class Publication:
    """A message to publish on ``topic`` (relative to the controller: ``~/name``): ``msg``,
    or made by ``build`` when first asked for (:attr:`msg`): a message published at a rate
    whether or not anyone listens (a controller's state) is then never built for no one."""

    __slots__ = ("_build", "_msg", "topic", "type")

    def __init__(
        self,
        topic: str,
        type: str,
        msg: Mapping[str, Any] | None = None,
        *,
        build: Callable[[], Mapping[str, Any]] | None = None,
    ) -> None:
        if (msg is None) == (build is None):
            raise TypeError("Publication takes a msg or a build function (one of them)")
        self.topic = topic
        self.type = type
        self._msg = msg
        self._build = build

    @property
    def msg(self) -> Mapping[str, Any]:
        """The message (built on first use when given as ``build``, then held)."""
        msg = self._msg
        if msg is None:
            assert self._build is not None
            msg = self._msg = self._build()
            self._build = None
        return msg

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Publication):
            return NotImplemented
        return (self.topic, self.type, self.msg) == (other.topic, other.type, other.msg)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"Publication(topic={self.topic!r}, type={self.type!r}, msg={self.msg!r})"


@dataclass(frozen=True)
class Feedback:
    """Action feedback for goal ``goal`` (the id the session gave it)."""

    goal: int
    values: Mapping[str, Any]


@dataclass(frozen=True)
class Result:
    """The end of goal ``goal``: ``status`` 4 succeeded, 5 canceled, 6 aborted."""

    goal: int
    values: Mapping[str, Any]
    status: int


@dataclass(frozen=True)
class LogLine:
    """A log line (``level`` 20 info, 30 warning, 40 error); ``connection`` (when non-zero)
    also gets it as a status frame."""

    level: int
    text: str
    connection: int = 0


@dataclass
class ControllerOutput:
    """What one call of a controller produced, in order of effect."""

    commands: list[Command] = field(default_factory=list)
    publications: list[Publication] = field(default_factory=list)
    feedback: list[Feedback] = field(default_factory=list)
    results: list[Result] = field(default_factory=list)
    logs: list[LogLine] = field(default_factory=list)
    base: BaseVelocity | None = None
    where: str = ""
    """What its log lines and the notices of its commands are prefixed with (default: the
    topic of the message it answers, else the controller's name)."""

    def extend(self, other: ControllerOutput) -> None:
        """Append ``other``'s items."""
        self.commands += other.commands
        self.publications += other.publications
        self.feedback += other.feedback
        self.results += other.results
        self.logs += other.logs
        if other.base is not None:
            self.base = other.base


class _Nothing(ControllerOutput):
    """An output with nothing in it, shared by the calls that produce nothing (a controller's
    idle update, every cycle): its fields are empty tuples and it refuses any change, so a
    caller that adds to an output it was given fails loudly instead of changing everyone's."""

    def __init__(self) -> None:
        for name in ("commands", "publications", "feedback", "results", "logs"):
            object.__setattr__(self, name, ())
        object.__setattr__(self, "base", None)
        object.__setattr__(self, "where", "")

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"NOTHING is shared: make a ControllerOutput to set {name}")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ControllerOutput):
            return NotImplemented
        return not (
            other.commands or other.publications or other.feedback or other.results or other.logs
        ) and (other.base, other.where) == (None, "")

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return "NOTHING"


NOTHING: ControllerOutput = _Nothing()
"""The output of a call that produced nothing (equal to an empty :class:`ControllerOutput`;
shared and unchangeable: return it, never add to it)."""


@dataclass(frozen=True)
class TopicEndpoint:
    """A topic a controller subscribes (``~/name`` relative to the controller); ``node``:
    the node it belongs to on the graph (default: the controller's)."""

    name: str
    type: str
    node: str = ""


@dataclass(frozen=True)
class ActionEndpoint:
    """An action a controller serves (``~/name`` relative to the controller)."""

    name: str
    type: str


class Controller(Protocol):
    """One ros2_control controller, sans-I/O. The manager drives its lifecycle; the session
    calls :meth:`update` every ``1 / update_rate`` of simulation time while it is active."""

    name: str
    type: str

    @property
    def command_interfaces(self) -> tuple[str, ...]:
        """``joint/interface`` names it claims when active."""
        ...

    @property
    def state_interfaces(self) -> tuple[str, ...]:
        """``joint/interface`` names it reads."""
        ...

    @property
    def subscriptions(self) -> Sequence[TopicEndpoint]: ...

    @property
    def publishers(self) -> Sequence[TopicEndpoint]:
        """Topics it publishes (advertised from the start, so the graph shows them)."""
        ...

    @property
    def actions(self) -> Sequence[ActionEndpoint]: ...

    def activate(self, state: JointReadings) -> ControllerOutput: ...

    def deactivate(self, state: JointReadings) -> ControllerOutput: ...

    def on_message(
        self, topic: str, msg: Mapping[str, Any], connection: int, state: JointReadings
    ) -> ControllerOutput: ...

    def on_goal(
        self, action: str, goal: int, values: Mapping[str, Any], state: JointReadings
    ) -> ControllerOutput: ...

    def on_cancel(self, action: str, goal: int, state: JointReadings) -> ControllerOutput: ...

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput: ...


class SensorInterfaces(Protocol):
    """A robot's sensors as ros2_control state interfaces (``<sensor>/<interface>``, e.g.
    ``imu/orientation.x``): their :attr:`names` and their latest :meth:`values` (what each
    sensor measured at its last update, in simulation time)."""

    @property
    def names(self) -> tuple[str, ...]: ...

    def claim(self, names: Sequence[str]) -> None:
        """A controller will read ``names`` (the manager claims each controller's
        ``state_interfaces`` that are sensors')."""
        ...

    def values(self) -> Mapping[str, float]: ...


class ControllerBase:
    """The no-op defaults every controller shares: no endpoints, no interfaces, lifecycle
    calls that only flip :attr:`active`, and inputs that produce nothing. A controller
    subclasses it and overrides what it does."""

    subscriptions: Sequence[TopicEndpoint] = ()
    publishers: Sequence[TopicEndpoint] = ()
    actions: Sequence[ActionEndpoint] = ()
    command_interfaces: tuple[str, ...] = ()
    state_interfaces: tuple[str, ...] = ()
    reference_interfaces: tuple[str, ...] = ()
    """``<name>/<joint>/<interface>`` it offers other controllers (a multiplexer's)."""
    multiplexes = False
    """Whether it is a multiplexer: the one controller of a set that claims the joints'
    command interfaces, which the set's other controllers command through (its
    :attr:`reference_interfaces`, shared: exempt from the one-claim rule). It is told of
    every command written through it (:meth:`taken`)."""
    every_step = False
    """Whether the session updates it at every simulation step (a harness-owned controller
    interpolating a command), instead of at its update rate; its :meth:`update` is then
    given the time only (reading a joint raises)."""

    @property
    def idle(self) -> bool:
        """Whether its :meth:`update` would return nothing and change nothing now (an
        every-step controller with nothing in progress; False when it cannot tell)."""
        return False

    notice_key = 0
    """Notices of its cyclic commands (a value clamped, ...) are said once per joint and
    kind for each value of this key (a controller changes it when a new command starts)."""

    def __init__(self, name: str, type: str) -> None:
        self.name = name
        self.type = type
        self.active = False

    def activate(self, state: JointReadings) -> ControllerOutput:
        """Become active."""
        self.active = True
        return ControllerOutput()

    def deactivate(self, state: JointReadings) -> ControllerOutput:
        """Become inactive."""
        self.active = False
        return ControllerOutput()

    def on_message(
        self, topic: str, msg: Mapping[str, Any], connection: int, state: JointReadings
    ) -> ControllerOutput:
        """No topics: nothing."""
        return ControllerOutput()

    def on_goal(
        self, action: str, goal: int, values: Mapping[str, Any], state: JointReadings
    ) -> ControllerOutput:
        """No actions: nothing."""
        return ControllerOutput()

    def on_cancel(self, action: str, goal: int, state: JointReadings) -> ControllerOutput:
        """No actions: nothing."""
        return ControllerOutput()

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput:
        """Nothing to do per cycle."""
        return NOTHING

    def taken(self, commands: Sequence[Command], by: str) -> None:
        """A multiplexer's hook: controller ``by`` (another, or this one answering a
        message; "" for Python) wrote ``commands``. Nothing by default."""
