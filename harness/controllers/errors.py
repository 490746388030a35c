"""Errors of the controllers; each message is one line naming what is wrong and where."""

from __future__ import annotations

from harness.errors import ConfigError, HarnessError

__all__ = [
    "CommandRefused",
    "ControllerError",
    "ControllersConfigError",
    "ControllersWarning",
    "UnknownControllerType",
]


class ControllerError(HarnessError):
    """A controller could not do what was asked."""


class ControllersConfigError(ControllerError, ConfigError):
    """An invalid controllers YAML (or a controller that does not fit the robot)."""


class CommandRefused(ControllerError):
    """A command message was refused; the message is the status text sent to its client."""


class UnknownControllerType(ControllerError):
    """A controller type no module of the controllers room registers; the message names it
    and the known types."""


class ControllersWarning(UserWarning):
    """Something of a robot's controllers set-up the harness leaves out (one line naming it)."""
