"""A planar (holonomic) base: a floating base moved kinematically by a commanded body velocity,
like Gazebo's planar move plugin, as a recorded write.

Each step the free joint's pose is advanced by the command (``linear_x``, ``linear_y`` in the
base's heading frame, ``angular_z`` about the world z axis); height, roll and pitch are kept.
The new ``qpos`` (7) and ``qvel`` (6) are the step's kinematic write for that joint, so they go
into the step's :class:`~harness.sim.inputs.AppliedInput` like kinematic joint writes and
replay applies them bit for bit.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import numpy.typing as npt

from harness.sim.errors import CommandError, ControlConfigError

__all__ = ["PlanarBase"]

F64 = npt.NDArray[np.float64]
U32 = npt.NDArray[np.uint32]


class PlanarBase:
    """The write for one free joint driven as a planar base (see the module docstring)."""

    def __init__(self, model: mujoco.MjModel, joint: str | None = None) -> None:
        free = [
            j
            for j in range(model.njnt)
            if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE)
        ]
        if joint is not None:
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
            if jid not in free:
                raise ControlConfigError(f"planar base: {joint!r} is not a free joint of the model")
        elif free:
            jid = free[0]
        else:
            raise ControlConfigError("planar base: the model has no floating base (free joint)")
        self.joint = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, jid) or f"joint{jid}"
        qadr, dadr = int(model.jnt_qposadr[jid]), int(model.jnt_dofadr[jid])
        self.qpos_index: U32 = np.arange(qadr, qadr + 7, dtype=np.uint32)
        self.qvel_index: U32 = np.arange(dadr, dadr + 6, dtype=np.uint32)
        self.velocity = (0.0, 0.0, 0.0)

    def command(self, linear_x: float, linear_y: float, angular_z: float) -> None:
        """Set the body velocity (m/s, m/s, rad/s); it holds until changed."""
        values = (float(linear_x), float(linear_y), float(angular_z))
        if not all(math.isfinite(v) for v in values):
            raise CommandError(f"planar base {self.joint!r}: non-finite velocity {values!r}")
        self.velocity = values

    @property
    def moving(self) -> bool:
        """Whether the command is non-zero."""
        return any(v != 0.0 for v in self.velocity)

    def write(self, qpos: F64, dt: float) -> tuple[F64, F64]:
        """The joint's ``qpos`` and ``qvel`` after one step of ``dt`` from ``qpos`` (the whole
        model's current positions)."""
        pose = np.array(qpos[self.qpos_index], dtype=np.float64)
        vx, vy, wz = self.velocity
        quat = pose[3:7]
        yaw = math.atan2(
            2.0 * (quat[0] * quat[3] + quat[1] * quat[2]),
            1.0 - 2.0 * (quat[2] * quat[2] + quat[3] * quat[3]),
        )
        cos, sin = math.cos(yaw), math.sin(yaw)
        world_x = vx * cos - vy * sin
        world_y = vx * sin + vy * cos
        pose[0] += world_x * dt
        pose[1] += world_y * dt
        turn = np.array([math.cos(wz * dt / 2), 0.0, 0.0, math.sin(wz * dt / 2)])
        new_quat = np.empty(4, dtype=np.float64)
        mujoco.mju_mulQuat(new_quat, turn, quat)
        mujoco.mju_normalize4(new_quat)
        pose[3:7] = new_quat
        # Free joint: linear velocity in the world frame, angular in the body frame.
        rot = np.empty(9, dtype=np.float64)
        mujoco.mju_quat2Mat(rot, new_quat)
        body_w = rot.reshape(3, 3).T @ np.array([0.0, 0.0, wz])
        qvel = np.array([world_x, world_y, 0.0, *body_w], dtype=np.float64)
        return pose, qvel
