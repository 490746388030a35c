"""Joint loggers: samples at a sim-time rate, and limit checks every step.

:class:`JointLogger` emits a :class:`JointSample` (positions, velocities, efforts) at its
rate in simulation time; :class:`JointLimitLogger` watches every step for positions outside
the joint range and velocities above the velocity limit (MuJoCo ignores URDF velocity limits,
so they come from the robot description: :func:`velocity_limits`) and emits one event per
episode, when it ends, with the peak excess.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np
import numpy.typing as npt

from harness.events.errors import LoggerConfigError
from harness.events.events import Event, JointLimitViolation, JointSample, VelocityLimitExceeded
from harness.events.logger import StepContext, period_ns_from_hz
from harness.models import RobotModel

__all__ = [
    "JointLimitLogger",
    "JointLogger",
    "index_of",
    "scalar_joints",
    "solver_limit_tolerance",
    "velocity_limits",
]

_SCALAR = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def scalar_joints(model: mujoco.MjModel) -> list[str]:
    """Names of the hinge and slide joints, in model order."""
    return [
        model.joint(j).name
        for j in range(model.njnt)
        if int(model.jnt_type[j]) in _SCALAR and model.joint(j).name
    ]


def solver_limit_tolerance(model: mujoco.MjModel, joint: int | str) -> float:
    """How far MuJoCo's solver lets ``joint`` sit beyond its position limit by design: the
    limit's ``margin`` plus its soft-constraint width ``solimp[2]``.

    MuJoCo's limits are soft constraints: the constraint's impedance ramps from ``solimp[0]``
    to ``solimp[1]`` over the first ``solimp[2]`` of penetration (MuJoCo's default: 0.001, in
    the joint's unit: rad or m), so a joint held against its limit by an actuator or a contact
    rests slightly inside that zone (the demo gripper at its stop: about 1e-6 m). An excess
    within it is the solver working as configured; beyond it the limit was really broken. The
    same value is the default tolerance of :class:`JointLimitLogger`, of the pytest plugin's
    joint-limit logger and of the scenario runner's ``joint_limits`` verdict.
    """
    jid = joint if isinstance(joint, int) else model.joint(joint).id
    return float(model.jnt_margin[jid] + model.jnt_solimp[jid][2])


def velocity_limits(robot: RobotModel) -> dict[str, float]:
    """``{joint: velocity limit}`` for the joints of ``robot`` that declare one."""
    return {
        j.name: float(j.limits.velocity)
        for j in robot.joints
        if j.limits.velocity is not None and j.limits.velocity > 0
    }


def index_of(addresses: npt.NDArray[np.integer]) -> slice | npt.NDArray[np.intp]:
    """``addresses`` as a slice when they are consecutive (a view reads the same values
    without a gather), else as an index array."""
    adr = np.asarray(addresses, dtype=np.intp)
    if adr.size and bool((np.diff(adr) == 1).all()):
        return slice(int(adr[0]), int(adr[-1]) + 1)
    return adr


def _joint_ids(model: mujoco.MjModel, joints: Sequence[str] | None, who: str) -> list[int]:
    names = scalar_joints(model) if joints is None else list(joints)
    ids = []
    for i, joint in enumerate(names):
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
        if jid < 0:
            raise LoggerConfigError(f"{who}: joints[{i}]: no joint named {joint!r}")
        if int(model.jnt_type[jid]) not in _SCALAR:
            raise LoggerConfigError(f"{who}: joints[{i}]: {joint!r} is not a hinge or slide")
        ids.append(jid)
    return ids


class JointLogger:
    """A :class:`JointSample` of ``joints`` (default: every hinge and slide joint) at
    ``rate_hz`` in simulation time (None: every step). Efforts are the actuator forces on the
    joints (``qfrc_actuator``)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        *,
        joints: Sequence[str] | None = None,
        rate_hz: float | None = None,
        name: str = "joints",
    ) -> None:
        ids = _joint_ids(model, joints, f"joint logger {name!r}")
        try:
            self._period_ns = period_ns_from_hz(rate_hz)
        except ValueError as exc:
            raise LoggerConfigError(f"joint logger {name!r}: rate_hz: {exc}") from None
        self._name = name
        self.joints = tuple(model.joint(j).name for j in ids)
        self._qpos = np.asarray(model.jnt_qposadr)[ids]
        self._dof = np.asarray(model.jnt_dofadr)[ids]

    @property
    def name(self) -> str:
        return self._name

    @property
    def period_ns(self) -> int:
        return self._period_ns

    def observe(self, ctx: StepContext) -> Sequence[Event]:
        """One sample of this step's state."""
        data = ctx.data
        return [
            JointSample(
                step=ctx.step,
                sim_time_ns=ctx.sim_time_ns,
                robot=ctx.robot,
                joints=self.joints,
                positions=tuple(data.qpos[self._qpos].tolist()),
                velocities=tuple(data.qvel[self._dof].tolist()),
                efforts=tuple(data.qfrc_actuator[self._dof].tolist()),
            )
        ]

    def finish(self, ctx: StepContext) -> Sequence[Event]:
        """Nothing is open at the end."""
        return []


class _Excess:
    __slots__ = ("amount", "begin_step", "begin_time_ns", "limit", "peak_step", "value")

    def __init__(self, step: int, time_ns: int) -> None:
        self.begin_step = step
        self.begin_time_ns = time_ns
        self.amount = -np.inf
        self.limit = 0.0
        self.value = 0.0
        self.peak_step = step


class _Watch:
    """Episodes of ``excess > tolerance`` per watched joint."""

    def __init__(self, joints: tuple[str, ...]) -> None:
        self.joints = joints
        self.open: dict[int, _Excess] = {}

    def update(
        self,
        ctx: StepContext,
        excess: npt.NDArray[np.float64],
        limit: npt.NDArray[np.float64],
        value: npt.NDArray[np.float64],
        tolerance: float | npt.NDArray[np.float64],
        kind: type[JointLimitViolation] | type[VelocityLimitExceeded],
    ) -> list[Event]:
        over = excess > tolerance
        if not self.open and not over.any():
            return []
        out: list[Event] = []
        for j in np.flatnonzero(over).tolist():
            episode = self.open.get(j)
            if episode is None:
                episode = self.open[j] = _Excess(ctx.step, ctx.sim_time_ns)
            if excess[j] > episode.amount:
                episode.amount = float(excess[j])
                episode.limit = float(limit[j])
                episode.value = float(value[j])
                episode.peak_step = ctx.step
        for j in sorted(self.open):
            if not over[j]:
                out.append(self._event(j, self.open.pop(j), ctx, kind, ctx.step, ctx.sim_time_ns))
        return out

    def finish(
        self, ctx: StepContext, kind: type[JointLimitViolation] | type[VelocityLimitExceeded]
    ) -> list[Event]:
        out: list[Event] = [
            self._event(j, self.open[j], ctx, kind, ctx.step, ctx.sim_time_ns, at_finish=True)
            for j in sorted(self.open)
        ]
        self.open.clear()
        return out

    def _event(
        self,
        j: int,
        e: _Excess,
        ctx: StepContext,
        kind: type[JointLimitViolation] | type[VelocityLimitExceeded],
        end_step: int,
        end_time_ns: int,
        at_finish: bool = False,
    ) -> Event:
        return kind(
            step=ctx.step,
            sim_time_ns=ctx.sim_time_ns,
            robot=ctx.robot,
            joint=self.joints[j],
            value=e.value,
            limit=e.limit,
            amount=e.amount,
            peak_step=e.peak_step,
            begin_step=e.begin_step,
            end_step=end_step,
            duration_ns=end_time_ns - e.begin_time_ns,
            at_finish=at_finish,
        )


class JointLimitLogger:
    """Limit violations (position outside the range of a limited joint) and velocity-limit
    excesses (``|qvel| > velocity_limits[joint]``), checked every step, of ``joints``
    (default: every hinge and slide joint). An excess counts when it is above ``tolerance``;
    ``None`` (the default): a position excess counts beyond the solver's own soft-limit zone
    (:func:`solver_limit_tolerance`, per joint) and a velocity excess (MuJoCo does not enforce
    velocity limits, no solver softness is involved) beyond 0.
    Each episode gives one event when it ends (``end_step``: first step back within limits)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        *,
        joints: Sequence[str] | None = None,
        velocity_limits: Mapping[str, float] | None = None,
        tolerance: float | None = None,
        name: str = "joint_limits",
    ) -> None:
        who = f"joint limit logger {name!r}"
        ids = _joint_ids(model, joints, who)
        self._name = name
        self.tolerance = tolerance
        called = {j: model.joint(j).name for j in ids}  # each accessor costs microseconds
        names = tuple(called[j] for j in ids)
        limited = [j for j in ids if bool(model.jnt_limited[j])]
        self._pos = _Watch(tuple(called[j] for j in limited))
        self._pos_adr = np.asarray(model.jnt_qposadr)[limited]
        self._pos_at: slice | npt.NDArray[np.intp] = index_of(self._pos_adr)
        ranges = np.asarray(model.jnt_range)[limited].reshape(-1, 2)
        self._lower = ranges[:, 0].copy()
        self._upper = ranges[:, 1].copy()
        self._pos_tolerance: float | npt.NDArray[np.float64] = (
            np.array([solver_limit_tolerance(model, j) for j in limited], dtype=np.float64)
            if tolerance is None
            else tolerance
        )
        self._vel_tolerance = 0.0 if tolerance is None else tolerance
        vel = dict(velocity_limits or {})
        unknown = sorted(set(vel) - set(names))
        if unknown:
            raise LoggerConfigError(f"{who}: velocity_limits: unknown joint {unknown[0]!r}")
        bad = sorted(k for k, v in vel.items() if not v > 0)
        if bad:
            raise LoggerConfigError(f"{who}: velocity_limits.{bad[0]}: must be > 0")
        vel_ids = [j for j, n in zip(ids, names, strict=True) if n in vel]
        self._vel = _Watch(tuple(called[j] for j in vel_ids))
        self._vel_dof = np.asarray(model.jnt_dofadr)[vel_ids]
        self._vel_at: slice | npt.NDArray[np.intp] = index_of(self._vel_dof)
        self._vel_limit = np.array([vel[called[j]] for j in vel_ids], dtype=float)

    @property
    def name(self) -> str:
        return self._name

    @property
    def period_ns(self) -> int:
        """Every step (a violation between samples must not be missed)."""
        return 0

    def observe(self, ctx: StepContext) -> Sequence[Event]:
        """Episodes that ended at this step."""
        out: list[Event] = []
        if self._pos_adr.size:
            q = ctx.data.qpos[self._pos_at]
            above = q - self._upper
            below = self._lower - q
            excess = np.maximum(above, below)
            # within limits and nothing open (the common step): no episode work
            if self._pos.open or np.count_nonzero(excess > self._pos_tolerance):
                limit = np.where(above >= below, self._upper, self._lower)
                out += self._pos.update(
                    ctx, excess, limit, q, self._pos_tolerance, JointLimitViolation
                )
        if self._vel_dof.size:
            v = ctx.data.qvel[self._vel_at]
            excess = np.abs(v) - self._vel_limit
            if self._vel.open or np.count_nonzero(excess > self._vel_tolerance):
                out += self._vel.update(
                    ctx, excess, self._vel_limit, v, self._vel_tolerance, VelocityLimitExceeded
                )
        return out

    def finish(self, ctx: StepContext) -> Sequence[Event]:
        """Close episodes still open at the end of the run."""
        return self._pos.finish(ctx, JointLimitViolation) + self._vel.finish(
            ctx, VelocityLimitExceeded
        )
