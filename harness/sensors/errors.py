"""Errors of the sensors; each message is one line naming the sensor (or file) and what is wrong."""

from __future__ import annotations

from harness.errors import ConfigError, HarnessError

__all__ = ["RenderBackendError", "SensorConfigError", "SensorError", "UnknownSensorType"]


class SensorError(HarnessError):
    """A simulated sensor could not do what was asked."""


class SensorConfigError(SensorError, ConfigError):
    """An invalid sensor declaration (robot file, world file, scenario or Python)."""


class RenderBackendError(SensorError):
    """No offscreen OpenGL back-end (EGL or OSMesa) could be initialised for a camera."""


class UnknownSensorType(SensorConfigError):
    """A sensor type no module of the sensors room registers; the message names it and the
    known types."""
