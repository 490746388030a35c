"""harness.events: the logger interface, the collision and joint loggers, and sinks.

After each step the session builds a :class:`StepContext` (``StepContext.of(sim, robot)``)
and calls :meth:`EventHub.observe`; the hub runs every due :class:`Logger` and hands their
typed events to every :class:`~harness.events.sinks.Sink`. At the end of the run
:meth:`EventHub.finish` closes open episodes and :meth:`EventHub.close` returns one
:class:`~harness.events.sinks.SinkReport` per sink (delivered and dropped counts).
"""

from __future__ import annotations

from harness.events.clearance import Clearance, ClearanceLogger
from harness.events.collision import CollisionLogger
from harness.events.config import (
    LOGGING_SCHEMA,
    LoggingConfig,
    SinkSpec,
    logging_config_from_scene,
)
from harness.events.errors import LoggerConfigError, SinkError
from harness.events.events import (
    CollisionBegin,
    CollisionEnd,
    Event,
    JointLimitViolation,
    JointSample,
    Level,
    LogMessage,
    NearMiss,
    VelocityLimitExceeded,
)
from harness.events.joints import (
    JointLimitLogger,
    JointLogger,
    index_of,
    solver_limit_tolerance,
    velocity_limits,
)
from harness.events.logger import EventHub, Logger, StepContext, period_ns_from_hz
from harness.events.sinks import (
    CollectingSink,
    JsonLinesSink,
    LoggingSink,
    RecordingSink,
    SeqSink,
    Sink,
    SinkReport,
    available_sinks,
    create_sink,
)

__all__ = [
    "LOGGING_SCHEMA",
    "Clearance",
    "ClearanceLogger",
    "CollectingSink",
    "CollisionBegin",
    "CollisionEnd",
    "CollisionLogger",
    "Event",
    "EventHub",
    "JointLimitLogger",
    "JointLimitViolation",
    "JointLogger",
    "JointSample",
    "JsonLinesSink",
    "Level",
    "LogMessage",
    "Logger",
    "LoggerConfigError",
    "LoggingConfig",
    "LoggingSink",
    "NearMiss",
    "RecordingSink",
    "SeqSink",
    "Sink",
    "SinkError",
    "SinkReport",
    "SinkSpec",
    "StepContext",
    "VelocityLimitExceeded",
    "available_sinks",
    "create_sink",
    "index_of",
    "logging_config_from_scene",
    "period_ns_from_hz",
    "solver_limit_tolerance",
    "velocity_limits",
]
