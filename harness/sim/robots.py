"""One robot's joints in a :class:`~harness.sim.Simulation` of several robots, in its own names.

A simulation of a world (:class:`harness.models.LoadedWorld`) addresses joints by their MuJoCo
names, which carry the robot's prefix (``"left/joint1"``). :class:`RobotJoints` is the view a
session needs per robot: the robot's controllable joints in the simulation's order, named
without the prefix (``"joint1"``), their positions, velocities, efforts and commands, and
commands by those names. Unknown names are refused naming the robot's own joints; notices
name the robot's joints too. For a robot without prefix that owns every joint (the one-robot
case) every call goes straight to the simulation.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from types import MappingProxyType

import numpy as np
import numpy.typing as npt

from harness.models import ControlMode
from harness.sim.commands import Notice
from harness.sim.errors import CommandError
from harness.sim.simulation import Simulation

__all__ = ["RobotJoints"]

F64 = npt.NDArray[np.float64]


class RobotJoints:
    """The controllable joints of one robot of ``sim``: ``joints`` are the robot's own
    (unprefixed) names, ``prefix`` what turns them into MuJoCo names (``"<namespace>/"`` or
    ``""``). :attr:`joint_names` keeps the simulation's order (the order of forward commands
    and of every per-joint array here)."""

    def __init__(self, sim: Simulation, joints: Iterable[str], prefix: str = "") -> None:
        wanted = set(joints)
        index = {name: row for row, name in enumerate(sim.joint_names)}
        missing = sorted(j for j in wanted if prefix + j not in index)
        if missing:
            raise CommandError(
                f"robot {prefix.rstrip('/') or '(no namespace)'}: joints {missing} are not "
                "controllable joints of the simulation"
            )
        rows = [index[prefix + j] for j in wanted]
        rows.sort()
        self.sim = sim
        self.prefix = prefix
        self.joint_names: tuple[str, ...] = tuple(
            sim.joint_names[r].removeprefix(prefix) for r in rows
        )
        """The robot's controllable joints (unprefixed), in the simulation's order."""
        self.mujoco_names: tuple[str, ...] = tuple(sim.joint_names[r] for r in rows)
        """The same joints' MuJoCo names."""
        self.rows = np.array(rows, dtype=np.intp)
        """Each joint's index in the simulation's per-joint arrays."""
        self._known = frozenset(self.joint_names)
        self._whole = not prefix and self.joint_names == sim.joint_names
        modes = sim.control
        self.control: Mapping[str, ControlMode] = MappingProxyType(
            {name: modes[prefix + name] for name in self.joint_names}
        )
        """Joint (unprefixed) -> control mode."""

    def owns(self, mujoco_name: str) -> bool:
        """Whether ``mujoco_name`` is one of this robot's controllable joints."""
        return mujoco_name.startswith(self.prefix) and (
            mujoco_name.removeprefix(self.prefix) in self._known
        )

    # ----------------------------------------------------------------------------- reads

    def joint_positions(self) -> F64:
        """Positions of :attr:`joint_names`."""
        values = self.sim.joint_positions()
        return values if self._whole else values[self.rows]

    def joint_velocities(self) -> F64:
        """Velocities of :attr:`joint_names`."""
        values = self.sim.joint_velocities()
        return values if self._whole else values[self.rows]

    def joint_efforts(self) -> F64:
        """Efforts of :attr:`joint_names` (see :meth:`Simulation.joint_efforts`)."""
        values = self.sim.joint_efforts()
        return values if self._whole else values[self.rows]

    def joint_commands(self) -> F64:
        """Current commands of :attr:`joint_names`."""
        values = self.sim.joint_commands()
        return values if self._whole else values[self.rows]

    # ----------------------------------------------------------------------------- commands

    def _name(self, joint: str) -> str:
        if self._whole:
            return joint
        if joint not in self._known:
            known = ", ".join(self.joint_names) or "none"
            raise CommandError(f"unknown joint {joint!r} (controllable joints: {known})")
        return self.prefix + joint

    def _names(self, joints: Iterable[str]) -> list[str]:
        return [self._name(j) for j in joints]

    def _own(self, notices: list[Notice]) -> list[Notice]:
        if not self.prefix:
            return notices
        return [n._replace(joint=n.joint.removeprefix(self.prefix)) for n in notices]

    def _mapped(self, values: Mapping[str, float]) -> Mapping[str, float]:
        if self._whole:
            return values  # the simulation's own names (a command per step: no copy)
        return {self._name(j): v for j, v in values.items()}

    def command(
        self,
        joint: str,
        *,
        position: float | None = None,
        velocity: float | None = None,
        effort: float | None = None,
    ) -> list[Notice]:
        """:meth:`Simulation.command` of the robot's ``joint``."""
        return self._own(
            self.sim.command(self._name(joint), position=position, velocity=velocity, effort=effort)
        )

    def set_positions(self, positions: Mapping[str, float]) -> list[Notice]:
        """Position commands by the robot's joint names (all validated before any applies)."""
        return self._own(self.sim.set_positions(self._mapped(positions)))

    def set_velocities(self, velocities: Mapping[str, float]) -> list[Notice]:
        """Velocity commands by the robot's joint names."""
        return self._own(self.sim.set_velocities(self._mapped(velocities)))

    def set_efforts(self, efforts: Mapping[str, float]) -> list[Notice]:
        """Effort commands by the robot's joint names."""
        return self._own(self.sim.set_efforts(self._mapped(efforts)))

    def command_joint_state(
        self,
        name: Sequence[str],
        position: Sequence[float] = (),
        velocity: Sequence[float] = (),
        effort: Sequence[float] = (),
    ) -> list[Notice]:
        """:meth:`Simulation.command_joint_state` with the robot's joint names."""
        return self._own(
            self.sim.command_joint_state(self._names(name), position, velocity, effort)
        )
