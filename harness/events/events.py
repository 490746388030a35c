"""The typed events loggers emit: immutable, stamped in simulation time, robot-named.

Every event carries ``step``, ``sim_time_ns`` (when the logger emitted it), ``robot`` and a
``level``; :meth:`Event.properties` gives its fields as JSON-ready values (what JSON lines,
stdlib ``logging`` ``extra`` and Seq CLEF properties carry) and :meth:`Event.message` renders
its message template (``TEMPLATE``, placeholders are property names: CLEF ``@mt``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, ClassVar

__all__ = [
    "CollisionBegin",
    "CollisionEnd",
    "Event",
    "JointLimitViolation",
    "JointSample",
    "Level",
    "LogMessage",
    "NearMiss",
    "Scalar",
    "VelocityLimitExceeded",
]

Vec3 = tuple[float, float, float]
Scalar = str | int | float | bool
"""A value a :class:`LogMessage` field may hold."""


class Level(IntEnum):
    """Severity; the numbers are those of ROS ``rcl_interfaces/msg/Log`` and stdlib logging."""

    DEBUG = 10
    INFO = 20
    WARNING = 30
    ERROR = 40
    FATAL = 50


def _json(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_json(v) for v in value]
    if isinstance(value, Level):
        return value.name
    return value


def _text(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list):
        return "[" + ", ".join(_text(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_text(v)}" for k, v in value.items()) + "}"
    return str(value)


@dataclass(frozen=True, kw_only=True)
class Event:
    """Base of every event. ``step``/``sim_time_ns``: the step at which it was emitted."""

    KIND: ClassVar[str] = "event"
    TEMPLATE: ClassVar[str] = "{robot}: event"

    step: int
    sim_time_ns: int
    robot: str
    level: Level = Level.INFO

    @property
    def kind(self) -> str:
        """The event type's stable name (``collision_begin``, ``joint_sample``, ...)."""
        return self.KIND

    def properties(self) -> dict[str, Any]:
        """Every field except ``level`` as JSON-ready values (tuples become lists)."""
        return {
            f.name: _json(getattr(self, f.name))
            for f in dataclasses.fields(self)
            if f.name != "level"
        }

    def message(self) -> str:
        """The human-readable message (``TEMPLATE`` rendered with :meth:`properties`)."""
        return self.TEMPLATE.format_map({k: _text(v) for k, v in self.properties().items()})

    def to_dict(self) -> dict[str, Any]:
        """``{"event": kind, "level": "INFO", **properties}`` (one JSON line)."""
        return {"event": self.kind, "level": self.level.name, **self.properties()}


@dataclass(frozen=True, kw_only=True)
class _PairEvent(Event):
    body1: str
    body2: str
    geom1: str
    geom2: str
    position: Vec3
    normal: Vec3


@dataclass(frozen=True, kw_only=True)
class CollisionBegin(_PairEvent):
    """Two bodies started touching at ``step``. ``position``/``normal`` (world frame, normal from
    ``body1`` to ``body2``), ``geom1``/``geom2``: the deepest contact of that step."""

    KIND: ClassVar[str] = "collision_begin"
    TEMPLATE: ClassVar[str] = (
        "{robot}: collision began between {body1} ({geom1}) and {body2} ({geom2}), "
        "penetration {penetration} m, normal force {normal_force} N"
    )

    penetration: float
    normal_force: float
    support: bool = False
    """A robot's contact with what supports it (:mod:`harness.events.support`)."""


@dataclass(frozen=True, kw_only=True)
class CollisionEnd(_PairEvent):
    """A contact episode ended: in contact from ``begin_step`` until ``end_step`` (the first
    step without contact; the event is emitted after the debounce window). Peaks are over the
    episode; ``position``/``normal``/geoms are those of the deepest contact. ``at_finish``: the
    run ended while the bodies still touched (``end_step`` is then the last step)."""

    KIND: ClassVar[str] = "collision_end"
    TEMPLATE: ClassVar[str] = (
        "{robot}: collision ended between {body1} and {body2} after {duration_ns} ns, "
        "peak penetration {penetration} m, peak normal force {normal_force} N"
    )

    penetration: float
    normal_force: float
    begin_step: int
    end_step: int
    duration_ns: int
    at_finish: bool = False
    support: bool = False
    """Every contact of the episode was a support contact (:mod:`harness.events.support`):
    a wheel on the floor, a base resting on its floor; never a bump into a wall."""


@dataclass(frozen=True, kw_only=True)
class NearMiss(_PairEvent):
    """Two bodies came within the near-miss distance without touching. ``distance`` is the
    closest approach, at ``closest_step`` (where ``position``: midpoint of the closest points,
    ``normal``: unit direction from ``geom1`` to ``geom2``, were taken)."""

    KIND: ClassVar[str] = "near_miss"
    TEMPLATE: ClassVar[str] = (
        "{robot}: near miss, {body1} ({geom1}) came within {distance} m of {body2} ({geom2})"
    )

    distance: float
    closest_step: int
    begin_step: int
    end_step: int
    at_finish: bool = False


@dataclass(frozen=True, kw_only=True)
class JointSample(Event):
    """Positions, velocities and efforts (actuator force) of ``joints`` at ``step``."""

    KIND: ClassVar[str] = "joint_sample"
    TEMPLATE: ClassVar[str] = "{robot}: joint sample {positions}"

    level: Level = Level.DEBUG
    joints: tuple[str, ...]
    positions: tuple[float, ...]
    velocities: tuple[float, ...]
    efforts: tuple[float, ...]

    def properties(self) -> dict[str, Any]:
        """Positions, velocities and efforts keyed by joint name."""
        return {
            "step": self.step,
            "sim_time_ns": self.sim_time_ns,
            "robot": self.robot,
            "positions": dict(zip(self.joints, self.positions, strict=True)),
            "velocities": dict(zip(self.joints, self.velocities, strict=True)),
            "efforts": dict(zip(self.joints, self.efforts, strict=True)),
        }


@dataclass(frozen=True, kw_only=True)
class _LimitEvent(Event):
    level: Level = Level.WARNING
    joint: str
    value: float
    limit: float
    amount: float
    peak_step: int
    begin_step: int
    end_step: int
    duration_ns: int
    at_finish: bool = False
    support: bool = False
    """Every contact of the episode was a support contact (:mod:`harness.events.support`):
    a wheel on the floor, a base resting on its floor; never a bump into a wall."""


@dataclass(frozen=True, kw_only=True)
class JointLimitViolation(_LimitEvent):
    """A joint was outside its position range from ``begin_step`` until ``end_step``; ``amount``
    is the peak excess (``value - upper`` or ``lower - value``) at ``peak_step``, ``limit`` the
    bound it passed, ``value`` the position there."""

    KIND: ClassVar[str] = "joint_limit_violation"
    TEMPLATE: ClassVar[str] = (
        "{robot}: joint {joint} passed its limit {limit} by {amount} (position {value})"
    )


@dataclass(frozen=True, kw_only=True)
class VelocityLimitExceeded(_LimitEvent):
    """A joint moved faster than its velocity limit; ``amount`` is the peak ``|v| - limit``,
    ``value`` the velocity at ``peak_step``."""

    KIND: ClassVar[str] = "velocity_limit_exceeded"
    TEMPLATE: ClassVar[str] = (
        "{robot}: joint {joint} velocity {value} exceeded its limit {limit} by {amount}"
    )


_RESERVED = frozenset({"event", "level", "step", "sim_time_ns", "robot", "text", "name"})


@dataclass(frozen=True, kw_only=True)
class LogMessage(Event):
    """A free-text log line from ``name`` (a logger name), with optional extra ``fields``."""

    KIND: ClassVar[str] = "log"
    TEMPLATE: ClassVar[str] = "{text}"

    text: str
    name: str = "harness"
    fields: tuple[tuple[str, Scalar], ...] = ()

    def __post_init__(self) -> None:
        clash = sorted(_RESERVED.intersection(k for k, _ in self.fields))
        if clash:
            raise ValueError(f"LogMessage fields may not be named {', '.join(clash)}")

    @staticmethod
    def of(
        *,
        step: int,
        sim_time_ns: int,
        robot: str,
        text: str,
        level: Level = Level.INFO,
        name: str = "harness",
        fields: Mapping[str, Scalar] | None = None,
    ) -> LogMessage:
        """Build one from a ``fields`` mapping."""
        return LogMessage(
            step=step,
            sim_time_ns=sim_time_ns,
            robot=robot,
            level=level,
            text=text,
            name=name,
            fields=tuple((fields or {}).items()),
        )

    def properties(self) -> dict[str, Any]:
        """Standard fields plus ``fields`` flattened in."""
        return {
            "step": self.step,
            "sim_time_ns": self.sim_time_ns,
            "robot": self.robot,
            "name": self.name,
            "text": self.text,
            **dict(self.fields),
        }

    def message(self) -> str:
        """The text itself (never formatted: it may contain braces)."""
        return self.text
