"""Names for every value of a MuJoCo state vector (``mj_getState`` with a given spec).

``mj_getState`` writes the components of the spec in ``mjtState`` bit order; each value is
named after what it belongs to: ``qpos``/``qvel``/``qacc_warmstart``/``qfrc_applied`` after the
joint (with the coordinate index for multi-coordinate joints), ``ctrl``/``act`` after the
actuator, ``xfrc_applied``/``mocap_*`` after the body, ``eq_active`` after the equality.
"""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

__all__ = ["StateLayout", "StateValue", "rotation_angle"]

_COMPONENTS = {
    "mjSTATE_TIME": "time",
    "mjSTATE_QPOS": "qpos",
    "mjSTATE_QVEL": "qvel",
    "mjSTATE_ACT": "act",
    "mjSTATE_HISTORY": "history",
    "mjSTATE_WARMSTART": "qacc_warmstart",
    "mjSTATE_CTRL": "ctrl",
    "mjSTATE_QFRC_APPLIED": "qfrc_applied",
    "mjSTATE_XFRC_APPLIED": "xfrc_applied",
    "mjSTATE_EQ_ACTIVE": "eq_active",
    "mjSTATE_MOCAP_POS": "mocap_pos",
    "mjSTATE_MOCAP_QUAT": "mocap_quat",
    "mjSTATE_USERDATA": "userdata",
    "mjSTATE_PLUGIN": "plugin_state",
    "mjSTATE_PLASTIC": "plastic",
}
_XFRC = ("fx", "fy", "fz", "tx", "ty", "tz")


class StateValue(NamedTuple):
    """One value of a state vector: its ``component`` (``"qpos"``, ...) and ``name``
    (``"joint2"``, ``"box_joint[3]"``, ``"link7.fz"``, ...)."""

    component: str
    name: str


def _name(model: mujoco.MjModel, obj: mujoco.mjtObj, index: int, kind: str) -> str:
    return mujoco.mj_id2name(model, obj, index) or f"{kind}{index}"


class StateLayout:
    """The component and name of every index of a ``spec`` state of ``model``."""

    def __init__(self, model: mujoco.MjModel, spec: int) -> None:
        self.model = model
        self.spec = spec
        self.slices: dict[str, slice] = {}
        offset = 0
        members = mujoco.mjtState.__members__
        for key, component in _COMPONENTS.items():
            bit = int(members[key]) if key in members else 0
            if not bit or not spec & bit:
                continue
            size = int(mujoco.mj_stateSize(model, bit))
            self.slices[component] = slice(offset, offset + size)
            offset += size
        self.size = offset
        self._joint_of_qpos = self._coordinates(model, qpos=True)
        self._joint_of_dof = self._coordinates(model, qpos=False)

    @staticmethod
    def _coordinates(model: mujoco.MjModel, *, qpos: bool) -> list[str]:
        size = model.nq if qpos else model.nv
        names = [""] * size
        for j in range(model.njnt):
            start = int(model.jnt_qposadr[j] if qpos else model.jnt_dofadr[j])
            jtype = int(model.jnt_type[j])
            if jtype == int(mujoco.mjtJoint.mjJNT_FREE):
                count = 7 if qpos else 6
            elif jtype == int(mujoco.mjtJoint.mjJNT_BALL):
                count = 4 if qpos else 3
            else:
                count = 1
            name = _name(model, mujoco.mjtObj.mjOBJ_JOINT, j, "joint")
            for i in range(count):
                names[start + i] = name if count == 1 else f"{name}[{i}]"
        return names

    def qpos_names(self) -> list[str]:
        """The joint coordinate named by each ``qpos`` index."""
        return list(self._joint_of_qpos)

    def dof_names(self) -> list[str]:
        """The joint coordinate named by each ``qvel`` index."""
        return list(self._joint_of_dof)

    def value(self, index: int) -> StateValue:
        """What index ``index`` of the state holds."""
        for component, where in self.slices.items():
            if where.start <= index < where.stop:
                return StateValue(component, self._element(component, index - where.start))
        raise IndexError(f"state index {index} is outside the layout ({self.size} values)")

    def _element(self, component: str, i: int) -> str:
        m = self.model
        if component == "time":
            return "time"
        if component == "qpos":
            return self._joint_of_qpos[i]
        if component in ("qvel", "qacc_warmstart", "qfrc_applied"):
            return self._joint_of_dof[i]
        if component in ("ctrl", "act"):
            act = (
                i
                if component == "ctrl"
                else int(np.searchsorted(m.actuator_actadr, i, "right") - 1)
            )
            return _name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, act, "actuator")
        if component == "xfrc_applied":
            body, axis = divmod(i, 6)
            return f"{_name(m, mujoco.mjtObj.mjOBJ_BODY, body, 'body')}.{_XFRC[axis]}"
        if component == "eq_active":
            return _name(m, mujoco.mjtObj.mjOBJ_EQUALITY, i, "equality")
        if component in ("mocap_pos", "mocap_quat"):
            width = 3 if component == "mocap_pos" else 4
            mocap, axis = divmod(i, width)
            bodies = np.flatnonzero(np.asarray(m.body_mocapid) == mocap)
            owner = (
                _name(m, mujoco.mjtObj.mjOBJ_BODY, int(bodies[0]), "body") if bodies.size else ""
            )
            return f"{owner or f'mocap{mocap}'}[{axis}]"
        return f"{component}[{i}]"


def rotation_angle(
    qa: npt.NDArray[np.float64], qb: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """The angle (rad) between unit quaternions (w-x-y-z, last axis), exactly 0 when equal:
    ``2 atan2(|v|, |w|)`` of the relative rotation ``conj(qa) * qb``."""
    aw, av = qa[..., :1], -qa[..., 1:]
    bw, bv = qb[..., :1], qb[..., 1:]
    w = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    v = aw * bv + bw * av + np.cross(av, bv)
    out: npt.NDArray[np.float64] = 2.0 * np.arctan2(np.linalg.norm(v, axis=-1), np.abs(w[..., 0]))
    return out
