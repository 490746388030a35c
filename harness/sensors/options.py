"""A sensor kind's own options: the base of the records each kind module defines
(``CameraOptions`` in :mod:`~harness.sensors.camera`, ``LidarOptions``, ...).

An options record is a frozen dataclass of the fields only its kind reads, validated on
creation with one-line messages that name the field (the spec prefixes which sensor and file).
It sits below the registry and the spec in the room: it knows neither.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from harness.sensors.errors import SensorConfigError

__all__ = ["NoOptions", "SensorOptions", "check_finite", "check_integer", "check_positive"]


@dataclass(frozen=True)
class SensorOptions:
    """The base of a kind's options record: subclasses are frozen dataclasses whose
    ``__post_init__`` validates their fields (:class:`SensorConfigError`, one line naming the
    field and the value)."""

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The option names, in declaration order (the keys a mapping gives for this kind)."""
        return tuple(f.name for f in dataclasses.fields(cls))


@dataclass(frozen=True)
class NoOptions(SensorOptions):
    """The options of a kind that has none (``ground_truth``)."""


def check_positive(name: str, value: object, zero: bool = False) -> None:
    """``value`` is a finite number > 0 (``zero``: >= 0)."""
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value < 0 or (value == 0 and not zero):  # type: ignore[operator]
        bound = ">= 0" if zero else "> 0"
        raise SensorConfigError(f"{name} must be a number {bound}, not {value!r}")


def check_integer(name: str, value: object) -> None:
    """``value`` is an integer >= 1 (not a bool)."""
    if not isinstance(value, int) or isinstance(value, bool) or value < 1:
        raise SensorConfigError(f"{name} must be an integer >= 1, not {value!r}")


def check_finite(name: str, value: object) -> None:
    """``value`` is a finite number."""
    if not isinstance(value, int | float) or not math.isfinite(value):
        raise SensorConfigError(f"{name} must be a finite number, not {value!r}")
