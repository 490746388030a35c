"""Placing a robot on the floor, and what touches at the start.

A fixed robot whose links would reach through the floor in its initial configuration is lifted
until nothing penetrates (plus :data:`CLEARANCE`); a floating robot is set down with its lowest
collision point on the floor. Distances are MuJoCo's own (``mj_geomDistance`` between each of
the robot's colliding geoms and each floor plane of the scene). Contacts still present at the
start are listed by :func:`start_contacts` so the loader can report them once.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

__all__ = ["CLEARANCE", "StartContact", "floor_gap", "start_contacts"]

CLEARANCE = 1e-3
"""Metres left between a lifted fixed robot and the floor."""
_FAR = 100.0


def _floors(model: mujoco.MjModel) -> list[int]:
    """Plane geoms fixed to the world that collide: the scene's floors (an SDF world's ground
    plane is a static model's link, a body welded to the world)."""
    return [
        g
        for g in range(model.ngeom)
        if model.body_weldid[model.geom_bodyid[g]] == 0
        and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE
        and (model.geom_contype[g] or model.geom_conaffinity[g])
    ]


def floor_gap(
    model: mujoco.MjModel, qpos: npt.NDArray[np.float64], bodies: Iterable[int]
) -> float | None:
    """The smallest signed distance between the colliding geoms of ``bodies`` and the
    scene's floor planes at ``qpos`` (negative: penetration); None without a floor or geoms."""
    floors = _floors(model)
    body_set = set(bodies)
    geoms = [
        g
        for g in range(model.ngeom)
        if int(model.geom_bodyid[g]) in body_set
        and (model.geom_contype[g] or model.geom_conaffinity[g])
    ]
    if not floors or not geoms:
        return None
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    fromto = np.zeros(6)
    gap = _FAR
    for floor in floors:
        for geom in geoms:
            gap = min(gap, float(mujoco.mj_geomDistance(model, data, floor, geom, _FAR, fromto)))
    return gap if gap < _FAR else None


class StartContact(NamedTuple):
    """A contact present in the initial configuration: the two bodies and the depth (m)."""

    body1: str
    body2: str
    depth: float

    def __str__(self) -> str:
        return f"{self.body1} / {self.body2} {self.depth * 1000:.1f} mm"


def start_contacts(model: mujoco.MjModel, qpos: npt.NDArray[np.float64]) -> list[StartContact]:
    """Penetrating contacts at ``qpos``, deepest per body pair, deepest first."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    mujoco.mj_collision(model, data)
    deepest: dict[tuple[int, int], float] = {}
    for i in range(int(data.ncon)):
        contact = data.contact[i]
        if contact.exclude or contact.dist >= 0.0:
            continue
        b1, b2 = (int(model.geom_bodyid[g]) for g in contact.geom)
        key = (min(b1, b2), max(b1, b2))
        deepest[key] = max(deepest.get(key, 0.0), -float(contact.dist))
    found = [
        StartContact(model.body(a).name or "world", model.body(b).name or "world", depth)
        for (a, b), depth in deepest.items()
    ]
    return sorted(found, key=lambda c: (-c.depth, c.body1, c.body2))
