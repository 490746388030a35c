"""Control modes and actuators: each controllable joint's mode from the ``control`` option,
one actuator per driven joint with default gains tuned for the joint's inertia and the
timestep, and the modes of an MJCF's own actuators.

A velocity joint tracks its command as Gazebo's velocity interface does (the joint is set to
the commanded speed, with no more than the effort limit), whatever the link's inertia and the
joint's damping (issue 34: DiffBot's wheels, Iyy 3e-5 kg m^2 and damping 0.2, reached 6 % of the
command). Three parts:

- a stiff servo: kv saturates the effort limit at a 0.2 rad/s error, so a load (a caster
  dragging, a slope) costs little speed (a tenth of the effort limit: 0.02 rad/s);
- the drive's rotor inertia (armature) for a joint whose file states none, enough for that kv:
  MuJoCo integrates a saturated actuator explicitly, and a kv above inertia / timestep then
  overshoots the command by more than it corrected and rings between the effort limits. So a
  saturated drive gains at most 0.2 rad/s per step, exactly that when the rotor outweighs the
  link (100 rad/s^2 at 2 ms; the effort limit still bounds it, Gazebo's would reach any speed
  within the limit in one step), and a drive within its limit reaches the command in a few
  steps, for any link inertia from 1e-6 to 1 kg m^2 (a joint whose file states an armature
  keeps it, and its kv stays capped at inertia / timestep);
- the joint's own damping overcome by the drive (gain kv + damping, bias -kv): the joint settles
  at the command instead of kv / (kv + damping) of it.

A world with velocity-driven joints also gets MuJoCo's no-slip pass on contact friction
(:data:`VELOCITY_NOSLIP_ITERATIONS`, unless the scene sets its own): MuJoCo's soft friction
otherwise creeps at a speed proportional to the traction force, which at DiffBot's 0.01 m/s
against its dragging casters lost 27 % of the distance; Gazebo's friction does not creep.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models.build.drives import COMMAND_FILTER_SECONDS
from harness.models.description import ControlMode, RobotModel
from harness.models.errors import ModelStructureError

__all__ = [
    "VELOCITY_NOSLIP_ITERATIONS",
    "add_actuators",
    "existing_control",
    "held_inertias",
    "resolve_control",
]

# Default gains: a position servo saturates its effort limit at this error, a velocity servo
# at this speed error; both are capped so that sqrt(kp / M) * dt <= 0.5 and kv * dt <= M,
# with M the joint's smallest effective inertia (other joints free: 1 / dof_invweight0).
# Reference: kp 2e4 critically damped tracked a Panda well, kp 1e6 was unstable.
#
# A position servo is critically damped for the inertia the joint sees when the other joints
# are held (the mass matrix diagonal, armature included, at the "home" keyframe or the zero
# configuration). Part of that damping is the drive's torque-speed limit, effort / velocity
# (a motor's torque falls linearly to zero at its no-load speed), put on the joint as
# damping so that it acts outside the actuator's force range: a saturated servo then runs at
# about the velocity limit and can brake, instead of reaching many times the limit and
# overshooting it (issue 2: joint7 reached 29x its velocity limit and 0.40 rad past its limit).
_POSITION_SATURATION_ERROR = 0.005
_VELOCITY_SATURATION_ERROR = 0.2
_DEFAULT_EFFORT = 100.0
_STABLE_OMEGA_DT = 0.5

VELOCITY_NOSLIP_ITERATIONS = 3
"""MuJoCo ``noslip_iterations`` of a world with velocity-driven joints (one already removes the
creep of DiffBot's wheels; three converge it)."""


def resolve_control(
    description: RobotModel,
    joint_names: set[str],
    control: ControlMode | str | Mapping[str, ControlMode | str],
    source: str,
) -> dict[str, ControlMode]:
    """Each controllable joint of ``description`` found in ``joint_names`` with its mode from
    ``control`` (one mode, or joint -> mode with ``"position"`` for the unlisted)."""
    controllable = [j.name for j in description.controllable_joints if j.name in joint_names]
    if isinstance(control, str):
        mode = _check_mode(control, "control")
        return dict.fromkeys(controllable, mode)
    unknown = sorted(set(control) - set(controllable))
    if unknown:
        raise ModelStructureError(
            f"{source}: control names joints that are not controllable joints of the robot: "
            f"{unknown} (controllable: {controllable})"
        )
    modes: dict[str, ControlMode] = {}
    for name in controllable:
        modes[name] = _check_mode(control.get(name, ControlMode.POSITION), f"control[{name!r}]")
    return modes


def _check_mode(mode: object, where: str) -> ControlMode:
    try:
        return ControlMode.parse(mode, where)
    except ValueError as exc:
        raise ModelStructureError(str(exc)) from None


def held_inertias(model: mujoco.MjModel, qpos: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Per dof, the inertia it sees with every other dof held: the mass matrix diagonal."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    # The diagonal straight from the sparse rows (the last entry of each lower-triangle row):
    # the dense nv x nv matrix was quadratic in the number of joints (200 MB at 5,000).
    diagonal: npt.NDArray[np.float64] = data.M[model.M_rowadr + model.M_rownnz - 1].copy()
    return diagonal


def _drive_armature(kp: float, inertia: float, dt: float) -> float:
    """The reflected rotor inertia a geared drive needs to servo at stiffness ``kp`` stably
    (``sqrt(kp / (inertia + armature)) * dt <= 0.5``), for a joint whose file states none:
    the link inertia alone (``inertia``, the smallest the joint sees) is what a motor without
    a gearbox would move. Real gearboxes reflect rotor inertia times the square of the ratio
    (0.01 to 1 kg m^2 for arm joints); 0 when the link inertia is already enough."""
    needed = kp / (_STABLE_OMEGA_DT / dt) ** 2
    return max(0.0, needed - inertia)


def add_actuators(
    spec: mujoco.MjSpec,
    model: mujoco.MjModel,
    description: RobotModel,
    modes: Mapping[str, ControlMode],
    gains: Mapping[str, float],
    held_inertia: npt.NDArray[np.float64],
    prefix: str = "",
) -> tuple[str, ...]:
    """One actuator per non-kinematic joint of ``modes`` (unprefixed names), named after its
    MuJoCo joint ``prefix + name``; returns the actuated joints (unprefixed) in order."""
    dt = float(model.opt.timestep)
    actuated = []
    for name, mode in modes.items():
        if mode == "kinematic":
            continue
        joint = description.joint(name)
        limits = joint.limits
        effort = limits.effort if limits.effort is not None and limits.effort > 0 else None
        mj_name = prefix + name
        dof = int(model.jnt_dofadr[model.joint(mj_name).id])
        # the smallest effective inertia (other joints free to move): the stability bound
        inertia = 1.0 / float(model.dof_invweight0[dof])
        act = spec.add_actuator(name=mj_name, target=mj_name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        if mode == "position":
            kp = gains.get(name)
            spec_joint = spec.joint(mj_name)
            held_dof = float(held_inertia[dof])
            if kp is None:
                kp = (effort or _DEFAULT_EFFORT) / _POSITION_SATURATION_ERROR
                added = _drive_armature(kp, inertia, dt) if spec_joint.armature == 0 else 0.0
                if added > 0.0:
                    spec_joint.armature = added
                    inertia += added
                    held_dof += added
                kp = min(kp, inertia * (_STABLE_OMEGA_DT / dt) ** 2)
            damping = float(spec_joint.damping[0])
            if effort is not None and limits.velocity is not None and limits.velocity > 0:
                damping += effort / limits.velocity
                spec_joint.damping = [damping, *spec_joint.damping[1:]]
            critical = 2.0 * float(np.sqrt(kp * held_dof))
            act.set_to_position(
                kp=float(kp), kv=max(critical - damping, 0.0), timeconst=COMMAND_FILTER_SECONDS
            )
            act.actearly = True  # the force uses the filtered command of this very step
            lower, upper = limits.lower, limits.upper
            bounded = lower is not None and upper is not None and lower < upper
            if bounded and joint.type != "continuous":
                act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
                act.ctrlrange = [lower, upper]
        elif mode == "velocity":
            kv = gains.get(name)
            spec_joint = spec.joint(mj_name)
            if kv is None:
                kv = (effort or _DEFAULT_EFFORT) / _VELOCITY_SATURATION_ERROR
                if spec_joint.armature == 0:
                    added = max(0.0, kv * dt - inertia)
                    spec_joint.armature = added
                    inertia += added
                kv = min(kv, inertia / dt)
            # the drive also overcomes the joint's own damping: force (kv + damping) * command
            # - kv * velocity, so that the joint settles at the command, not kv / (kv + damping)
            # of it (issue 34: DiffBot's light wheels with damping 0.2 reached 6 %)
            act.set_to_velocity(kv=float(kv))
            act.gainprm[0] = float(kv) + float(spec_joint.damping[0])
            if limits.velocity is not None and limits.velocity > 0:
                act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
                act.ctrlrange = [-limits.velocity, limits.velocity]
        else:
            act.set_to_motor()
            if effort is not None:
                act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
                act.ctrlrange = [-effort, effort]
        if mode in ("position", "velocity") and effort is not None:
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.forcerange = [-effort, effort]
        actuated.append(name)
    if "velocity" in modes.values() and spec.option.noslip_iterations == 0:
        spec.option.noslip_iterations = VELOCITY_NOSLIP_ITERATIONS
    return tuple(actuated)


def existing_control(
    model: mujoco.MjModel, prefix: str, description: RobotModel
) -> tuple[dict[str, ControlMode], tuple[str, ...]]:
    """Control modes of an MJCF's own joint actuators, inferred from gain and bias (joint
    names unprefixed)."""
    own = {prefix + j.name for j in description.joints}
    modes: dict[str, ControlMode] = {}
    actuated = []
    for a in range(model.nu):
        if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
            continue
        joint = model.joint(int(model.actuator_trnid[a][0])).name
        if joint not in own:
            continue
        bias: Any = model.actuator_biasprm[a]
        mode = ControlMode.EFFORT
        if model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE:
            mode = ControlMode.POSITION if bias[1] != 0 else ControlMode.VELOCITY
        joint = joint.removeprefix(prefix)
        modes[joint] = mode
        actuated.append(joint)
    return modes, tuple(actuated)
