"""The applied input of a step, captured from what a :class:`~harness.sim.Simulation` wrote
into MuJoCo before it: ``ctrl``, the kinematic writes (a planar base's included), mocap poses
and applied forces, as one :class:`~harness.sim.inputs.AppliedInput` (what is recorded and
replayed)."""

from __future__ import annotations

import mujoco
import numpy as np
import numpy.typing as npt

from harness.sim.inputs import AppliedInput
from harness.sim.planar import PlanarBase

__all__ = ["KinematicWrites", "capture_input"]

F64 = npt.NDArray[np.float64]
U32 = npt.NDArray[np.uint32]
KinematicWrites = tuple[U32, F64, U32, F64]
"""A step's kinematic writes: qpos addresses and values, dof addresses and values."""
_EMPTY_F: F64 = np.zeros(0, dtype=np.float64)
_EMPTY_U: U32 = np.zeros(0, dtype=np.uint32)


def capture_input(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    step: int,
    dt_ns: int,
    kinematic_joints: tuple[str, ...],
    kinematic: KinematicWrites | None,
    planar: PlanarBase | None,
    dt: float,
) -> AppliedInput:
    """The input of ``step`` (the next step): ``data``'s ctrl, mocap poses and applied forces
    (copies), and the ``kinematic`` writes (the arrays are kept; None: none) followed by
    ``planar``'s write for a step of ``dt`` from ``data.qpos``."""
    qpos_i, qpos_v, qvel_i, qvel_v = kinematic or (_EMPTY_U, _EMPTY_F, _EMPTY_U, _EMPTY_F)
    if planar is not None:
        # The planar base's write joins the kinematic writes (recorded, replayed alike).
        base_q, base_v = planar.write(data.qpos, dt)
        kinematic_joints = (*kinematic_joints, planar.joint)
        qpos_i = np.concatenate([qpos_i, planar.qpos_index])
        qpos_v = np.concatenate([qpos_v, base_q])
        qvel_i = np.concatenate([qvel_i, planar.qvel_index])
        qvel_v = np.concatenate([qvel_v, base_v])
    nmocap = model.nmocap
    qfrc = data.qfrc_applied
    xfrc = data.xfrc_applied
    return AppliedInput(
        step=step,
        sim_time_ns=step * dt_ns,
        ctrl=np.array(data.ctrl, dtype=np.float64),
        kinematic_joints=kinematic_joints,
        qpos_index=qpos_i,
        qpos_value=qpos_v,
        qvel_index=qvel_i,
        qvel_value=qvel_v,
        mocap_pos=np.array(data.mocap_pos, dtype=np.float64).ravel() if nmocap else _EMPTY_F,
        mocap_quat=np.array(data.mocap_quat, dtype=np.float64).ravel() if nmocap else _EMPTY_F,
        # count_nonzero: what any() says (-0.0 is zero, NaN is not), for less
        qfrc_applied=np.array(qfrc, dtype=np.float64) if np.count_nonzero(qfrc) else _EMPTY_F,
        xfrc_applied=(
            np.array(xfrc, dtype=np.float64).ravel() if np.count_nonzero(xfrc) else _EMPTY_F
        ),
    )
