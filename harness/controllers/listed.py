"""Joints a robot lists on ``joint_states`` without controlling them: mimic followers (URDF
``<mimic>``) and passive joints.

A client that echoes ``joint_states`` into ``joint_command`` names them too. Such a name is
not refused: its value is dropped from the command, silently when it is consistent with what
the joint does anyway (a follower's mimic law applied to its leader's value in the same
message, or its leader's position now; a passive joint's position now), with one warning per
joint otherwise (the value cannot be applied). Names the robot does not list are still
refused (:mod:`harness.controllers.command_topics`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from harness.models import RobotModel
from harness.sim import Notice

__all__ = ["CONSISTENT", "ListedJoints"]

CONSISTENT = 1e-2
"""How far (rad or m) a listed joint's value may be from what it does anyway, unwarned."""


@dataclass(frozen=True)
class _Listed:
    name: str
    leader: str | None
    multiplier: float
    offset: float


class ListedJoints:
    """The joints of ``listed`` (a robot's ``joint_states`` names) that are not in
    ``controllable``, with their mimic law from ``description``."""

    def __init__(
        self, description: RobotModel, listed: Sequence[str], controllable: Sequence[str]
    ) -> None:
        control = set(controllable)
        self.order = tuple(listed)
        self.joints: dict[str, _Listed] = {}
        for name in listed:
            if name in control:
                continue
            try:
                mimic = description.joint(name).mimic
            except KeyError:
                mimic = None
            if mimic is None:
                self.joints[name] = _Listed(name, None, 1.0, 0.0)
            else:
                self.joints[name] = _Listed(name, mimic.joint, mimic.multiplier, mimic.offset)
        self.warned: set[str] = set()

    def strip(
        self, msg: Mapping[str, Any], positions: npt.NDArray[np.float64]
    ) -> tuple[Mapping[str, Any], list[Notice]]:
        """``msg`` (a ``sensor_msgs/msg/JointState`` command) without the listed joints, and
        a warning for each whose value is inconsistent the first time it is. ``positions``:
        the current positions of the ``joint_states`` joints (in :attr:`order`)."""
        names: list[str] = list(msg["name"])
        if not self.joints or not any(n in self.joints for n in names):
            return msg, []
        keep = [i for i, n in enumerate(names) if n not in self.joints]
        position: list[float] = list(msg["position"])
        now = dict(zip(self.order, positions.tolist(), strict=True))
        given = {names[i]: position[i] for i in range(min(len(names), len(position)))}
        notices: list[Notice] = []
        for name in names:
            joint = self.joints.get(name)
            if joint is None or name not in given or name in self.warned:
                continue
            if joint.leader is None:
                expected = now.get(name, math.nan)
                why = "a passive joint: it moves only with the robot"
            else:
                leader = given.get(joint.leader, now.get(joint.leader, math.nan))
                expected = joint.multiplier * leader + joint.offset
                why = f"it mimics {joint.leader!r}"
            value = float(given[name])
            if abs(value - expected) <= CONSISTENT:
                continue
            self.warned.add(name)
            notices.append(
                Notice(
                    name, "ignored", "position", value, math.nan,
                    f"joint {name!r} is not controllable ({why}): its value {value:g} is "
                    f"ignored (it is {expected:g} by that); said once",
                )
            )  # fmt: skip

        def pick(values: Sequence[Any]) -> list[Any]:
            return [values[i] for i in keep if i < len(values)]

        stripped = dict(msg)
        stripped["name"] = pick(names)
        for key in ("position", "velocity", "effort"):
            stripped[key] = pick(list(msg[key]))
        return stripped, notices
