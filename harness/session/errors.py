"""Errors of the session; each message is one line naming what is wrong and where."""

from __future__ import annotations

from harness.controllers import CommandRefused
from harness.errors import ConfigError, HarnessError

__all__ = [
    "ClientTimeoutError",
    "CommandRefused",
    "SessionClosedError",
    "SessionConfigError",
    "SessionError",
    "SimTimeoutError",
]


class SessionError(HarnessError):
    """A session could not do what was asked."""


class SessionConfigError(SessionError, ConfigError):
    """An invalid session option (clock mode, rate, topic name, namespace...)."""


class SessionClosedError(SessionError):
    """The session is closed (or its simulation failed) and can no longer run."""


class SimTimeoutError(SessionError):
    """A condition did not hold within its simulation-time budget."""


class ClientTimeoutError(SessionError):
    """No client connected within the wall-clock readiness timeout."""
