"""Errors of :mod:`harness.sim`: all are :class:`~harness.errors.SimulationError`."""

from __future__ import annotations

from harness.errors import SimulationError

__all__ = [
    "CommandError",
    "ControlConfigError",
    "InstabilityError",
    "StateError",
    "TimestepError",
]


class TimestepError(SimulationError):
    """The model's timestep is not a whole, positive number of nanoseconds."""


class ControlConfigError(SimulationError):
    """The control mapping does not fit the model (unknown joint, missing or extra actuator,
    a mimic follower named as controllable, sleeping enabled)."""


class CommandError(SimulationError):
    """A joint command was refused (unknown joint, non-finite value); nothing was applied."""


class InstabilityError(SimulationError):
    """A step went wrong: a MuJoCo warning (BADQACC, auto-reset, ...) or time not matching
    ``step * dt``. ``step`` is the step that failed, ``warning`` the warning's name (or
    ``"TIME"``)."""

    def __init__(self, message: str, *, step: int, warning: str) -> None:
        super().__init__(message)
        self.step = step
        self.warning = warning


class StateError(SimulationError):
    """A state given to ``set_state`` does not fit the model or the step given."""
