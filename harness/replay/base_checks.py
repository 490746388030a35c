"""What a base re-run measures beside the path (:mod:`harness.replay.base_resim`): wheel slip
(the distance the wheel encoders count against the distance the base truly travelled) and the
robot's contacts with the world other than the floor, per run, so that collisions appearing or
disappearing between the recorded and the re-run base are named."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np
import numpy.typing as npt

__all__ = ["contact_pairs", "encoder_distance", "robot_bodies"]

F64 = npt.NDArray[np.float64]


def encoder_distance(
    model: mujoco.MjModel, qpos: F64, wheels: Sequence[str], radius: float
) -> float | None:
    """The distance the wheels' encoders count over the rows of ``qpos``: the wheel radius
    times the mean of the wheels' rotation, summed step by step as a magnitude (a diff drive's
    odometry distance). None when a wheel is not a joint of ``model``."""
    columns = []
    for wheel in wheels:
        try:
            columns.append(int(model.jnt_qposadr[model.joint(wheel).id]))
        except KeyError:
            return None
    if not columns or len(qpos) < 2:
        return None
    turn = np.diff(qpos[:, columns], axis=0).mean(axis=1)
    return float(np.abs(turn).sum() * radius)


def robot_bodies(model: mujoco.MjModel, free_joint: str) -> frozenset[int]:
    """The bodies of the robot whose floating base is ``free_joint`` (its subtree)."""
    root = int(model.jnt_bodyid[model.joint(free_joint).id])
    return frozenset(b for b in range(model.nbody) if int(model.body_rootid[b]) == root)


def contact_pairs(model: mujoco.MjModel, qpos: F64, robot: frozenset[int]) -> set[tuple[str, str]]:
    """(robot body, other body) pairs in contact in any row of ``qpos``, floor contacts (a
    plane geom) left out."""
    data = mujoco.MjData(model)
    plane = int(mujoco.mjtGeom.mjGEOM_PLANE)
    pairs: set[tuple[str, str]] = set()
    for row in qpos:
        data.qpos[:] = row
        mujoco.mj_forward(model, data)
        for c in data.contact[: data.ncon]:
            g1, g2 = int(c.geom1), int(c.geom2)
            if plane in (int(model.geom_type[g1]), int(model.geom_type[g2])):
                continue
            b1, b2 = int(model.geom_bodyid[g1]), int(model.geom_bodyid[g2])
            if (b1 in robot) == (b2 in robot):
                continue
            mine, other = (b1, b2) if b1 in robot else (b2, b1)
            pairs.add((model.body(mine).name, model.body(other).name))
    return pairs
