"""Pose queries of a :class:`~harness.sim.Simulation`: every body's world pose for the current
state, computed by forward kinematics in a scratch ``MjData`` (the simulation's own data is
never touched between steps)."""

from __future__ import annotations

import mujoco
import numpy as np
import numpy.typing as npt

from harness.sim.layout import object_name

__all__ = ["BodyPoses"]

F64 = npt.NDArray[np.float64]


class BodyPoses:
    """The world poses of a model's bodies, read from a state (``MjData``) on demand."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.named = tuple(
            (b, n)
            for b in range(1, model.nbody)
            if (n := object_name(model, mujoco.mjtObj.mjOBJ_BODY, b))
        )
        """``(body id, name)`` of every named body but the world."""
        self._scratch: mujoco.MjData | None = None

    def read(self, data: mujoco.MjData) -> tuple[F64, F64]:
        """Every body's world position (``nbody x 3``) and orientation (``nbody x 4``, w-x-y-z)
        in ``data``'s state, by body id: arrays reused by the next call."""
        if self._scratch is None:
            self._scratch = mujoco.MjData(self.model)
        scratch = self._scratch
        scratch.qpos[:] = data.qpos
        if self.model.nmocap:
            scratch.mocap_pos[:] = data.mocap_pos
            scratch.mocap_quat[:] = data.mocap_quat
        mujoco.mj_kinematics(self.model, scratch)
        return scratch.xpos, scratch.xquat

    def by_name(self, data: mujoco.MjData) -> dict[str, tuple[F64, F64]]:
        """Every named body's world pose in ``data``'s state as ``(xyz, quat w-x-y-z)``
        (copies)."""
        xpos, xquat = self.read(data)
        return {n: (xpos[b].copy(), xquat[b].copy()) for b, n in self.named}
