"""The physics input applied at one step, as a record: what the simulation produces and the
recording stores and reads back (it mirrors ``harness_msgs/msg/AppliedInput``).

One type for one concept, in a neutral place: it imports only numpy, so reading a recording
does not load MuJoCo or the simulation. Applying it to MuJoCo is :mod:`harness.sim.inputs`
(which re-exports it from here).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from harness.bits import same_bits

__all__ = ["ARRAY_FIELDS", "AppliedInput"]

F64 = npt.NDArray[np.float64]
U32 = npt.NDArray[np.uint32]
_EMPTY_F64: F64 = np.zeros(0, np.float64)
_EMPTY_U32: U32 = np.zeros(0, np.uint32)
_EMPTY_F64.flags.writeable = False
_EMPTY_U32.flags.writeable = False


ARRAY_FIELDS = (
    "ctrl",
    "qpos_index",
    "qpos_value",
    "qvel_index",
    "qvel_value",
    "mocap_pos",
    "mocap_quat",
    "qfrc_applied",
    "xfrc_applied",
)


class AppliedInput(NamedTuple):
    """Everything the simulation wrote into MuJoCo for one step (fields as in
    ``harness_msgs/msg/AppliedInput``; float64 arrays, empty where unused).

    ``qpos_index``/``qpos_value`` and ``qvel_index``/``qvel_value`` are the kinematic writes
    (``kinematic_joints`` names the joints, mimic followers included, in the same order): they
    are written before the step *and again after it*, so kinematic joints report exactly the
    commanded position. ``qfrc_applied`` (nv) and ``xfrc_applied`` (nbody * 6) are empty when
    all zero; ``mocap_pos``/``mocap_quat`` are empty when the model has no mocap bodies.
    """

    step: int
    sim_time_ns: int
    ctrl: F64
    kinematic_joints: tuple[str, ...] = ()
    qpos_index: U32 = _EMPTY_U32
    qpos_value: F64 = _EMPTY_F64
    qvel_index: U32 = _EMPTY_U32
    qvel_value: F64 = _EMPTY_F64
    mocap_pos: F64 = _EMPTY_F64
    mocap_quat: F64 = _EMPTY_F64
    qfrc_applied: F64 = _EMPTY_F64
    xfrc_applied: F64 = _EMPTY_F64

    def same_physics(self, other: AppliedInput) -> bool:
        """True when both write exactly the same values, bit for bit (``step`` and time are
        ignored; ``-0.0`` differs from ``0.0``: MuJoCo keeps the sign in the state)."""
        if self.kinematic_joints != other.kinematic_joints:
            return False
        for f in ARRAY_FIELDS:
            a, b = getattr(self, f), getattr(other, f)
            if a is not b and not same_bits(a, b):  # often the very same (empty) array
                return False
        return True
