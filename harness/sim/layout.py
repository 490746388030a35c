"""How a :class:`~harness.sim.Simulation` lays a control map onto a compiled model, checked.

:func:`check_run_layout` checks what the whole run depends on (a timestep of whole nanoseconds, no
sleeping bodies, an initial keyframe at time 0). :func:`build_layout` turns ``control`` (joint
name -> mode) into a :class:`JointLayout`: one row per controllable joint with its addresses,
actuator and command range, and the kinematic writes (the kinematic joints, then the mimic
followers of those joints). Bad input raises
:class:`~harness.sim.errors.ControlConfigError` (or
:class:`~harness.sim.errors.TimestepError`) naming the joint, actuator or option.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import EllipsisType
from typing import NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models.description import CONTROL_MODES, ControlMode, RobotModel
from harness.sim.errors import ControlConfigError, TimestepError
from harness.vocabulary import LimitPolicy

__all__ = [
    "Follow",
    "JointLayout",
    "WriteKey",
    "build_layout",
    "check_run_layout",
    "kinematic_targets",
    "object_name",
    "write_target",
]

F64 = npt.NDArray[np.float64]
WriteKey = EllipsisType | npt.NDArray[np.intp]
"""The key of :func:`write_target`'s ``target[key] = values``."""
Follow = tuple[int, float, float, float, float, float, float, float]
"""One mimic follower's write: its slot in the kinematic positions, leader_ref, follower_ref
and the mimic law's coefficients c0..c4."""
_Coef = tuple[float, float, float, float, float]


def object_name(model: mujoco.MjModel, obj: mujoco.mjtObj, index: int) -> str:
    """The name of MuJoCo object ``index`` of type ``obj`` (``""`` when unnamed)."""
    return mujoco.mj_id2name(model, obj, index) or ""


def check_run_layout(model: mujoco.MjModel, keyframe: str | None) -> tuple[float, int, int]:
    """``(dt, dt_ns, keyframe id)`` of a model fit to simulate (keyframe id -1: ``qpos0``)."""
    dt = float(model.opt.timestep)
    dt_ns = round(dt * 1e9)
    if dt_ns <= 0 or dt_ns / 1e9 != dt:
        raise TimestepError(
            f"model timestep {dt!r} s is not a whole number of nanoseconds "
            f"(sim_time_ns = step * dt_ns needs one; e.g. {max(dt_ns, 1) / 1e9!r})"
        )
    if int(model.opt.enableflags) & int(mujoco.mjtEnableBit.mjENBL_SLEEP):
        raise ControlConfigError(
            "the model enables sleeping (option/flag sleep): sleeping bodies break state "
            "restore, disable it"
        )
    key = -1
    if keyframe is not None:
        key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe)
        if key < 0 and keyframe != "home":
            raise ControlConfigError(f"the model has no keyframe {keyframe!r}")
        if key >= 0 and float(model.key_time[key]) != 0.0:
            raise ControlConfigError(
                f"keyframe {keyframe!r} has time {float(model.key_time[key])!r}: "
                "the initial state must be at time 0"
            )
    return dt, dt_ns, key


@dataclass(frozen=True, eq=False)
class JointLayout:
    """The controllable joints (rows, in ``control``'s order) and the kinematic writes."""

    names: tuple[str, ...]
    modes: tuple[ControlMode, ...]
    qadr: npt.NDArray[np.intp]
    """Per row: the joint's ``qpos`` address."""
    dadr: npt.NDArray[np.intp]
    """Per row: the joint's dof (``qvel``) address."""
    lows: tuple[float, ...]
    """Per row: the lower end of the command range of the mode's field."""
    highs: tuple[float, ...]
    is_kin: npt.NDArray[np.bool_]
    kin_rows: npt.NDArray[np.intp]
    dyn_rows: npt.NDArray[np.intp]
    dyn_act: npt.NDArray[np.intp]
    """The actuator of each of ``dyn_rows``."""
    kin_names: tuple[str, ...]
    """The joints written kinematically: the kinematic rows', then their mimic followers'."""
    kin_qadr: npt.NDArray[np.uint32]
    kin_dadr: npt.NDArray[np.uint32]
    kin_gather: npt.NDArray[np.intp]
    """The rows whose commands give the kinematic writes' positions: each kinematic row, then
    each follower's leader's (turned into the follower's by the mimic law, see ``follow``)."""
    follow: tuple[Follow, ...]


class _Mimic(NamedTuple):
    leader_row: int  # index into the kinematic leaders
    qpos_adr: int
    dof_adr: int
    name: str
    coef: _Coef
    follower_ref: float
    leader_ref: float


def build_layout(
    model: mujoco.MjModel,
    control: Mapping[str, ControlMode],
    description: RobotModel | None,
    kinematic_limits: LimitPolicy,
) -> JointLayout:
    """The layout of ``control`` on ``model``: dynamic joints need exactly one joint actuator
    of the matching kind, kinematic joints none, mimic followers are not commanded."""
    actuators: dict[int, list[int]] = {}
    for act in range(model.nu):
        if int(model.actuator_trntype[act]) == int(mujoco.mjtTrn.mjTRN_JOINT):
            actuators.setdefault(int(model.actuator_trnid[act][0]), []).append(act)
    mimics = _mimic_equalities(model)

    names: list[str] = []
    modes: list[ControlMode] = []
    qadr: list[int] = []
    dadr: list[int] = []
    act_of: list[int] = []
    lows: list[float] = []
    highs: list[float] = []
    for name, mode in control.items():
        if mode not in CONTROL_MODES:
            raise ControlConfigError(
                f"joint {name!r}: control mode {mode!r} is not one of {', '.join(CONTROL_MODES)}"
            )
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if jid < 0:
            raise ControlConfigError(f"control names joint {name!r}, which the model lacks")
        jtype = int(model.jnt_type[jid])
        if jtype not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            raise ControlConfigError(
                f"joint {name!r} is not a hinge or slide joint: it cannot be controlled"
            )
        if jid in mimics:
            lead = object_name(model, mujoco.mjtObj.mjOBJ_JOINT, mimics[jid][0])
            raise ControlConfigError(
                f"joint {name!r} mimics {lead!r} (joint equality): command {lead!r}"
            )
        acts = actuators.get(jid, [])
        act_names = ", ".join(
            repr(object_name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a)) for a in acts
        )
        if mode == "kinematic":
            if acts:
                raise ControlConfigError(
                    f"joint {name!r} is kinematic but actuator {act_names} drives it: "
                    "build the model without an actuator on kinematic joints"
                )
            act_of.append(-1)
        else:
            if len(acts) != 1:
                raise ControlConfigError(
                    f"joint {name!r} ({mode}) needs exactly one joint actuator, "
                    f"the model has {len(acts)}{': ' + act_names if acts else ''}"
                )
            kind = _actuator_kind(model, acts[0])
            if kind is not None and kind != mode:
                raise ControlConfigError(
                    f"joint {name!r} is to be {mode}-controlled but its actuator "
                    f"{act_names} is a {kind} actuator"
                )
            act_of.append(acts[0])
        lo, hi = _command_range(
            model, jid, acts[0] if acts else -1, name, mode, description, kinematic_limits
        )
        names.append(name)
        modes.append(mode)
        qadr.append(int(model.jnt_qposadr[jid]))
        dadr.append(int(model.jnt_dofadr[jid]))
        lows.append(lo)
        highs.append(hi)

    qadr_a = np.array(qadr, dtype=np.intp)
    dadr_a = np.array(dadr, dtype=np.intp)
    is_kin = np.array([m == "kinematic" for m in modes], dtype=bool)
    dyn_rows = np.flatnonzero(~is_kin)
    kin_rows = np.flatnonzero(is_kin)

    # Kinematic writes: the kinematic joints, then the mimic followers of those joints.
    leader_row = {int(qadr_a[r]): i for i, r in enumerate(kin_rows)}
    followers: list[_Mimic] = []
    for follower, (leader, coef) in sorted(mimics.items()):
        row = leader_row.get(int(model.jnt_qposadr[leader]))
        if row is not None:
            followers.append(
                _Mimic(
                    leader_row=row,
                    qpos_adr=int(model.jnt_qposadr[follower]),
                    dof_adr=int(model.jnt_dofadr[follower]),
                    name=object_name(model, mujoco.mjtObj.mjOBJ_JOINT, follower),
                    coef=coef,
                    follower_ref=float(model.qpos0[model.jnt_qposadr[follower]]),
                    leader_ref=float(model.qpos0[model.jnt_qposadr[leader]]),
                )
            )
    return JointLayout(
        names=tuple(names),
        modes=tuple(modes),
        qadr=qadr_a,
        dadr=dadr_a,
        lows=tuple(lows),
        highs=tuple(highs),
        is_kin=is_kin,
        kin_rows=kin_rows,
        dyn_rows=dyn_rows,
        dyn_act=np.array([act_of[r] for r in dyn_rows], dtype=np.intp),
        kin_names=tuple(names[r] for r in kin_rows) + tuple(f.name for f in followers),
        kin_qadr=np.array([*qadr_a[kin_rows], *(f.qpos_adr for f in followers)], dtype=np.uint32),
        kin_dadr=np.array([*dadr_a[kin_rows], *(f.dof_adr for f in followers)], dtype=np.uint32),
        kin_gather=np.array(
            [*kin_rows, *(kin_rows[f.leader_row] for f in followers)], dtype=np.intp
        ),
        follow=tuple(
            (kin_rows.size + i, f.leader_ref, f.follower_ref, *f.coef)
            for i, f in enumerate(followers)
        ),
    )


def write_target(array: F64, index: npt.NDArray[np.integer]) -> tuple[F64, WriteKey]:
    """Where ``array[index] = values`` writes, as ``(target, key)`` for ``target[key] =
    values``: a view and ``...`` when ``index`` is a run of consecutive addresses (the same
    elements, written for much less per step), else ``array`` and ``index``."""
    size = int(index.size)
    first = int(index[0]) if size else 0
    if np.array_equal(index, np.arange(first, first + size)):
        return array[first : first + size], ...
    return array, np.asarray(index, dtype=np.intp)


def kinematic_targets(cmd: F64, gather: npt.NDArray[np.intp], follow: tuple[Follow, ...]) -> F64:
    """A new array of the kinematic writes' positions from the commands ``cmd``: the
    kinematic rows', then the mimic followers' (``gather`` and ``follow`` of a
    :class:`JointLayout`; never changed in place afterwards: applied inputs share it)."""
    out: F64 = cmd[gather]  # fancy indexing: a new array
    for slot, leader_ref, follower_ref, c0, c1, c2, c3, c4 in follow:
        x = out.item(slot) - leader_ref
        out[slot] = follower_ref + c0 + x * (c1 + x * (c2 + x * (c3 + x * c4)))
    return out


def _actuator_kind(model: mujoco.MjModel, act: int) -> ControlMode | None:
    """The control mode an actuator implements, or None when it is not one of the three."""
    if int(model.actuator_dyntype[act]) != int(mujoco.mjtDyn.mjDYN_NONE):
        return None
    if int(model.actuator_gaintype[act]) != int(mujoco.mjtGain.mjGAIN_FIXED):
        return None
    gain = float(model.actuator_gainprm[act][0])
    bias = model.actuator_biasprm[act]
    biastype = int(model.actuator_biastype[act])
    if biastype == int(mujoco.mjtBias.mjBIAS_NONE):
        return ControlMode.EFFORT
    if biastype == int(mujoco.mjtBias.mjBIAS_AFFINE) and gain != 0.0 and bias[0] == 0.0:
        if bias[1] == -gain:
            return ControlMode.POSITION
        if bias[1] == 0.0 and bias[2] == -gain:
            return ControlMode.VELOCITY
    return None


def _mimic_equalities(model: mujoco.MjModel) -> dict[int, tuple[int, _Coef]]:
    """follower joint id -> (leader joint id, polynomial coefficients), from the active
    joint equalities (URDF ``<mimic>`` becomes one)."""
    out: dict[int, tuple[int, _Coef]] = {}
    for e in range(model.neq):
        if int(model.eq_type[e]) != int(mujoco.mjtEq.mjEQ_JOINT):
            continue
        if not model.eq_active0[e] or int(model.eq_obj2id[e]) < 0:
            continue
        c = [float(v) for v in model.eq_data[e][:5]]
        out[int(model.eq_obj1id[e])] = (int(model.eq_obj2id[e]), (c[0], c[1], c[2], c[3], c[4]))
    return out


def _command_range(
    model: mujoco.MjModel,
    jid: int,
    act: int,
    name: str,
    mode: ControlMode,
    description: RobotModel | None,
    kinematic_limits: LimitPolicy,
) -> tuple[float, float]:
    """The range a command of ``mode``'s field is clamped to: the model's limits (joint range,
    force range, the actuator's ctrlrange) and the description's (URDF velocity, effort)."""
    lo, hi = -math.inf, math.inf
    limits = None
    if description is not None:
        try:
            limits = description.joint(name).limits
        except KeyError:
            limits = None
    if mode == "position" or (mode == "kinematic" and kinematic_limits == "clamp"):
        if model.jnt_limited[jid]:
            lo, hi = float(model.jnt_range[jid][0]), float(model.jnt_range[jid][1])
    elif mode == "velocity":
        if limits is not None and limits.velocity:
            lo, hi = -abs(limits.velocity), abs(limits.velocity)
    elif mode == "effort":
        if model.jnt_actfrclimited[jid]:
            lo, hi = (float(v) for v in model.jnt_actfrcrange[jid])
        if limits is not None and limits.effort:
            lo, hi = max(lo, -abs(limits.effort)), min(hi, abs(limits.effort))
    if act >= 0 and model.actuator_ctrllimited[act]:
        lo = max(lo, float(model.actuator_ctrlrange[act][0]))
        hi = min(hi, float(model.actuator_ctrlrange[act][1]))
    return lo, hi
