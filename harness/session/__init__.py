"""The session: one run of a simulated robot on the rosbridge bridge (:class:`Session`), its
command topics (:mod:`harness.session.commands`) and ``harness serve``."""

from harness.session.commands import FORWARD_TOPICS, Trajectory
from harness.session.errors import (
    CommandRefused,
    SessionClosedError,
    SessionConfigError,
    SessionError,
    SimTimeoutError,
)
from harness.session.session import CLOCK_MODES, ClockMode, LoggerFactory, Session, SessionTopics

__all__ = [
    "CLOCK_MODES",
    "FORWARD_TOPICS",
    "ClockMode",
    "CommandRefused",
    "LoggerFactory",
    "Session",
    "SessionClosedError",
    "SessionConfigError",
    "SessionError",
    "SessionTopics",
    "SimTimeoutError",
    "Trajectory",
]
