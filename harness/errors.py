"""The error tree: every error the harness raises on purpose is a :class:`HarnessError`.

Each subpackage defines its own small subclasses (``harness.models.errors`` and so on); the
CLI turns any ``HarnessError`` into one line on stderr and exit code 2. Messages say what is
wrong and where (file, element, key path, step), in one line.
"""

from __future__ import annotations

__all__ = [
    "BridgeError",
    "ConfigError",
    "HarnessError",
    "ModelError",
    "RecordingError",
    "ReplayError",
    "SimulationError",
]


class HarnessError(Exception):
    """Base of every error the harness raises deliberately."""


class ModelError(HarnessError):
    """A robot description (URDF, SDF, MJCF, SRDF, mesh) cannot be loaded or built."""


class SimulationError(HarnessError):
    """The simulation became invalid (unstable step, time going backwards, refused edit)."""


class BridgeError(HarnessError):
    """The rosbridge server or client could not do what was asked."""


class RecordingError(HarnessError):
    """An MCAP recording cannot be written or read."""


class ReplayError(HarnessError):
    """A recording cannot be replayed or compared."""


class ConfigError(HarnessError):
    """A scenario, runner or plugin configuration is invalid."""
