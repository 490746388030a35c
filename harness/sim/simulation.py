"""`Simulation`: a MuJoCo model stepped at a fixed ``dt``, one control mode per joint.

Simulation time is the only clock: the state after ``step_index`` steps is at
``sim_time_ns == step_index * dt_ns`` (an integer product, never a float sum). Commands take
effect at the next step boundary. Everything the simulation writes into MuJoCo before a step is
captured as an :class:`~harness.sim.inputs.AppliedInput` (``last_input``), so the model, the
initial state and those inputs are enough to re-simulate a run bit for bit.

Kinematic joints, and how they report exactly the commanded position
--------------------------------------------------------------------
Before every step the commanded position of each kinematic joint is written to ``qpos`` and the
finite difference of successive commands ``(q_cmd[k] - q_cmd[k-1]) / dt`` to ``qvel`` (mimic
followers of kinematic joints get the mimic law's value). ``mj_step`` then integrates the whole
world: contacts and constraint forces see the kinematic links where they were commanded, moving
at that velocity. Integration moves the kinematic joints too, so *after* ``mj_step`` the same
qpos/qvel are written again. The state after the step therefore holds the commanded position bit
for bit, and it is that state which is recorded, restored and replayed (the rewrite is part of
the applied input's meaning, see :func:`harness.sim.inputs.advance`).

What observers read after a step: ``joint_positions``/``joint_velocities`` and ``get_state``
come from the post-step state; ``link_poses`` runs forward kinematics on that state (in a scratch
``MjData``, so the simulation's own data is never touched between steps); ``contacts`` and
``joint_efforts`` are what MuJoCo computed during the step (the pre-integration state of that
step, MuJoCo's convention).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType
from typing import Protocol

import mujoco
import numpy as np
import numpy.typing as npt

from harness.errors import SimulationError
from harness.models import ControlMode, LoadedWorld, RobotModel
from harness.sim.capture import capture_input
from harness.sim.commands import (
    CommandField,
    CommandTable,
    Entry,
    Notice,
    body_wrench,
    joint_state_entries,
)
from harness.sim.contacts import ContactSet, extract_contacts
from harness.sim.errors import ControlConfigError, InstabilityError
from harness.sim.inputs import AppliedInput
from harness.sim.instability import failure, warning_names
from harness.sim.layout import (
    build_layout,
    check_run_layout,
    kinematic_targets,
    object_name,
    write_target,
)
from harness.sim.planar import PlanarBase
from harness.sim.poses import BodyPoses
from harness.sim.state import STATE_SPEC, checked_state, out_error
from harness.vocabulary import LimitPolicy

__all__ = [
    "STATE_SPEC",
    "CommandField",
    "Notice",
    "Observer",
    "RobotLike",
    "Simulation",
    "warning_names",
]

F64 = npt.NDArray[np.float64]

Observer = Callable[["Simulation"], None]
_mj_step = mujoco.mj_step


class RobotLike(Protocol):
    """What :class:`Simulation` needs from a loaded robot (``harness.models.LoadedRobot``)."""

    @property
    def description(self) -> RobotModel: ...

    @property
    def model(self) -> mujoco.MjModel: ...

    @property
    def control(self) -> Mapping[str, ControlMode]: ...


class Simulation:
    """A MuJoCo model stepped deterministically, with a control mode per controllable joint.

    Build it from a loaded robot (``Simulation(load_robot(...))``), a world of several robots
    (``Simulation(load_world(...))``: joints by their MuJoCo, prefixed, names; per robot see
    :class:`harness.sim.RobotJoints`) or from a compiled model (:meth:`from_model`).
    ``kinematic_limits`` decides what a kinematic joint does with a command beyond its position
    limits: ``"clamp"`` to the limit (reported as a :class:`Notice`) or ``"allow"`` it,
    reproducing the original framework's teleport "jumping". Dynamic modes always clamp to the
    model's and the description's limits. The initial state is the model's ``keyframe`` (default
    ``"home"``, used when the model has one, as the demo robot does: its zero configuration is
    outside joint 4's range), else ``qpos0``.

    The model must not be edited while the simulation runs; write inputs only through the
    command methods (never into ``data`` directly), or they are not recorded.
    """

    model: mujoco.MjModel
    data: mujoco.MjData
    dt_ns: int
    description: RobotModel | None
    kinematic_limits: LimitPolicy
    state_spec: int

    def __init__(
        self,
        robot: RobotLike | LoadedWorld,
        *,
        kinematic_limits: LimitPolicy | str = LimitPolicy.CLAMP,
        keyframe: str | None = "home",
    ) -> None:
        description = (
            robot.combined_description() if isinstance(robot, LoadedWorld) else robot.description
        )
        self._setup(robot.model, robot.control, description, kinematic_limits, keyframe)

    @classmethod
    def from_model(
        cls,
        model: mujoco.MjModel,
        *,
        control: Mapping[str, ControlMode],
        description: RobotModel | None = None,
        kinematic_limits: LimitPolicy | str = LimitPolicy.CLAMP,
        keyframe: str | None = "home",
    ) -> Simulation:
        """A simulation of a compiled model: ``control`` maps each controllable joint (hinge or
        slide) to its mode; dynamic joints need exactly one joint actuator of the matching kind,
        kinematic joints none. ``description`` adds limits MuJoCo ignores (URDF velocity)."""
        sim = cls.__new__(cls)
        sim._setup(model, control, description, kinematic_limits, keyframe)
        return sim

    # ----------------------------------------------------------------------------- set-up

    def _setup(
        self,
        model: mujoco.MjModel,
        control: Mapping[str, ControlMode],
        description: RobotModel | None,
        kinematic_limits: LimitPolicy | str,
        keyframe: str | None,
    ) -> None:
        try:
            limit_policy = LimitPolicy.parse(kinematic_limits)
        except ValueError as exc:
            raise ControlConfigError(str(exc)) from None
        dt, dt_ns, self._keyframe = check_run_layout(model, keyframe)
        self.model = model
        self.data = mujoco.MjData(model)
        self.dt_ns = dt_ns
        self.description = description
        self.kinematic_limits = limit_policy
        self.state_spec = STATE_SPEC
        self._dt = dt
        self._half_dt = dt / 2
        self._dt_array = np.array(dt)  # the same division as by dt, for less per call
        self._state_size = int(mujoco.mj_stateSize(model, STATE_SPEC))
        self._warnings = self.data.warning.number  # a live view of the counters
        self._no_warnings = bytes(self._warnings.nbytes)
        self._warning_names = warning_names()
        self._observers: list[Observer] = []
        self._planar: PlanarBase | None = None

        layout = build_layout(model, control, description, limit_policy)
        self._commands = CommandTable(layout)
        self._cmd = self._commands.cmd  # the same array, updated in place
        self._layout = layout
        # The layout's arrays the step and read paths use, as attributes of their own.
        self._names = layout.names
        self._qadr = layout.qadr
        self._dadr = layout.dadr
        self._is_kin = layout.is_kin
        self._dyn_rows = layout.dyn_rows
        self._dyn_act = layout.dyn_act
        self._has_kin = bool(layout.kin_rows.size)
        self._kin_gather = layout.kin_gather
        self._follow = layout.follow
        self._kin_names = layout.kin_names
        self._kin_qadr = layout.kin_qadr
        self._kin_dadr = layout.kin_dadr
        # The kinematic writes' targets in the simulation's own MjData (its buffers are never
        # reallocated, so views of them stay valid).
        self._kin_qpos, self._kin_qkey = write_target(self.data.qpos, self._kin_qadr)
        self._kin_qvel, self._kin_dkey = write_target(self.data.qvel, self._kin_dadr)
        self._poses = BodyPoses(model)
        self.reset()

    # ----------------------------------------------------------------------------- state

    def reset(self) -> None:
        """Back to the initial state at step 0 (the keyframe, else the model's ``qpos0``);
        every joint holds its initial position (position servos target it, velocity and effort
        commands are 0)."""
        if self._keyframe >= 0:
            mujoco.mj_resetDataKeyframe(self.model, self.data, self._keyframe)
        else:
            mujoco.mj_resetData(self.model, self.data)
        self._commands.hold(self.data.qpos)
        self.data.ctrl[self._dyn_act] = self._cmd[self._dyn_rows]
        # a filtered position command (the drive's setpoint filter) starts at its command
        model = self.model
        exact = int(mujoco.mjtDyn.mjDYN_FILTEREXACT)  # a NumPy scalar compares to an enum slowly
        for act in self._dyn_act.tolist():
            adr = int(model.actuator_actadr[act])
            if adr >= 0 and int(model.actuator_dyntype[act]) == exact:
                self.data.act[adr] = self.data.ctrl[act]
        self._restart(0)

    def get_state(self, out: F64 | None = None) -> F64:
        """The full ``mjSTATE_INTEGRATION`` state: a new array, or written into ``out`` (a
        C-contiguous float64 array of :attr:`state_size` values) and ``out`` returned."""
        if out is None:
            state = np.empty(self._state_size, dtype=np.float64)
            mujoco.mj_getState(self.model, self.data, state, STATE_SPEC)
            return state
        try:
            mujoco.mj_getState(self.model, self.data, out, STATE_SPEC)
        except TypeError:
            raise out_error(out, self._state_size) from None
        return out

    def set_state(self, state: npt.ArrayLike, step_index: int) -> None:
        """Restore a state captured by :meth:`get_state` at ``step_index``. Commands are taken
        from it: positions held, ctrl as in the state."""
        arr = checked_state(state, self._state_size, step_index, self._dt, self.dt_ns)
        mujoco.mj_setState(self.model, self.data, arr, STATE_SPEC)
        kin_rows = self._layout.kin_rows
        self._cmd[kin_rows] = self.data.qpos[self._qadr[kin_rows]]
        self._cmd[self._dyn_rows] = self.data.ctrl[self._dyn_act]
        self._restart(step_index)

    def _restart(self, step_index: int) -> None:
        self._step = step_index
        self._failed: str | None = None
        self._xfrc = np.array(self.data.xfrc_applied, dtype=np.float64)
        self._kin_prev = np.array(self.data.qpos[self._kin_qadr], dtype=np.float64)
        self._kin_pos = self._kin_prev
        self._kin_vel = np.zeros(self._kin_qadr.size, dtype=np.float64)
        self._kin_moving = False
        self._dirty = True
        self._kin_dirty = False
        self._fast = False
        self._kin_fast = False
        self._changed = False
        self._applied: AppliedInput | None = None
        # Derived quantities (contacts, poses) for observers at this step; mj_forward reads
        # the state but writes none of it.
        mujoco.mj_forward(self.model, self.data)

    # ----------------------------------------------------------------------------- stepping

    @property
    def step_index(self) -> int:
        """Steps taken since step 0 (the initial state)."""
        return self._step

    @property
    def sim_time_ns(self) -> int:
        """``step_index * dt_ns``."""
        return self._step * self.dt_ns

    @property
    def dt(self) -> float:
        """The timestep in seconds (``dt_ns / 1e9`` exactly)."""
        return self._dt

    @property
    def state_size(self) -> int:
        """Length of :meth:`get_state`'s array."""
        return self._state_size

    def add_observer(self, fn: Observer) -> Callable[[], None]:
        """Call ``fn(sim)`` after every step, in registration order; returns its remover."""
        self._observers.append(fn)
        self._fast = self._kin_fast = False

        def remove() -> None:
            if fn in self._observers:
                self._observers.remove(fn)
            self._update_fast()

        return remove

    @property
    def plain(self) -> bool:
        """Whether the next :meth:`step` is a bare ``mj_step`` (dynamic joints only, no
        observer, no input pending): a caller's tight loop may call ``mj_step`` itself, then
        :meth:`stepped`."""
        return self._fast

    def stepped(self, n: int) -> None:
        """Account for ``n`` bare ``mj_step`` calls a caller made on :attr:`data` while
        :attr:`plain` held: the step count, then :meth:`step`'s checks once (MuJoCo's
        warnings, time = steps x dt; a failure names the last of the ``n`` steps, not the
        first that went wrong: step one at a time to find it)."""
        step = self._step = self._step + n
        self._changed = False
        if (
            self._warnings.tobytes() != self._no_warnings
            or abs(self.data.time - step * self._dt) > self._half_dt
        ):
            self._fail(step)

    def step(self, n: int = 1) -> None:
        """Take ``n`` steps. Raises :class:`~harness.sim.errors.InstabilityError` naming the step
        when MuJoCo warns (BADQACC, ...) or time does not match ``step * dt``."""
        if n == 1 and self._fast:
            # The common case (dynamic joints, no observer, input unchanged), kept lean: the
            # overhead over a bare mj_step is what bench_sim measures.
            _mj_step(self.model, self.data)
            step = self._step = self._step + 1
            self._changed = False
            if (
                self._warnings.tobytes() != self._no_warnings
                or abs(self.data.time - step * self._dt) > self._half_dt
            ):
                self._fail(step)
            return
        if self._kin_fast and n >= 0:
            # Kinematic joints, no observer, nothing new but kinematic commands.
            if n == 1:
                self._step_kinematic()
                return
            for _ in range(n):
                self._step_kinematic()
            return
        if n < 0:
            raise SimulationError(f"step count must be >= 0, not {n}")
        if self._failed is not None:
            raise SimulationError(self._failed)
        if n > 1 and not self._observers and not self._has_kin and self._planar is None:
            self._step_batch(n)
            return
        for _ in range(n):
            self._step_one()
            if self._observers:
                for fn in tuple(self._observers):
                    fn(self)

    def _update_fast(self) -> None:
        blocked = bool(self._dirty or self._observers or self._failed or self._planar)
        self._fast = not (blocked or self._has_kin)
        self._kin_fast = self._has_kin and not blocked

    def _step_kinematic(self) -> None:
        """One step when the only input that may have changed since the last step is the
        kinematic joints' (what :meth:`_step_one` does then, without its general bookkeeping):
        ctrl, applied forces and mocap poses are the last applied input's, so that input with
        the new kinematic writes is this step's, and it changed exactly when those writes did.
        """
        if self._kin_dirty or self._kin_moving:
            pos = (
                kinematic_targets(self._cmd, self._kin_gather, self._follow)
                if self._kin_dirty
                else self._kin_pos
            )
            self._kin_dirty = False
            vel: F64 = pos - self._kin_prev
            vel /= self._dt_array
            self._kin_prev = self._kin_pos = pos
            self._kin_vel = vel
            moving = self._kin_moving = any(vel.tolist())  # vel.any(), for less
            last = self._applied
            assert last is not None  # the step after a restart takes the general path
            # last.qpos_value holds the positions written at the last step, bit for bit (the
            # old _kin_prev): a nonzero velocity means new positions, so a changed input.
            if not moving and (
                pos.tobytes() == last.qpos_value.tobytes()
                and vel.tobytes() == last.qvel_value.tobytes()
            ):
                self._changed = False
            else:
                self._changed = True
                self._applied = AppliedInput(
                    last.step,
                    last.sim_time_ns,
                    last.ctrl,
                    last.kinematic_joints,
                    last.qpos_index,
                    pos,
                    last.qvel_index,
                    vel,
                    last.mocap_pos,
                    last.mocap_quat,
                    last.qfrc_applied,
                    last.xfrc_applied,
                )
        else:
            pos, vel = self._kin_pos, self._kin_vel
            self._changed = False
        qpos, qkey, qvel, dkey = self._kin_qpos, self._kin_qkey, self._kin_qvel, self._kin_dkey
        qpos[qkey] = pos
        qvel[dkey] = vel
        _mj_step(self.model, self.data)
        qpos[qkey] = pos
        qvel[dkey] = vel
        step = self._step = self._step + 1
        if (
            self._warnings.tobytes() != self._no_warnings
            or abs(self.data.time - step * self._dt) > self._half_dt
        ):
            self._fail(step)

    def _step_one(self) -> None:
        data = self.data
        if self._dirty or self._kin_dirty or self._kin_moving or self._planar is not None:
            self._prepare_input()
        else:
            self._changed = False
        if self._planar is not None:
            applied = self._applied
            assert applied is not None
            data.qpos[applied.qpos_index] = applied.qpos_value
            data.qvel[applied.qvel_index] = applied.qvel_value
            mujoco.mj_step(self.model, data)
            data.qpos[applied.qpos_index] = applied.qpos_value
            data.qvel[applied.qvel_index] = applied.qvel_value
        elif self._has_kin:
            data.qpos[self._kin_qadr] = self._kin_pos
            data.qvel[self._kin_dadr] = self._kin_vel
            mujoco.mj_step(self.model, data)
            data.qpos[self._kin_qadr] = self._kin_pos
            data.qvel[self._kin_dadr] = self._kin_vel
        else:
            mujoco.mj_step(self.model, data)
        step = self._step + 1
        self._step = step
        if (
            self._warnings.tobytes() != self._no_warnings
            or abs(data.time - step * self._dt) > self._half_dt
        ):
            self._fail(step)

    def _step_batch(self, n: int) -> None:
        if self._dirty or self._kin_moving:
            self._prepare_input()
        start = self._step
        saved = self.get_state()
        mujoco.mj_step(self.model, self.data, nstep=n)
        self._step = start + n
        self._changed = False
        if (
            self._warnings.tobytes() != self._no_warnings
            or abs(self.data.time - self._step * self._dt) > self._half_dt
        ):
            # Deterministic: replay the batch one step at a time to name the failing step.
            mujoco.mj_setState(self.model, self.data, saved, STATE_SPEC)
            self.data.warning.number[:] = 0
            self._step = start
            for _ in range(n):
                self._step_one()
            self._fail(self._step)

    def _prepare_input(self) -> None:
        """Write the pending commands into MuJoCo and capture them as the applied input."""
        data = self.data
        if self._dirty:
            data.ctrl[self._dyn_act] = self._cmd[self._dyn_rows]
            data.xfrc_applied[:] = self._xfrc
        if (self._dirty or self._kin_dirty) and self._has_kin:
            self._kin_pos = kinematic_targets(self._cmd, self._kin_gather, self._follow)
        if self._has_kin:
            self._kin_vel = (self._kin_pos - self._kin_prev) / self._dt
            self._kin_prev = self._kin_pos
            self._kin_moving = bool(self._kin_vel.any())
        self._dirty = self._kin_dirty = False
        self._update_fast()
        kinematic = None
        if self._has_kin:
            kinematic = (self._kin_qadr, self._kin_pos.copy(), self._kin_dadr, self._kin_vel.copy())
        step, planar = self._step + 1, self._planar
        applied = capture_input(
            self.model, data, step, self.dt_ns, self._kin_names, kinematic, planar, self._dt
        )
        self._changed = self._applied is None or not applied.same_physics(self._applied)
        self._applied = applied

    def _fail(self, step: int) -> None:
        message, warning = failure(self.model, self.data, step, self.dt_ns)
        self._failed = f"the simulation failed at {message}; reset() or set_state() first"
        self._fast = self._kin_fast = False
        raise InstabilityError(message, step=step, warning=warning)

    @property
    def last_input(self) -> AppliedInput | None:
        """The physics input applied at the last step (None before the first step after a
        reset or restore). It holds until changed: its ``step`` is the last step taken."""
        applied = self._applied
        if applied is None or self._step == 0:
            return None
        # Copies of the kinematic writes: the simulation keeps writing its own arrays.
        return applied._replace(
            step=self._step,
            sim_time_ns=self.sim_time_ns,
            qpos_value=applied.qpos_value.copy(),
            qvel_value=applied.qvel_value.copy(),
        )

    @property
    def input_changed(self) -> bool:
        """Whether the last step's input differs from the step before's (True for the first
        step after a reset or restore)."""
        return self._changed

    # ----------------------------------------------------------------------------- commands

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The controllable joints, in the order of every per-joint array."""
        return self._names

    @property
    def control(self) -> Mapping[str, ControlMode]:
        """Joint name -> control mode."""
        return MappingProxyType(dict(zip(self._names, self._layout.modes, strict=True)))

    def command(
        self,
        joint: str,
        *,
        position: float | None = None,
        velocity: float | None = None,
        effort: float | None = None,
    ) -> list[Notice]:
        """Command one joint: the field matching its mode applies (``position`` for kinematic
        and position joints, ``velocity`` for velocity, ``effort`` for effort); others are
        reported as ignored when nothing applies. Unknown joint or non-finite value: raises
        :class:`~harness.sim.errors.CommandError` and nothing changes."""
        given = {"position": position, "velocity": velocity, "effort": effort}
        return self._apply([(joint, f, v) for f, v in given.items() if v is not None])

    def set_positions(self, positions: Mapping[str, float]) -> list[Notice]:
        """Position commands for several joints (all validated before any applies)."""
        notices, kin, dyn = self._commands.apply_field("position", positions)
        self._mark_dirty(kin, dyn)
        return notices

    def set_velocities(self, velocities: Mapping[str, float]) -> list[Notice]:
        """Velocity commands for several joints (all validated before any applies)."""
        notices, kin, dyn = self._commands.apply_field("velocity", velocities)
        self._mark_dirty(kin, dyn)
        return notices

    def set_efforts(self, efforts: Mapping[str, float]) -> list[Notice]:
        """Effort commands for several joints (all validated before any applies)."""
        notices, kin, dyn = self._commands.apply_field("effort", efforts)
        self._mark_dirty(kin, dyn)
        return notices

    def command_joint_state(
        self,
        name: Sequence[str],
        position: Sequence[float] = (),
        velocity: Sequence[float] = (),
        effort: Sequence[float] = (),
    ) -> list[Notice]:
        """A ``sensor_msgs/JointState``-style command (the original framework's
        JointStateSubscriber): for each ``name[i]``, ``effort[i]``, ``velocity[i]`` and
        ``position[i]`` apply where that index exists, per the joint's mode. Unlike the
        original, unknown names are refused, not skipped."""
        return self._apply(joint_state_entries(name, position, velocity, effort))

    def set_base_velocity(
        self,
        linear_x: float,
        linear_y: float = 0.0,
        angular_z: float = 0.0,
        *,
        joint: str | None = None,
    ) -> None:
        """Drive the floating base as a planar base (:class:`~harness.sim.planar.PlanarBase`)
        at this body velocity from the next step on; from then on the base's pose is a recorded
        kinematic write every step. ``joint``: the base's free joint (default the first)."""
        if self._planar is None or (joint is not None and joint != self._planar.joint):
            self._planar = PlanarBase(self.model, joint)
        self._planar.command(linear_x, linear_y, angular_z)
        self._dirty = True
        self._fast = self._kin_fast = False

    def apply_wrench(
        self, body: str, force: Sequence[float], torque: Sequence[float] = (0.0, 0.0, 0.0)
    ) -> None:
        """Apply a world-frame force and torque at ``body``'s centre of mass from the next step
        on (it holds until changed; zero to stop)."""
        bid, wrench = body_wrench(self.model, body, force, torque)
        self._xfrc[bid] = wrench
        self._dirty = True
        self._fast = self._kin_fast = False

    def joint_commands(self) -> F64:
        """The current command per joint, in the unit of its mode's field."""
        commands: F64 = self._cmd.copy()
        return commands

    def _apply(self, entries: list[Entry]) -> list[Notice]:
        notices, kin, dyn = self._commands.apply(self._commands.validate(entries))
        self._mark_dirty(kin, dyn)
        return notices

    def _mark_dirty(self, kin: bool, dyn: bool) -> None:
        """New commands for kinematic joints (``kin``) or dynamic ones (``dyn``) take effect at
        the next step; kinematic ones alone keep the kinematic fast path."""
        if kin:
            self._kin_dirty = True
            self._fast = False
        if dyn:
            self._dirty = True
            self._fast = self._kin_fast = False

    # ----------------------------------------------------------------------------- reads

    @property
    def kinematic_joints(self) -> tuple[str, ...]:
        """Joints written kinematically each step (mimic followers of kinematic joints too)."""
        return self._kin_names

    def joint_positions(self) -> F64:
        """Positions of :attr:`joint_names` (rad or m)."""
        return np.array(self.data.qpos[self._qadr], dtype=np.float64)

    def joint_velocities(self) -> F64:
        """Velocities of :attr:`joint_names`."""
        return np.array(self.data.qvel[self._dadr], dtype=np.float64)

    def joint_efforts(self) -> F64:
        """Generalised force per joint: the actuator's (after the joint's force limit) for
        dynamic joints, the applied generalised force (``qfrc_applied``) for kinematic ones."""
        if not self._has_kin:  # what np.where gives then, for less (a new array too)
            actuator: F64 = self.data.qfrc_actuator[self._dadr]
            return actuator
        efforts: F64 = np.where(
            self._is_kin, self.data.qfrc_applied[self._dadr], self.data.qfrc_actuator[self._dadr]
        )
        return efforts

    def link_poses(self) -> dict[str, tuple[F64, F64]]:
        """Every named body's world pose as ``(xyz, quat w-x-y-z)``, for the current state."""
        return self._poses.by_name(self.data)

    def body_poses(self) -> tuple[F64, F64]:
        """Every body's world position (``nbody x 3``) and orientation (``nbody x 4``, w-x-y-z)
        for the current state, by body id (0: the world). The arrays are reused: read them
        before the next call."""
        return self._poses.read(self.data)

    def contacts(self) -> ContactSet:
        """The contacts of the last step (see :func:`harness.sim.contacts.extract_contacts`)."""
        return extract_contacts(self.model, self.data)

    def body_name(self, body_id: int) -> str:
        """A body's name (``"body<id>"`` when unnamed)."""
        return object_name(self.model, mujoco.mjtObj.mjOBJ_BODY, body_id) or f"body{body_id}"

    def geom_name(self, geom_id: int) -> str:
        """A geom's name (``"geom<id>"`` when unnamed)."""
        return object_name(self.model, mujoco.mjtObj.mjOBJ_GEOM, geom_id) or f"geom{geom_id}"

    def warning_counts(self) -> dict[str, int]:
        """MuJoCo's warning counters by name (all zero while the run is valid)."""
        return {n: int(c) for n, c in zip(self._warning_names, self._warnings, strict=True)}
