"""Errors of :mod:`harness.events`."""

from __future__ import annotations

from harness.errors import ConfigError, HarnessError

__all__ = ["LoggerConfigError", "SinkError"]


class LoggerConfigError(ConfigError):
    """A logger, sink or ``logging`` section is configured wrongly (the message names the key)."""


class SinkError(HarnessError):
    """A sink cannot be created or written (file not writable, recorder refused an event)."""
