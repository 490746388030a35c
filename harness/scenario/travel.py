"""Where each floating-base (mobile) robot started and ended: the ``returns_to_start``
criterion (a round trip ends within a radius of its start)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco

from harness.models import LoadedWorld
from harness.scenario.results import Verdict

__all__ = ["BaseTracker", "BaseTravel", "travel_verdict"]


@dataclass(frozen=True)
class BaseTravel:
    """A robot's base position (x, y in the world, metres) at the start and at the end."""

    robot: str
    start: tuple[float, float]
    end: tuple[float, float]

    @property
    def distance(self) -> float:
        """Horizontal distance between the end and the start."""
        return math.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1])


class BaseTracker:
    """The free joint of each floating-base robot of ``world``, its start read from ``data``."""

    def __init__(
        self, world: LoadedWorld | None, model: mujoco.MjModel, data: mujoco.MjData
    ) -> None:
        self._bases: list[tuple[str, int]] = []
        for view in world.robots if world is not None else ():
            if view.base != "floating":
                continue
            bodies = set(view.bodies.values())
            for j in range(model.njnt):
                free = model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
                if free and int(model.jnt_bodyid[j]) in bodies:
                    name = view.namespace or view.description.name
                    self._bases.append((name, int(model.jnt_qposadr[j])))
                    break
        self._start = [self._xy(data, adr) for _, adr in self._bases]

    @staticmethod
    def _xy(data: mujoco.MjData, adr: int) -> tuple[float, float]:
        return float(data.qpos[adr]), float(data.qpos[adr + 1])

    def travels(self, data: mujoco.MjData) -> tuple[BaseTravel, ...]:
        """Each floating base's start and its position in ``data`` now."""
        return tuple(
            BaseTravel(name, start, self._xy(data, adr))
            for (name, adr), start in zip(self._bases, self._start, strict=True)
        )


def travel_verdict(radius: float, travels: tuple[BaseTravel, ...]) -> Verdict:
    """``returns_to_start``: every floating base ended within ``radius`` of its start."""
    if not travels:
        return Verdict("returns_to_start", False, "no floating-base robot to judge")
    worst = max(travels, key=lambda t: t.distance)
    ok = worst.distance <= radius
    detail = (
        f"{worst.robot} ended {worst.distance:.3f} m from its start "
        f"({worst.end[0]:.3f}, {worst.end[1]:.3f}); allowed {radius:g} m"
    )
    return Verdict("returns_to_start", ok, detail)
