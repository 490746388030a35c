"""Errors of the rosbridge layer; each message is one line naming what is wrong and where."""

from __future__ import annotations

from harness.errors import BridgeError

__all__ = [
    "ClientError",
    "ConversionError",
    "ExposedServerWarning",
    "FrameError",
    "TypeNameError",
    "UnknownTypeError",
]


class FrameError(BridgeError):
    """An incoming frame cannot be processed (bad JSON, unknown op, missing or wrong field)."""


class TypeNameError(BridgeError):
    """A type string is not of the form ``pkg/Type`` or ``pkg/<kind>/Type``."""


class UnknownTypeError(BridgeError):
    """A well-formed type name that no registered definition provides."""


class ConversionError(BridgeError):
    """A JSON value does not match its ROS message definition (wrong type, extra field...)."""


class ClientError(BridgeError):
    """The client for an external rosbridge server could not connect or was closed."""


class ExposedServerWarning(UserWarning):
    """A server was asked to listen on a non-loopback address (reachable from other
    machines); issued once per server start."""
