"""Reading controller parameters and building the small messages controllers share."""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from typing import Any

from harness.controllers.config import ControllerSpec
from harness.controllers.errors import ControllersConfigError

__all__ = ["Params", "duration", "duration_ns", "point_msg", "stamp"]


def stamp(ns: int) -> dict[str, int]:
    """``builtin_interfaces/Time`` (or Duration) of ``ns`` nanoseconds."""
    sec, nanosec = divmod(ns, 1_000_000_000)
    return {"sec": sec, "nanosec": nanosec}


duration = stamp


def duration_ns(value: Mapping[str, Any]) -> int:
    """Nanoseconds of a ``builtin_interfaces`` Time or Duration dict."""
    return int(value["sec"]) * 1_000_000_000 + int(value["nanosec"])


def point_msg(
    positions: Sequence[float],
    velocities: Sequence[float] = (),
    accelerations: Sequence[float] = (),
    effort: Sequence[float] = (),
    time_from_start_ns: int = 0,
) -> dict[str, Any]:
    """A ``trajectory_msgs/msg/JointTrajectoryPoint``."""
    return {
        "positions": [float(v) for v in positions],
        "velocities": [float(v) for v in velocities],
        "accelerations": [float(v) for v in accelerations],
        "effort": [float(v) for v in effort],
        "time_from_start": duration(time_from_start_ns),
    }


class Params:
    """Typed access to one controller's parameters; errors name the controller and key."""

    def __init__(self, spec: ControllerSpec, source: str) -> None:
        self.spec = spec
        self.where = f"{source}: controller {spec.name!r} ({spec.type})"

    def error(self, text: str) -> ControllersConfigError:
        """A config error about this controller."""
        return ControllersConfigError(f"{self.where}: {text}")

    def get(self, key: str, default: Any = None) -> Any:
        """The raw value of ``key`` (``default`` when absent)."""
        return self.spec.params.get(key, default)

    def number(self, key: str, default: float, *, minimum: float | None = None) -> float:
        """A finite number (>= ``minimum``)."""
        value = self.spec.params.get(key, default)
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise self.error(f"{key} must be a number, not {value!r}")
        if minimum is not None and value < minimum:
            raise self.error(f"{key} must be >= {minimum:g}, not {value!r}")
        return float(value)

    def flag(self, key: str, default: bool) -> bool:
        """A boolean."""
        value = self.spec.params.get(key, default)
        if not isinstance(value, bool):
            raise self.error(f"{key} must be true or false, not {value!r}")
        return value

    def strings(self, key: str, default: Sequence[str] | None = None) -> tuple[str, ...]:
        """A list of strings (required when ``default`` is None)."""
        value = self.spec.params.get(key, default)
        if value is None:
            raise self.error(f"{key} is required")
        if not isinstance(value, list | tuple) or not all(isinstance(v, str) for v in value):
            raise self.error(f"{key} must be a list of names, not {value!r}")
        return tuple(value)

    def string(self, key: str, default: str | None = None) -> str:
        """A string (required when ``default`` is None)."""
        value = self.spec.params.get(key, default)
        if not isinstance(value, str) or not value:
            raise self.error(f"{key} must be a non-empty string, not {value!r}")
        return value

    def joints(self, names: Sequence[str], known: Collection[str]) -> tuple[str, ...]:
        """``names`` checked against the robot's controllable joints."""
        if not names:
            raise self.error("names no joints")
        for name in names:
            if name not in known and "/" in name:
                controller = name.partition("/")[0]
                raise self.error(
                    f"joint {name!r} is a reference interface of controller {controller!r}: "
                    "chained controllers are not supported by the harness"
                )
            if name not in known:
                raise self.error(
                    f"joint {name!r} is not a controllable joint of the robot "
                    f"(joints: {', '.join(sorted(known)) or 'none'})"
                )
        if len(set(names)) != len(names):
            raise self.error(f"names a joint twice: {', '.join(names)}")
        return tuple(names)
