"""Support contacts: what a robot stands and rolls on, told apart from what it bumps into.

A contact of a body of a robot with a floating base (a mobile robot: a welded arm stands on
nothing) with something that is not a robot is a *support* contact when the
other side pushes the robot up (the contact normal, from the other side to the robot, within
:data:`SUPPORT_ANGLE_DEG` of the world's +z) and either

- the other side is a floor: a plane geom (a ground plane), or a geom of the world (welded to
  it) the robot rests on at the start, such as a floor mesh or a floor box; or
- the robot's side rolls: a wheel or a caster, a body turning on a hinge without limits (or
  limits a full turn apart or more), on a ball joint, or named ``*wheel*`` / ``*caster*``.

A bump into a wall, furniture or a pillar is never support (its normal is horizontal), also
when a wheel is driven into it; a base that drops onto a table top is not either (the table
is not a floor and the base does not roll). :class:`SupportClassifier` decides per contact,
vectorised over a step's :class:`~harness.sim.contacts.ContactSet`; the collision logger marks
an episode ``support`` when every contact of it was.
"""

from __future__ import annotations

import math
from collections.abc import Set

import mujoco
import numpy as np
import numpy.typing as npt

from harness.sim import ContactSet

__all__ = ["SUPPORT_ANGLE_DEG", "SupportClassifier", "floating_bodies", "rolling_bodies"]

SUPPORT_ANGLE_DEG = 30.0
"""The most a support contact's normal leaves the vertical (degrees)."""
_COS = math.cos(math.radians(SUPPORT_ANGLE_DEG))
_ROLL_NAMES = ("wheel", "caster")
_BALL = int(mujoco.mjtJoint.mjJNT_BALL)
_HINGE = int(mujoco.mjtJoint.mjJNT_HINGE)


def floating_bodies(model: mujoco.MjModel) -> npt.NDArray[np.bool_]:
    """Per body: in the tree of a floating base (a free joint at its root)."""
    root = np.asarray(model.body_rootid, dtype=np.int64)
    free = np.zeros(model.nbody, dtype=bool)
    for b in range(model.nbody):
        j = int(model.body_jntadr[b])
        free[b] = j >= 0 and int(model.jnt_type[j]) == mujoco.mjtJoint.mjJNT_FREE
    return free[root]


def rolling_bodies(model: mujoco.MjModel) -> npt.NDArray[np.bool_]:
    """Per body: a wheel or a caster (see the module docstring)."""
    raw: bytes = model.names
    rolls = np.array(
        [
            any(
                word in raw[a : raw.index(b"\0", a)].decode().rpartition("/")[2].lower()
                for word in _ROLL_NAMES
            )
            for a in model.name_bodyadr.tolist()
        ],
        dtype=bool,
    ).reshape(-1)
    kind = np.asarray(model.jnt_type)
    low, high = np.asarray(model.jnt_range, dtype=np.float64).reshape(-1, 2).T
    endless = (np.asarray(model.jnt_limited) == 0) | (high - low >= 2 * math.pi)
    turning = (kind == _BALL) | ((kind == _HINGE) & endless)
    rolls[np.asarray(model.jnt_bodyid)[turning]] = True
    return rolls


class SupportClassifier:
    """Tells support contacts of ``robot`` bodies (ids) apart (see the module docstring).

    ``other_robots``: bodies of other robots (a contact with one is never support). The floors
    the robot rests on are learnt from the first step observed (:meth:`learn_floors`).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        robot: Set[int],
        other_robots: Set[int] = frozenset(),
    ) -> None:
        self.robot = np.zeros(model.nbody, dtype=bool)
        self.robot[list(robot)] = True
        self.not_world = self.robot.copy()
        self.not_world[list(other_robots)] = True
        self.robot &= floating_bodies(model)  # a welded arm stands on nothing
        rolls = rolling_bodies(model)
        body = np.asarray(model.geom_bodyid, dtype=np.int64)
        self._geom_rolls = rolls[body] & self.robot[body]
        static = np.asarray(model.body_weldid, dtype=np.int64)[body] == 0
        self._geom_static = static & ~self.not_world[body]
        plane = int(mujoco.mjtGeom.mjGEOM_PLANE)  # an int: an array compares to an enum slowly
        self.floor = (np.asarray(model.geom_type) == plane) & ~self.robot[body]
        self._learnt = False
        self._last: (
            tuple[tuple[bytes, bytes], npt.NDArray[np.bool_], npt.NDArray[np.bool_], bool] | None
        ) = None

    def learn_floors(self, contacts: ContactSet) -> None:
        """Once: the world's static geoms the robot rests on in ``contacts`` are floors."""
        if self._learnt:
            return
        self._learnt = True
        self._last = None
        if contacts.size == 0:
            return
        up, _, other_geom, relevant = self._sides(contacts)
        resting = relevant & (up >= _COS) & self._geom_static[other_geom]
        self.floor[other_geom[resting]] = True

    def support(self, contacts: ContactSet) -> npt.NDArray[np.bool_]:
        """Per contact: a support contact of the robot (False for every other contact)."""
        if contacts.size == 0:
            return np.zeros(0, dtype=bool)
        # What depends on the geoms alone is kept while a step's geoms are the last step's.
        geoms = (contacts.geom1.tobytes(), contacts.geom2.tobytes())
        last = self._last
        if last is None or last[0] != geoms:
            robot2 = self.robot[contacts.body2]
            relevant = self._relevant(contacts)
            g1 = contacts.geom1.astype(np.int64)
            g2 = contacts.geom2.astype(np.int64)
            robot_geom = np.where(robot2, g2, g1)
            other_geom = np.where(robot2, g1, g2)
            candidate = relevant & (self.floor[other_geom] | self._geom_rolls[robot_geom])
            last = self._last = (geoms, robot2, candidate, bool(candidate.any()))
        _, robot2, candidate, any_candidate = last
        if not any_candidate:
            return np.zeros(contacts.size, dtype=bool)
        nz = contacts.normal[:, 2]  # from geom1 to geom2
        found: npt.NDArray[np.bool_] = candidate & (np.where(robot2, nz, -nz) >= _COS)
        return found

    def _relevant(self, contacts: ContactSet) -> npt.NDArray[np.bool_]:
        """Per contact: one of a robot body and a non-robot body."""
        relevant: npt.NDArray[np.bool_] = (
            self.robot[contacts.body1] & ~self.not_world[contacts.body2]
        ) | (self.robot[contacts.body2] & ~self.not_world[contacts.body1])
        return relevant

    def _sides(
        self, contacts: ContactSet
    ) -> tuple[
        npt.NDArray[np.float64],
        npt.NDArray[np.int64],
        npt.NDArray[np.int64],
        npt.NDArray[np.bool_],
    ]:
        """The normal's z from the other side to the robot, the robot's and the other geom,
        and whether the contact is one of a robot body and a non-robot body."""
        robot2 = self.robot[contacts.body2]
        relevant = self._relevant(contacts)
        nz = contacts.normal[:, 2]  # from geom1 to geom2
        up = np.where(robot2, nz, -nz)
        g1 = contacts.geom1.astype(np.int64)
        g2 = contacts.geom2.astype(np.int64)
        robot_geom = np.where(robot2, g2, g1)
        other_geom = np.where(robot2, g1, g2)
        return up, robot_geom, other_geom, relevant
