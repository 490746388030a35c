"""``check_model``: the sanity report a user runs first on a robot (``harness check-model``).

It loads the robot with the defaults (lenient, self-collision ``auto``, gravity-compensated
position servos; ``harness check-model`` takes ``--robot-arg``, ``--self-collision``,
``--srdf``, ``--base`` and ``--strict`` as :func:`harness.models.load_robot` does) and
simulates it without a session or bridge, straight on MuJoCo:

- **hold**: every actuated joint commanded to its initial position for :data:`HOLD_SECONDS`
  under gravity; the error is the largest ``|position - command|`` seen (checked every
  :data:`HOLD_CHECK_STEPS` steps). It holds within :data:`HOLD_RAD` (revolute) or
  :data:`HOLD_M` (prismatic);
- **step response**: each position joint in turn commanded :data:`STEP` rad (:data:`STEP_M`
  m if prismatic) away from its initial position (towards the side with room inside the
  limits), the others held; the overshoot, the time it stays within :data:`SETTLE_BAND` of
  the step and the peak speed against the URDF velocity limit; it settles within
  :data:`SETTLE_SECONDS` plus the travel time at its velocity limit. Contacts are
  off while stepping (a step may drive a link into the floor: that is the scene, not the
  servo);
- **kinematic hold**: the same initial positions written before and after each step for a
  second, as the kinematic mode does: the joints not written (mimic followers, passive
  joints) drift by less than :data:`HOLD_RAD`;
- **stand** (floating bases): :data:`STAND_SECONDS` on the floor, no NaN, no MuJoCo warning,
  base height finite, nothing through the floor, nothing launched.

:attr:`ModelCheck.problems` says in one line each why a robot does not behave; the reason of
a joint that does not hold is named (its effort limit below the gravity load, a contact, a
servo that cannot reach). :attr:`ModelCheck.hints` says what to try: a wheeled robot checked
with a fixed base is told ``--base floating`` (:mod:`harness.models.check.base_hint`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.errors import HarnessError
from harness.models.build.decompose import MeshCollision
from harness.models.check.base_hint import floating_base_hint
from harness.models.errors import ModelWarning
from harness.models.files.resolve import PackageMap
from harness.models.world.placement import floor_gap, start_contacts
from harness.models.world.records import SelfCollision
from harness.models.xacro.expand import RobotArgs

__all__ = [
    "HOLD_M",
    "HOLD_RAD",
    "HOLD_SECONDS",
    "JointCheck",
    "ModelCheck",
    "StandCheck",
    "check_loaded",
    "check_model",
]

HOLD_SECONDS = 10.0
HOLD_CHECK_STEPS = 25
HOLD_RAD = 1e-3
HOLD_M = 1e-3
STEP = 0.1
STEP_M = 0.01
"""The step of a prismatic joint (m)."""
SETTLE_SECONDS = 0.5
SETTLE_BAND = 0.05
"""A joint has settled when it stays within this fraction of the step from its target."""
STEP_WINDOW = 1.0
OVERSHOOT_LIMIT = 0.2
SPEED_MARGIN = 1.2
"""A peak speed above this multiple of the velocity limit is a problem."""
STAND_SECONDS = 5.0
KINEMATIC_SECONDS = 1.0


@dataclass(frozen=True)
class JointCheck:
    """One actuated joint: ``hold_error`` (rad or m) over the hold, and when stepped, the
    ``overshoot`` (fraction of the step), ``settling_time`` (s, None: never settled),
    ``peak_speed`` and the ``velocity_limit`` of the URDF (None: none given)."""

    name: str
    prismatic: bool
    hold_error: float
    hold_reason: str | None = None
    overshoot: float | None = None
    settling_time: float | None = None
    peak_speed: float | None = None
    velocity_limit: float | None = None

    @property
    def holds(self) -> bool:
        """Within :data:`HOLD_RAD` (:data:`HOLD_M` for a prismatic joint)."""
        return self.hold_error <= (HOLD_M if self.prismatic else HOLD_RAD)


@dataclass(frozen=True)
class StandCheck:
    """A floating robot left on the floor: ``seconds`` simulated, ``finite`` (no NaN),
    ``warnings`` (MuJoCo warning counts), base height at start and end (m)."""

    seconds: float
    finite: bool
    warnings: Mapping[str, int]
    start_height: float
    end_height: float

    end_gap: float = 0.0

    @property
    def stood(self) -> bool:
        """No NaN, no warning, nothing sunk through the floor (``end_gap``, the lowest
        point's height, above -1 cm), not launched (the base at most 0.5 m higher)."""
        ok_height = math.isfinite(self.end_height) and self.end_height < self.start_height + 0.5
        return (
            self.finite and not any(self.warnings.values()) and ok_height and self.end_gap > -0.01
        )


@dataclass(frozen=True)
class ModelCheck:
    """The report of :func:`check_model`. ``error`` is set when the robot does not load."""

    source: str
    error: str | None = None
    base: str = "fixed"
    notes: tuple[str, ...] = ()
    repairs: tuple[str, ...] = ()
    self_collision: Mapping[str, Any] = field(default_factory=dict)
    start_contacts: tuple[tuple[str, str, float], ...] = ()
    joints: tuple[JointCheck, ...] = ()
    kinematic_drift: float | None = None
    stand: StandCheck | None = None
    mass: Mapping[str, float] = field(default_factory=dict)
    problems: tuple[str, ...] = ()
    hints: tuple[str, ...] = ()
    """What to try (a wheeled robot checked with a fixed base: ``--base floating``)."""

    @property
    def loaded(self) -> bool:
        return self.error is None

    @property
    def exit_code(self) -> int:
        """0: the robot behaves; 1: it loads but does not behave; 2: it does not load."""
        if self.error is not None:
            return 2
        return 1 if self.problems else 0

    @property
    def worst_hold(self) -> float:
        """The largest hold error of any joint (0 without joints)."""
        return max((j.hold_error for j in self.joints), default=0.0)

    def as_dict(self) -> dict[str, Any]:
        """The JSON report (``harness check-model --json``)."""
        return {
            "source": self.source,
            "loaded": self.loaded,
            "error": self.error,
            "exit_code": self.exit_code,
            "base": self.base,
            "notes": list(self.notes),
            "repairs": list(self.repairs),
            "self_collision": dict(self.self_collision),
            "start_contacts": [
                {"body1": a, "body2": b, "depth": d} for a, b, d in self.start_contacts
            ],
            "joints": [
                {
                    "name": j.name,
                    "type": "prismatic" if j.prismatic else "revolute",
                    "hold_error": j.hold_error,
                    "holds": j.holds,
                    "hold_reason": j.hold_reason,
                    "overshoot": j.overshoot,
                    "settling_time": j.settling_time,
                    "peak_speed": j.peak_speed,
                    "velocity_limit": j.velocity_limit,
                }
                for j in self.joints
            ],
            "kinematic_drift": self.kinematic_drift,
            "stand": None
            if self.stand is None
            else {
                "seconds": self.stand.seconds,
                "stood": self.stand.stood,
                "finite": self.stand.finite,
                "warnings": dict(self.stand.warnings),
                "start_height": self.stand.start_height,
                "end_height": self.stand.end_height,
                "end_floor_gap": self.stand.end_gap,
            },
            "mass": dict(self.mass),
            "problems": list(self.problems),
            "hints": list(self.hints),
        }


def check_model(
    source: str | Path,
    *,
    base: str | None = None,
    hold_seconds: float = HOLD_SECONDS,
    step_response: bool = True,
    cache_dir: str | Path | None = None,
    strict: bool = False,
    self_collision: SelfCollision | None = None,
    robot_args: RobotArgs | None = None,
    packages: PackageMap | None = None,
    srdf: str | Path | None = None,
    mesh_collision: MeshCollision = "decompose",
) -> ModelCheck:
    """Load ``source`` with the defaults and check it (see the module docstring).
    ``base``, ``strict``, ``self_collision``, ``robot_args`` (a xacro robot's arguments),
    ``packages``, ``srdf`` and ``mesh_collision``: as for :func:`harness.models.load_robot`.
    Never raises for a robot that does not load: the report says why in one line (exit
    code 2)."""
    from harness.models.build.load import load_robot

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            loaded = load_robot(
                source,
                cache_dir=cache_dir,
                base=base,  # type: ignore[arg-type]
                strict=strict,
                self_collision=self_collision,
                robot_args=robot_args,
                packages=packages,
                srdf=srdf,
                mesh_collision=mesh_collision,
            )
    except HarnessError as exc:
        return ModelCheck(str(source), error=str(exc))
    return check_loaded(loaded, str(source), hold_seconds=hold_seconds, step_response=step_response)


def _home(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if key >= 0:
        mujoco.mj_resetDataKeyframe(model, data, key)
    else:
        mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)


def _warnings(data: mujoco.MjData) -> dict[str, int]:
    counts = {}
    for index in range(len(data.warning)):
        number = int(data.warning[index].number)
        if number:
            counts[str(mujoco.mjtWarning(index).name)] = number
    return counts


class _Actuated:
    """The actuated joints of a loaded robot: actuator, qpos and dof addresses."""

    def __init__(self, loaded: Any) -> None:
        model = loaded.model
        self.names: list[str] = []
        self.actuators: list[int] = []
        self.qpos: list[int] = []
        self.dofs: list[int] = []
        self.prismatic: list[bool] = []
        self.position: list[bool] = []
        for act in range(model.nu):
            if model.actuator_trntype[act] != mujoco.mjtTrn.mjTRN_JOINT:
                continue
            joint = int(model.actuator_trnid[act][0])
            self.names.append(model.joint(joint).name)
            self.actuators.append(act)
            self.qpos.append(int(model.jnt_qposadr[joint]))
            self.dofs.append(int(model.jnt_dofadr[joint]))
            self.prismatic.append(int(model.jnt_type[joint]) == int(mujoco.mjtJoint.mjJNT_SLIDE))
            bias = model.actuator_biastype[act] == mujoco.mjtBias.mjBIAS_AFFINE
            self.position.append(bool(bias and model.actuator_biasprm[act][1] != 0))


def _hold(
    model: mujoco.MjModel, data: mujoco.MjData, joints: _Actuated, seconds: float
) -> npt.NDArray[np.float64]:
    _home(model, data)
    qpos = np.asarray(joints.qpos, dtype=int)
    target = data.qpos[qpos].copy()
    worst = np.zeros(len(qpos))
    steps = max(1, round(seconds / model.opt.timestep))
    done = 0
    while done < steps:
        chunk = min(HOLD_CHECK_STEPS, steps - done)
        mujoco.mj_step(model, data, nstep=chunk)
        done += chunk
        error = np.abs(data.qpos[qpos] - target)
        if not np.all(np.isfinite(error)):
            return np.full(len(qpos), np.inf)
        np.maximum(worst, error, out=worst)
    return worst


def _hold_reason(model: mujoco.MjModel, data: mujoco.MjData, joints: _Actuated, index: int) -> str:
    """Why joint ``index`` does not hold: its gravity load against its effort limit, a
    contact on the robot, or a servo too soft for what it carries."""
    dof = joints.dofs[index]
    act = joints.actuators[index]
    probe = mujoco.MjData(model)
    _home(model, probe)
    load = abs(float(probe.qfrc_bias[dof]))  # at rest: the gravity torque on the joint
    limited = bool(model.actuator_forcelimited[act])
    effort = float(model.actuator_forcerange[act][1]) if limited else math.inf
    unit = "N" if joints.prismatic[index] else "N m"
    if load > effort:
        return (
            f"effort limit {effort:g} {unit} below the gravity load {load:.3g} {unit} at the "
            "initial configuration"
        )
    contacts = start_contacts(model, data.qpos)
    if contacts:
        return f"in contact: {contacts[0]}"
    return "the servo cannot hold what it carries (gain bounded for stability)"


def _step_size(joints: _Actuated, i: int) -> float:
    return STEP_M if joints.prismatic[i] else STEP


def _deadline(step: float, velocity_limit: float | None) -> float:
    """Settling deadline: :data:`SETTLE_SECONDS` plus the travel at the velocity limit."""
    return SETTLE_SECONDS + (step / velocity_limit if velocity_limit else 0.0)


def _step_one(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    joints: _Actuated,
    i: int,
    velocity_limit: float | None,
) -> tuple[float | None, float | None, float | None]:
    """Joint ``i`` alone commanded one step away (the others held): overshoot, settling
    time (None: not settled within the window), peak speed; all None when the joint has no
    room for a step or is not a position joint."""
    if not joints.position[i]:
        return None, None, None
    _home(model, data)
    act, adr, dof = joints.actuators[i], joints.qpos[i], joints.dofs[i]
    size = _step_size(joints, i)
    start = float(data.qpos[adr])
    sign = 1.0
    if model.actuator_ctrllimited[act]:
        low, high = (float(v) for v in model.actuator_ctrlrange[act])
        sign = 1.0 if start + size <= high else -1.0
        if not low <= start + sign * size <= high:
            return None, None, None
    data.ctrl[act] = start + sign * size
    steps = round((_deadline(size, velocity_limit) + STEP_WINDOW) / model.opt.timestep)
    positions = np.empty(steps)
    speeds = np.empty(steps)
    for k in range(steps):
        mujoco.mj_step(model, data)
        positions[k] = data.qpos[adr]
        speeds[k] = data.qvel[dof]
    progress = (positions - start) * sign / size
    overshoot = max(0.0, float(np.max(progress)) - 1.0)
    outside = np.nonzero(np.abs(progress - 1.0) > SETTLE_BAND)[0]
    settling: float | None
    if len(outside) == 0:
        settling = 0.0
    elif outside[-1] == steps - 1:
        settling = None
    else:
        settling = float(outside[-1] + 1) * float(model.opt.timestep)
    return overshoot, settling, float(np.max(np.abs(speeds)))


def _step(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    joints: _Actuated,
    velocity_limits: Mapping[str, float],
) -> tuple[list[float | None], list[float | None], list[float | None]]:
    overshoot: list[float | None] = []
    settling: list[float | None] = []
    peak: list[float | None] = []
    flags = int(model.opt.disableflags)
    # the servo's response, not the scene's: a step may drive a link into the floor
    model.opt.disableflags = flags | int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    try:
        for i, name in enumerate(joints.names):
            o, s, p = _step_one(model, data, joints, i, velocity_limits.get(name))
            overshoot.append(o)
            settling.append(s)
            peak.append(p)
    finally:
        model.opt.disableflags = flags
    return overshoot, settling, peak


def _kinematic(model: mujoco.MjModel, data: mujoco.MjData, joints: _Actuated) -> float:
    """The actuated joints written to their initial positions before and after every step,
    as the simulation's kinematic mode does, for :data:`KINEMATIC_SECONDS`: the largest drift
    of every other hinge or slide joint (mimic followers, passive joints)."""
    _home(model, data)
    qpos = np.asarray(joints.qpos, dtype=int)
    dofs = np.asarray(joints.dofs, dtype=int)
    target = data.qpos[qpos].copy()
    others = np.asarray(
        [
            int(model.jnt_qposadr[j])
            for j in range(model.njnt)
            if int(model.jnt_type[j]) in _HINGE_OR_SLIDE and int(model.jnt_qposadr[j]) not in qpos
        ],
        dtype=int,
    )
    start = data.qpos[others].copy()
    worst = 0.0
    for _ in range(round(KINEMATIC_SECONDS / model.opt.timestep)):
        data.qpos[qpos] = target
        data.qvel[dofs] = 0.0
        mujoco.mj_step(model, data)
        data.qpos[qpos] = target
        data.qvel[dofs] = 0.0
        if len(others):
            worst = max(worst, float(np.max(np.abs(data.qpos[others] - start))))
    return worst


_HINGE_OR_SLIDE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def _stand(
    model: mujoco.MjModel, data: mujoco.MjData, seconds: float, bodies: Sequence[int]
) -> StandCheck:
    _home(model, data)
    free = [
        j for j in range(model.njnt) if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE)
    ]
    adr = int(model.jnt_qposadr[free[0]]) + 2 if free else -1
    start = float(data.qpos[adr]) if adr >= 0 else math.nan
    steps = round(seconds / model.opt.timestep)
    mujoco.mj_step(model, data, nstep=steps)
    finite = bool(np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel)))
    end = float(data.qpos[adr]) if adr >= 0 else math.nan
    gap = floor_gap(model, np.array(data.qpos), bodies) if finite else None
    end_gap = -math.inf if not finite else (0.0 if gap is None else gap)
    return StandCheck(seconds, finite, _warnings(data), start, end, end_gap)


def _robot_bodies(model: mujoco.MjModel, loaded: Any) -> list[int]:
    return [
        int(model.body(link.name).id)
        for link in loaded.description.links
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, link.name) > 0
    ]


def _mass_summary(model: mujoco.MjModel, loaded: Any) -> dict[str, float]:
    bodies = _robot_bodies(model, loaded)
    masses = np.array([model.body_mass[b] for b in bodies]) if bodies else np.zeros(1)
    moving = [b for b in bodies if int(model.body_weldid[b]) != 0]
    inertia = np.array([min(model.body_inertia[b]) for b in moving]) if moving else np.zeros(1)
    return {
        "total_kg": float(masses.sum()),
        "links": float(len(bodies)),
        "lightest_moving_kg": float(min((model.body_mass[b] for b in moving), default=0.0)),
        "heaviest_kg": float(masses.max()),
        "smallest_moving_inertia_kg_m2": float(inertia.min()),
    }


def check_loaded(
    loaded: Any,
    source: str,
    *,
    hold_seconds: float = HOLD_SECONDS,
    step_response: bool = True,
    kinematic: bool = True,
) -> ModelCheck:
    """Check an already loaded robot (a :class:`harness.models.LoadedRobot`). MuJoCo's
    printed warnings (an unstable step) are not printed: they become problems."""
    printed: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(printed.append)
    try:
        report = _check(loaded, source, hold_seconds, step_response, kinematic)
    finally:
        mujoco.set_mju_user_warning(previous)
    if printed and report.error is None:
        unstable = f"MuJoCo warned {len(printed)} time(s): {' '.join(printed[0].split())}"
        report = replace(report, problems=(*report.problems, unstable))
    return report


def _check(
    loaded: Any, source: str, hold_seconds: float, step_response: bool, kinematic: bool
) -> ModelCheck:
    model = loaded.model
    data = mujoco.MjData(model)
    joints = _Actuated(loaded)
    _home(model, data)
    contacts = tuple(
        (c.body1, c.body2, c.depth) for c in start_contacts(model, np.array(data.qpos))
    )
    problems: list[str] = []
    hold = _hold(model, data, joints, hold_seconds)
    hold_warnings = _warnings(data)
    floating = getattr(loaded, "base", "fixed") == "floating"
    reasons: list[str | None] = []
    for i in range(len(joints.names)):
        limit = HOLD_M if joints.prismatic[i] else HOLD_RAD
        if hold[i] <= limit:
            reasons.append(None)
            continue
        reasons.append(_hold_reason(model, data, joints, i))
    weak = [joints.names[i] for i, r in enumerate(reasons) if r and "below the gravity load" in r]
    for i, reason in enumerate(reasons):
        if reason is None:
            continue
        if weak and "below the gravity load" not in reason:
            reason = reasons[i] = f"moved by {', '.join(weak[:3])}, which cannot carry its load"
        if not floating:
            unit = "mm" if joints.prismatic[i] else "mrad"
            problems.append(
                f"{joints.names[i]} does not hold: {hold[i] * 1000:.3g} {unit} in "
                f"{hold_seconds:g} s ({reason})"
            )
    if hold_warnings and not floating:
        problems.append(f"MuJoCo warnings while holding: {hold_warnings}")
    overshoot: Sequence[float | None] = [None] * len(joints.names)
    settling: Sequence[float | None] = [None] * len(joints.names)
    peak: Sequence[float | None] = [None] * len(joints.names)
    velocity_limits = _velocity_limits(loaded)
    if step_response and not floating and joints.names:
        overshoot, settling, peak = _step(model, data, joints, velocity_limits)
    drift = _kinematic(model, data, joints) if kinematic and joints.names else None
    if drift is not None and drift > HOLD_RAD and not floating:
        problems.append(f"kinematic hold: joints not written drift {drift:.3g}")
    checks = []
    for i, name in enumerate(joints.names):
        velocity_limit = velocity_limits.get(name)
        check = JointCheck(
            name,
            joints.prismatic[i],
            float(hold[i]),
            reasons[i],
            overshoot[i],
            settling[i],
            peak[i],
            velocity_limit,
        )
        checks.append(check)
        if check.overshoot is not None and check.overshoot > OVERSHOOT_LIMIT:
            problems.append(f"{name} overshoots a {STEP:g} step by {check.overshoot:.0%}")
        size = _step_size(joints, i)
        deadline = _deadline(size, velocity_limit)
        if check.overshoot is not None and (
            check.settling_time is None or check.settling_time > deadline
        ):
            when = "never" if check.settling_time is None else f"in {check.settling_time:.3g} s"
            problems.append(f"{name} settles on a {size:g} step {when} (> {deadline:.3g} s)")
        if (
            check.peak_speed is not None
            and velocity_limit is not None
            and check.peak_speed > (SPEED_MARGIN * velocity_limit)
        ):
            problems.append(
                f"{name} reaches {check.peak_speed:.3g} on a {STEP:g} step, above its velocity "
                f"limit {velocity_limit:g}"
            )
    stand = None
    if floating:
        stand = _stand(model, data, STAND_SECONDS, _robot_bodies(model, loaded))
        if not stand.stood:
            problems.append(
                f"does not stand {STAND_SECONDS:g} s: finite={stand.finite}, warnings="
                f"{dict(stand.warnings)}, base height {stand.end_height:.3g} m"
            )
    report = getattr(loaded, "self_collision", None)
    return ModelCheck(
        source,
        base="floating" if floating else "fixed",
        notes=tuple(getattr(loaded, "notes", ())),
        repairs=tuple(getattr(loaded, "repairs", ())),
        self_collision=report.as_dict() if report is not None else {},
        start_contacts=contacts,
        joints=tuple(checks),
        kinematic_drift=drift,
        stand=stand,
        mass=_mass_summary(model, loaded),
        problems=tuple(problems),
        hints=tuple(h for h in (floating_base_hint(loaded),) if h),
    )


def _velocity_limits(loaded: Any) -> dict[str, float]:
    limits = {}
    for joint in loaded.description.joints:
        velocity = joint.limits.velocity
        if velocity is not None and velocity > 0:
            limits[joint.name] = float(velocity)
    return limits
