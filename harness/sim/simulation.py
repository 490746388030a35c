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

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from types import EllipsisType, MappingProxyType
from typing import Literal, NamedTuple, Protocol

import mujoco
import numpy as np
import numpy.typing as npt

from harness.errors import SimulationError
from harness.models.description import CONTROL_MODES, ControlMode, RobotModel
from harness.models.world import LoadedWorld
from harness.sim.contacts import ContactSet, extract_contacts
from harness.sim.errors import (
    CommandError,
    ControlConfigError,
    InstabilityError,
    StateError,
    TimestepError,
)
from harness.sim.inputs import AppliedInput
from harness.sim.planar import PlanarBase
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
_Key = EllipsisType | npt.NDArray[np.intp]

STATE_SPEC = int(mujoco.mjtState.mjSTATE_INTEGRATION)
"""The ``mjtState`` mask of every captured state: FULLPHYSICS alone misses the solver
warmstart and does not restore bit-exactly."""

CommandField = Literal["position", "velocity", "effort"]
Observer = Callable[["Simulation"], None]

_FIELD_OF_MODE: dict[str, CommandField] = {
    "kinematic": "position",
    "position": "position",
    "velocity": "velocity",
    "effort": "effort",
}
_WARNING_MEANING = {
    "INERTIA": "invalid inertia",
    "CONTACTFULL": "too many contacts, some dropped",
    "CNSTRFULL": "constraint buffer full, some dropped",
    "BADQPOS": "bad position, MuJoCo auto-reset the state",
    "BADQVEL": "bad velocity, MuJoCo auto-reset the state",
    "BADQACC": "bad acceleration, MuJoCo auto-reset the state",
    "BADCTRL": "bad control value",
}
_mj_step = mujoco.mj_step
_EMPTY_F = np.zeros(0, dtype=np.float64)
_EMPTY_U = np.zeros(0, dtype=np.uint32)


def warning_names() -> tuple[str, ...]:
    """MuJoCo's warning names by index (``"BADQACC"``, ...), as in ``data.warning``."""
    members = mujoco.mjtWarning.__members__
    by_index = {int(v): k.removeprefix("mjWARN_") for k, v in members.items() if k != "mjNWARNING"}
    return tuple(by_index[i] for i in sorted(by_index))


class RobotLike(Protocol):
    """What :class:`Simulation` needs from a loaded robot (``harness.models.LoadedRobot``)."""

    @property
    def description(self) -> RobotModel: ...

    @property
    def model(self) -> mujoco.MjModel: ...

    @property
    def control(self) -> Mapping[str, ControlMode]: ...


class Notice(NamedTuple):
    """Something a command did not do as asked: ``kind`` is ``"clamped"`` (``applied`` is the
    value used) or ``"ignored"`` (the field does not apply to the joint's mode; ``applied`` is
    NaN). The session turns notices into warning events."""

    joint: str
    kind: Literal["clamped", "ignored"]
    field: CommandField
    requested: float
    applied: float
    message: str


class _Mimic(NamedTuple):
    leader_row: int  # index into the kinematic leaders
    qpos_adr: int
    dof_adr: int
    name: str
    coef: tuple[float, float, float, float, float]
    follower_ref: float
    leader_ref: float


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


def _write_target(array: F64, index: npt.NDArray[np.integer]) -> tuple[F64, _Key]:
    """Where ``array[index] = values`` writes, as ``(target, key)`` for ``target[key] =
    values``: a view and ``...`` when ``index`` is a run of consecutive addresses (the same
    elements, written for much less per step), else ``array`` and ``index``."""
    size = int(index.size)
    first = int(index[0]) if size else 0
    if np.array_equal(index, np.arange(first, first + size)):
        return array[first : first + size], ...
    return array, np.asarray(index, dtype=np.intp)


def _name(model: mujoco.MjModel, obj: mujoco.mjtObj, index: int) -> str:
    return mujoco.mj_id2name(model, obj, index) or ""


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
        self._keyframe = -1
        if keyframe is not None:
            self._keyframe = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe)
            if self._keyframe < 0 and keyframe != "home":
                raise ControlConfigError(f"the model has no keyframe {keyframe!r}")
            if self._keyframe >= 0 and float(model.key_time[self._keyframe]) != 0.0:
                raise ControlConfigError(
                    f"keyframe {keyframe!r} has time {float(model.key_time[self._keyframe])!r}: "
                    "the initial state must be at time 0"
                )
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
        self._scratch: mujoco.MjData | None = None

        actuators: dict[int, list[int]] = {}
        for act in range(model.nu):
            if int(model.actuator_trntype[act]) == int(mujoco.mjtTrn.mjTRN_JOINT):
                actuators.setdefault(int(model.actuator_trnid[act][0]), []).append(act)
        mimics = self._mimic_equalities(model)

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
                    f"joint {name!r}: control mode {mode!r} is not one of "
                    f"{', '.join(CONTROL_MODES)}"
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
                lead = _name(model, mujoco.mjtObj.mjOBJ_JOINT, mimics[jid][0])
                raise ControlConfigError(
                    f"joint {name!r} mimics {lead!r} (joint equality): command {lead!r}"
                )
            acts = actuators.get(jid, [])
            act_names = ", ".join(repr(_name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a)) for a in acts)
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
            lo, hi = self._command_range(model, jid, acts[0] if acts else -1, name, mode)
            names.append(name)
            modes.append(mode)
            qadr.append(int(model.jnt_qposadr[jid]))
            dadr.append(int(model.jnt_dofadr[jid]))
            lows.append(lo)
            highs.append(hi)

        self._names = tuple(names)
        self._index = {n: i for i, n in enumerate(names)}
        self._modes = tuple(modes)
        self._qadr = np.array(qadr, dtype=np.intp)
        self._dadr = np.array(dadr, dtype=np.intp)
        self._lo = np.array(lows, dtype=np.float64)
        self._hi = np.array(highs, dtype=np.float64)
        self._cmd: F64 = np.zeros(len(names), dtype=np.float64)
        self._is_kin = np.array([m == "kinematic" for m in modes], dtype=bool)
        self._dyn_rows = np.flatnonzero(~self._is_kin)
        self._dyn_act = np.array([act_of[r] for r in self._dyn_rows], dtype=np.intp)
        self._kin_rows = np.flatnonzero(self._is_kin)
        self._has_kin = bool(self._kin_rows.size)
        # Per-row facts as plain Python values: commands read them for every joint they name.
        self._wanted = tuple(_FIELD_OF_MODE[m] for m in modes)
        self._row_is_kin = tuple(m == "kinematic" for m in modes)
        self._lo_list = tuple(lows)
        self._hi_list = tuple(highs)

        # Kinematic writes: the kinematic joints, then the mimic followers of those joints.
        leader_row = {int(self._qadr[r]): i for i, r in enumerate(self._kin_rows)}
        followers: list[_Mimic] = []
        for follower, (leader, coef) in sorted(mimics.items()):
            row = leader_row.get(int(model.jnt_qposadr[leader]))
            if row is not None:
                followers.append(
                    _Mimic(
                        leader_row=row,
                        qpos_adr=int(model.jnt_qposadr[follower]),
                        dof_adr=int(model.jnt_dofadr[follower]),
                        name=_name(model, mujoco.mjtObj.mjOBJ_JOINT, follower),
                        coef=coef,
                        follower_ref=float(model.qpos0[model.jnt_qposadr[follower]]),
                        leader_ref=float(model.qpos0[model.jnt_qposadr[leader]]),
                    )
                )
        self._followers = tuple(followers)
        # The kinematic writes' positions gather the commands of the kinematic rows, then each
        # follower's leader's (turned into the follower's by the mimic law: _follow holds the
        # slot, leader_ref, follower_ref, c0..c4).
        self._kin_gather = np.array(
            [*self._kin_rows, *(self._kin_rows[f.leader_row] for f in followers)], dtype=np.intp
        )
        self._follow = tuple(
            (self._kin_rows.size + i, f.leader_ref, f.follower_ref, *f.coef)
            for i, f in enumerate(followers)
        )
        self._kin_names = tuple(self._names[r] for r in self._kin_rows) + tuple(
            f.name for f in followers
        )
        self._kin_qadr = np.array(
            [*self._qadr[self._kin_rows], *(f.qpos_adr for f in followers)], dtype=np.uint32
        )
        self._kin_dadr = np.array(
            [*self._dadr[self._kin_rows], *(f.dof_adr for f in followers)], dtype=np.uint32
        )
        # The kinematic writes' targets in the simulation's own MjData (its buffers are never
        # reallocated, so views of them stay valid).
        self._kin_qpos, self._kin_qkey = _write_target(self.data.qpos, self._kin_qadr)
        self._kin_qvel, self._kin_dkey = _write_target(self.data.qvel, self._kin_dadr)
        self._bodies = tuple(
            (b, n)
            for b in range(1, model.nbody)
            if (n := _name(model, mujoco.mjtObj.mjOBJ_BODY, b))
        )
        self.reset()

    @staticmethod
    def _mimic_equalities(
        model: mujoco.MjModel,
    ) -> dict[int, tuple[int, tuple[float, float, float, float, float]]]:
        """follower joint id -> (leader joint id, polynomial coefficients), from the active
        joint equalities (URDF ``<mimic>`` becomes one)."""
        out: dict[int, tuple[int, tuple[float, float, float, float, float]]] = {}
        for e in range(model.neq):
            if int(model.eq_type[e]) != int(mujoco.mjtEq.mjEQ_JOINT):
                continue
            if not model.eq_active0[e] or int(model.eq_obj2id[e]) < 0:
                continue
            c = [float(v) for v in model.eq_data[e][:5]]
            out[int(model.eq_obj1id[e])] = (int(model.eq_obj2id[e]), (c[0], c[1], c[2], c[3], c[4]))
        return out

    def _command_range(
        self, model: mujoco.MjModel, jid: int, act: int, name: str, mode: ControlMode
    ) -> tuple[float, float]:
        lo, hi = -math.inf, math.inf
        limits = None
        if self.description is not None:
            try:
                limits = self.description.joint(name).limits
            except KeyError:
                limits = None
        if mode == "position" or (mode == "kinematic" and self.kinematic_limits == "clamp"):
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

    # ----------------------------------------------------------------------------- state

    def reset(self) -> None:
        """Back to the initial state at step 0 (the keyframe, else the model's ``qpos0``);
        every joint holds its initial position (position servos target it, velocity and effort
        commands are 0)."""
        if self._keyframe >= 0:
            mujoco.mj_resetDataKeyframe(self.model, self.data, self._keyframe)
        else:
            mujoco.mj_resetData(self.model, self.data)
        for r, mode in enumerate(self._modes):
            q = float(self.data.qpos[self._qadr[r]])
            if mode == "kinematic":
                self._cmd[r] = q
            elif mode == "position":
                self._cmd[r] = min(max(q, self._lo[r]), self._hi[r])
            else:
                self._cmd[r] = 0.0
        self.data.ctrl[self._dyn_act] = self._cmd[self._dyn_rows]
        # a filtered position command (the drive's setpoint filter) starts at its command
        model = self.model
        for act in self._dyn_act.tolist():
            adr = int(model.actuator_actadr[act])
            if adr >= 0 and model.actuator_dyntype[act] == mujoco.mjtDyn.mjDYN_FILTEREXACT:
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
            raise StateError(
                f"get_state(out=): out must be a writable C-contiguous float64 array of "
                f"{self._state_size} values, not {getattr(out, 'dtype', type(out).__name__)} "
                f"of shape {getattr(out, 'shape', '?')}"
            ) from None
        return out

    def set_state(self, state: npt.ArrayLike, step_index: int) -> None:
        """Restore a state captured by :meth:`get_state` at ``step_index``. Commands are taken
        from it: positions held, ctrl as in the state."""
        arr = np.asarray(state, dtype=np.float64)
        if arr.shape != (self._state_size,):
            raise StateError(
                f"state has shape {arr.shape}, the model's INTEGRATION state has "
                f"({self._state_size},)"
            )
        if not np.all(np.isfinite(arr)):
            raise StateError("state holds non-finite values")
        if step_index < 0:
            raise StateError(f"step_index must be >= 0, not {step_index}")
        # mjSTATE_TIME is the first component of every state.
        if abs(float(arr[0]) - step_index * self._dt) > self._half_dt:
            raise StateError(
                f"state time {float(arr[0])!r} s does not match step {step_index} "
                f"(step * dt = {step_index * self.dt_ns / 1e9!r} s)"
            )
        mujoco.mj_setState(self.model, self.data, arr, STATE_SPEC)
        self._cmd[self._kin_rows] = self.data.qpos[self._qadr[self._kin_rows]]
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
            pos = self._kinematic_targets() if self._kin_dirty else self._kin_pos
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
            self._kin_pos = self._kinematic_targets()
        if self._has_kin:
            self._kin_vel = (self._kin_pos - self._kin_prev) / self._dt
            self._kin_prev = self._kin_pos
            self._kin_moving = bool(self._kin_vel.any())
        self._dirty = self._kin_dirty = False
        self._update_fast()
        nmocap = self.model.nmocap
        qfrc = data.qfrc_applied
        xfrc = data.xfrc_applied
        kin_names = self._kin_names
        qpos_i, qpos_v, qvel_i, qvel_v = _EMPTY_U, _EMPTY_F, _EMPTY_U, _EMPTY_F
        if self._has_kin:
            qpos_i, qpos_v = self._kin_qadr, self._kin_pos.copy()
            qvel_i, qvel_v = self._kin_dadr, self._kin_vel.copy()
        if self._planar is not None:
            # The planar base's write joins the kinematic writes (recorded, replayed alike).
            base_q, base_v = self._planar.write(data.qpos, self._dt)
            kin_names = (*kin_names, self._planar.joint)
            qpos_i = np.concatenate([qpos_i, self._planar.qpos_index])
            qpos_v = np.concatenate([qpos_v, base_q])
            qvel_i = np.concatenate([qvel_i, self._planar.qvel_index])
            qvel_v = np.concatenate([qvel_v, base_v])
        applied = AppliedInput(
            step=self._step + 1,
            sim_time_ns=(self._step + 1) * self.dt_ns,
            ctrl=np.array(data.ctrl, dtype=np.float64),
            kinematic_joints=kin_names,
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
        self._changed = self._applied is None or not applied.same_physics(self._applied)
        self._applied = applied

    def _kinematic_targets(self) -> F64:
        """A new array of the kinematic writes' positions: the commands, then the mimic
        followers' (never changed in place afterwards: applied inputs share it)."""
        out: F64 = self._cmd[self._kin_gather]  # fancy indexing: a new array
        for slot, leader_ref, follower_ref, c0, c1, c2, c3, c4 in self._follow:
            x = out.item(slot) - leader_ref
            out[slot] = follower_ref + c0 + x * (c1 + x * (c2 + x * (c3 + x * c4)))
        return out

    def _fail(self, step: int) -> None:
        counts = self._warnings
        nonzero = np.flatnonzero(counts)
        if nonzero.size:
            index = int(nonzero[0])
            warning = self._warning_names[index]
            info = int(self.data.warning.lastinfo[index])
            where = ""
            if warning in ("BADQACC", "BADQVEL") and 0 <= info < self.model.nv:
                joint = _name(
                    self.model, mujoco.mjtObj.mjOBJ_JOINT, int(self.model.dof_jntid[info])
                )
                where = f" at dof {info} (joint {joint!r})"
            message = (
                f"step {step} (sim time {step * self.dt_ns} ns): MuJoCo warning {warning}"
                f"{where}: {_WARNING_MEANING.get(warning, 'see MuJoCo docs')}; the run is no "
                "longer valid (lower gains or the timestep, or check masses and forces)"
            )
        else:
            warning = "TIME"
            message = (
                f"step {step}: simulation time {self.data.time!r} s does not match "
                f"step * dt = {step * self.dt_ns / 1e9!r} s (time jumped: did MuJoCo reset?)"
            )
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
        return MappingProxyType(dict(zip(self._names, self._modes, strict=True)))

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
        entries = [(joint, f, v) for f, v in given.items() if v is not None]
        return self._apply(self._validate(entries))

    def set_positions(self, positions: Mapping[str, float]) -> list[Notice]:
        """Position commands for several joints (all validated before any applies)."""
        return self._apply_field("position", positions)

    def set_velocities(self, velocities: Mapping[str, float]) -> list[Notice]:
        """Velocity commands for several joints (all validated before any applies)."""
        return self._apply_field("velocity", velocities)

    def set_efforts(self, efforts: Mapping[str, float]) -> list[Notice]:
        """Effort commands for several joints (all validated before any applies)."""
        return self._apply_field("effort", efforts)

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
        entries: list[tuple[str, str, object]] = []
        for field, values in (("effort", effort), ("velocity", velocity), ("position", position)):
            if len(values) > len(name):
                raise CommandError(
                    f"joint state command has {len(values)} {field} values for {len(name)} names"
                )
            entries.extend((name[i], field, values[i]) for i in range(len(values)))
        return self._apply(self._validate(entries))

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
        bid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, body)
        if bid <= 0:
            raise CommandError(f"unknown body {body!r} for apply_wrench")
        wrench = np.array([*force, *torque], dtype=np.float64)
        if wrench.shape != (6,) or not np.all(np.isfinite(wrench)):
            raise CommandError(f"body {body!r}: force and torque must be 3 finite values each")
        self._xfrc[bid] = wrench
        self._dirty = True
        self._fast = self._kin_fast = False

    def joint_commands(self) -> F64:
        """The current command per joint, in the unit of its mode's field."""
        commands: F64 = self._cmd.copy()
        return commands

    def _validate(self, entries: Iterable[tuple[str, str, object]]) -> list[tuple[int, str, float]]:
        out: list[tuple[int, str, float]] = []
        for joint, field, raw in entries:
            row = self._index.get(joint)
            if row is None:
                known = ", ".join(self._names) or "none"
                raise CommandError(f"unknown joint {joint!r} (controllable joints: {known})")
            try:
                value = float(raw)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                raise CommandError(f"joint {joint!r}: {field} {raw!r} is not a number") from None
            if not math.isfinite(value):
                raise CommandError(f"joint {joint!r}: {field} {value!r} is not finite")
            out.append((row, field, value))
        return out

    def _apply_field(self, field: CommandField, values: Mapping[str, float]) -> list[Notice]:
        """Commands of one field, one per joint (a mapping names each joint once): what
        ``_apply(_validate(...))`` does for them, in one pass (a client may send these every
        step). Every value is checked before any applies."""
        index, wanted, lows, highs = self._index, self._wanted, self._lo_list, self._hi_list
        notices: list[Notice] = []
        writes: list[tuple[int, float]] = []
        for joint, raw in values.items():
            row = index.get(joint)
            if row is None:
                known = ", ".join(self._names) or "none"
                raise CommandError(f"unknown joint {joint!r} (controllable joints: {known})")
            try:
                value = float(raw)
            except (TypeError, ValueError):
                raise CommandError(f"joint {joint!r}: {field} {raw!r} is not a number") from None
            if not math.isfinite(value):
                raise CommandError(f"joint {joint!r}: {field} {value!r} is not finite")
            if wanted[row] != field:
                notices.append(self._ignored(row, field, value))
                continue
            # min(max(value, low), high), for less
            applied = value
            if applied < lows[row]:
                applied = lows[row]
            if applied > highs[row]:
                applied = highs[row]
            if applied != value:
                notices.append(self._clamped(row, value, applied))
            writes.append((row, applied))
        cmd, row_is_kin = self._cmd, self._row_is_kin
        kin = dyn = False
        for row, applied in writes:
            cmd[row] = applied
            if row_is_kin[row]:
                kin = True
            else:
                dyn = True
        self._mark_dirty(kin, dyn)
        return notices

    def _apply(self, entries: list[tuple[int, str, float]]) -> list[Notice]:
        notices: list[Notice] = []
        by_row: dict[int, dict[str, float]] = {}
        for row, field, value in entries:
            by_row.setdefault(row, {})[field] = value
        kin = dyn = False
        for row, fields in by_row.items():
            wanted = self._wanted[row]
            if wanted not in fields:
                for field, value in fields.items():
                    notices.append(self._ignored(row, field, value))
                continue
            value = fields[wanted]
            applied = min(max(value, self._lo_list[row]), self._hi_list[row])
            if applied != value:
                notices.append(self._clamped(row, value, applied))
            self._cmd[row] = applied
            if self._row_is_kin[row]:
                kin = True
            else:
                dyn = True
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

    def _ignored(self, row: int, field: str, value: float) -> Notice:
        name, mode = self._names[row], self._modes[row]
        return Notice(
            name,
            "ignored",
            field,  # type: ignore[arg-type]
            value,
            math.nan,
            f"joint {name!r} is {mode}-controlled: {field} command ignored",
        )

    def _clamped(self, row: int, value: float, applied: float) -> Notice:
        name, wanted = self._names[row], self._wanted[row]
        lo, hi = self._lo_list[row], self._hi_list[row]
        return Notice(
            name,
            "clamped",
            wanted,
            value,
            applied,
            f"joint {name!r}: {wanted} {value:g} is beyond its limits "
            f"[{lo:g}, {hi:g}]: clamped to {applied:g}",
        )

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
        xpos, xquat = self.body_poses()
        return {n: (xpos[b].copy(), xquat[b].copy()) for b, n in self._bodies}

    def body_poses(self) -> tuple[F64, F64]:
        """Every body's world position (``nbody x 3``) and orientation (``nbody x 4``, w-x-y-z)
        for the current state, by body id (0: the world). The arrays are reused: read them
        before the next call."""
        if self._scratch is None:
            self._scratch = mujoco.MjData(self.model)
        scratch = self._scratch
        scratch.qpos[:] = self.data.qpos
        if self.model.nmocap:
            scratch.mocap_pos[:] = self.data.mocap_pos
            scratch.mocap_quat[:] = self.data.mocap_quat
        mujoco.mj_kinematics(self.model, scratch)
        return scratch.xpos, scratch.xquat

    def contacts(self) -> ContactSet:
        """The contacts of the last step (see :func:`harness.sim.contacts.extract_contacts`)."""
        return extract_contacts(self.model, self.data)

    def body_name(self, body_id: int) -> str:
        """A body's name (``"body<id>"`` when unnamed)."""
        return _name(self.model, mujoco.mjtObj.mjOBJ_BODY, body_id) or f"body{body_id}"

    def geom_name(self, geom_id: int) -> str:
        """A geom's name (``"geom<id>"`` when unnamed)."""
        return _name(self.model, mujoco.mjtObj.mjOBJ_GEOM, geom_id) or f"geom{geom_id}"

    def warning_counts(self) -> dict[str, int]:
        """MuJoCo's warning counters by name (all zero while the run is valid)."""
        return {n: int(c) for n, c in zip(self._warning_names, self._warnings, strict=True)}
