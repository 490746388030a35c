"""Kinematic <-> dynamic re-simulation: the measurable version of "jumping".

The recorded joint commands are the *position targets* the recorded run applied, read from
the applied inputs: for a joint driven by a position actuator, its ``ctrl`` value; for a
kinematic joint, the ``qpos_value`` written for it. Joints recorded in velocity or effort mode
have no position target: the re-simulation uses their recorded positions as targets. The
other mode re-simulates these targets from the recorded initial configuration with every
controllable joint ``kinematic`` (written each step, limits *not* clamped: that is what
teleporting does) or ``dynamic`` (position servos with the model's default gains, clamped to
the joint range as a servo's ctrlrange is). The robot is rebuilt from the recording's source
attachments with :func:`harness.models.load_robot` (a world of several robots with
:func:`harness.models.load_world`: :func:`harness.replay.source.rebuild_run`; its joints are
named by their MuJoCo, prefixed, names).

Both runs (the recorded one, replayed from its own inputs, and the re-simulation) are
measured the same way, per step: tracking error ``|q - q_target|``, limit violation
``max(q - hi, lo - q, 0)``, speed against the description's velocity limits, peak
penetration of any contact, total energy rise between steps, and which body pairs touch.
A :class:`Finding` is the first step at which a quantity exceeds its threshold.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Literal, NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from harness.errors import HarnessError
from harness.models import RobotModel
from harness.replay.errors import LevelUnavailableError, RecordedDataError
from harness.replay.source import (
    check_states_fit,
    control_modes,
    open_recording,
    read_inputs,
    read_states,
    rebuild_run,
    run_description,
)
from harness.replay.verify import Progress
from harness.sim import InstabilityError, Simulation
from harness.sim.collisions import CollisionTracker
from harness.sim.inputs import AppliedInput, advance
from harness.sim.metrics import energy

__all__ = [
    "Finding",
    "JointSummary",
    "ResimMode",
    "ResimReport",
    "RunSummary",
    "Thresholds",
    "resimulate",
]

F64 = npt.NDArray[np.float64]
ResimMode = Literal["kinematic", "dynamic"]


class Thresholds(NamedTuple):
    """Limits above which a quantity is a :class:`Finding` (and the exit code non-zero)."""

    max_tracking_error: float = 0.05
    """rad (or m): |q - q_target| of a joint."""
    max_limit_violation: float = 1e-3
    """rad (or m) beyond a joint's position limit."""
    max_velocity_ratio: float = 1.0
    """|qvel| / the description's velocity limit."""
    max_penetration: float = 0.005
    """m: the deepest contact penetration."""
    max_energy_jump: float = 0.5
    """J: total (kinetic + potential) energy rise from one step to the next."""


@dataclass(frozen=True)
class Finding:
    """The first step at which ``quantity`` of ``name`` exceeded its threshold in ``run``."""

    run: str  # "recorded" or "resimulated"
    quantity: str  # tracking_error, limit_violation, velocity_ratio, penetration, energy_jump
    name: str  # joint name ("" for whole-run quantities)
    step: int
    value: float
    threshold: float


@dataclass(frozen=True)
class JointSummary:
    """One joint's worst values in one run, with the step of each (-1: never above 0)."""

    joint: str
    max_tracking_error: float
    tracking_step: int
    max_limit_violation: float
    violation_step: int
    max_velocity_ratio: float
    velocity_step: int


@dataclass(frozen=True)
class RunSummary:
    """One run's metrics."""

    label: str
    control: str
    joints: tuple[JointSummary, ...]
    peak_penetration: float
    penetration_step: int
    max_energy_jump: float
    energy_step: int
    contact_pairs: dict[str, int]  # "body1|body2" -> first step in contact
    unstable_at: int | None


@dataclass(frozen=True)
class ResimReport:
    """Recorded run and re-simulation side by side (``passed``: no finding)."""

    path: str
    mode: ResimMode
    steps: int
    thresholds: dict[str, float]
    recorded: RunSummary
    resimulated: RunSummary
    findings: tuple[Finding, ...]
    contacts_appearing: tuple[str, ...]
    contacts_disappearing: tuple[str, ...]
    wall_seconds: float

    @property
    def passed(self) -> bool:
        """True when no threshold was exceeded in either run."""
        return not self.findings

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return {**asdict(self), "passed": self.passed}

    def format(self) -> str:
        """The side-by-side table."""
        a, b = self.recorded, self.resimulated
        lines = [
            f"{self.path}: {self.steps} steps, recorded ({a.control}) vs re-simulated "
            f"({b.control})",
            f"  {'joint':<16} {'tracking error (rad)':>27} {'limit violation (rad)':>27} "
            f"{'speed / limit':>23}",
        ]

        def cell(value: float, step: int, width: int) -> str:
            text = "-" if math.isnan(value) else f"{value:.4g}"
            if step >= 0 and not math.isnan(value) and value > 0:
                text += f" @{step}"
            return f"{text:>{width}}"

        for ja, jb in zip(a.joints, b.joints, strict=True):
            lines.append(
                f"  {ja.joint:<16} {cell(ja.max_tracking_error, ja.tracking_step, 13)} |"
                f"{cell(jb.max_tracking_error, jb.tracking_step, 12)} "
                f"{cell(ja.max_limit_violation, ja.violation_step, 13)} |"
                f"{cell(jb.max_limit_violation, jb.violation_step, 12)} "
                f"{cell(ja.max_velocity_ratio, ja.velocity_step, 11)} |"
                f"{cell(jb.max_velocity_ratio, jb.velocity_step, 10)}"
            )
        lines.append(
            f"  peak penetration (m): {cell(a.peak_penetration, a.penetration_step, 0)} | "
            f"{cell(b.peak_penetration, b.penetration_step, 0)}"
        )
        lines.append(
            f"  max energy jump (J):  {cell(a.max_energy_jump, a.energy_step, 0)} | "
            f"{cell(b.max_energy_jump, b.energy_step, 0)}"
        )
        for run in (a, b):
            if run.unstable_at is not None:
                lines.append(f"  {run.label}: UNSTABLE at step {run.unstable_at}")
        if self.contacts_appearing:
            lines.append(f"  contacts only when re-simulated: {', '.join(self.contacts_appearing)}")
        if self.contacts_disappearing:
            lines.append(f"  contacts only when recorded: {', '.join(self.contacts_disappearing)}")
        if not self.findings:
            lines.append("PASSED: no threshold exceeded")
        for f in self.findings:
            what = f"{f.quantity} {f.name}".strip()
            lines.append(
                f"EXCEEDED ({f.run}): {what} = {f.value:.4g} > {f.threshold:g} at step {f.step}"
            )
        return "\n".join(lines)


class _Trace:
    """Per-step rows of one run."""

    def __init__(self, model: mujoco.MjModel, joints: Sequence[str]) -> None:
        self.model = model
        ids = [model.joint(j).id for j in joints]
        self.qadr = np.array([model.jnt_qposadr[i] for i in ids], dtype=np.intp)
        self.dadr = np.array([model.jnt_dofadr[i] for i in ids], dtype=np.intp)
        self.names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
                      for b in range(model.nbody)]  # fmt: skip
        self.tracker = CollisionTracker()
        self.steps: list[int] = []
        self.q: list[F64] = []
        self.v: list[F64] = []
        self.qpos: list[F64] = []
        self.qvel: list[F64] = []
        self.pen: list[float] = []
        self.pairs: dict[str, int] = {}

    def observe(self, step: int, data: mujoco.MjData, dt_ns: int) -> None:
        self.steps.append(step)
        self.q.append(data.qpos[self.qadr].copy())
        self.v.append(data.qvel[self.dadr].copy())
        self.qpos.append(data.qpos.copy())
        self.qvel.append(data.qvel.copy())
        depth = data.contact.dist[: data.ncon]
        self.pen.append(max(0.0, -float(depth.min())) if depth.size else 0.0)
        from harness.sim.contacts import extract_contacts

        for t in self.tracker.update(step, step * dt_ns, extract_contacts(self.model, data)):
            if t.kind == "begin":
                key = f"{self.names[t.body1]}|{self.names[t.body2]}"
                self.pairs.setdefault(key, t.step)


def _targets(
    model: mujoco.MjModel, joints: Sequence[str], inp: AppliedInput | None, q_now: F64
) -> F64:
    """The position target of each joint under ``inp`` (recorded position where none)."""
    out: F64 = q_now.copy()
    if inp is None:
        return out
    act_of: dict[int, int] = {}
    for a in range(model.nu):
        if int(model.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT):
            act_of[int(model.actuator_trnid[a][0])] = a
    written = dict(zip(inp.qpos_index.tolist(), inp.qpos_value.tolist(), strict=True))
    for i, name in enumerate(joints):
        jid = model.joint(name).id
        adr = int(model.jnt_qposadr[jid])
        if adr in written:
            out[i] = written[adr]
        elif jid in act_of:
            a = act_of[jid]
            biastype = int(model.actuator_biastype[a])
            gain = float(model.actuator_gainprm[a][0])
            if (
                biastype == int(mujoco.mjtBias.mjBIAS_AFFINE)
                and model.actuator_biasprm[a][1] == -gain
            ):
                out[i] = float(inp.ctrl[a])
    return out


class _Measured(NamedTuple):
    summary: RunSummary
    tracking: F64
    violation: F64
    ratio: F64
    penetration: F64
    rises: F64
    steps: npt.NDArray[np.int64]


def _measure(
    label: str,
    control: str,
    trace: _Trace,
    targets: F64,
    model: mujoco.MjModel,
    description: RobotModel,
    joints: Sequence[str],
    unstable_at: int | None,
) -> _Measured:
    steps = np.array(trace.steps, dtype=np.int64)
    q = np.stack(trace.q)
    v = np.stack(trace.v)
    lower = np.full(len(joints), -np.inf)
    upper = np.full(len(joints), np.inf)
    vmax = np.full(len(joints), np.nan)
    for i, name in enumerate(joints):
        jid = model.joint(name).id
        if model.jnt_limited[jid]:
            lower[i], upper[i] = model.jnt_range[jid]
        try:
            limit = description.joint(name).limits.velocity
        except KeyError:
            limit = None
        if limit:
            vmax[i] = abs(limit)
    tracking = np.abs(q - targets[: q.shape[0]])
    violation = np.maximum(np.maximum(q - upper, lower - q), 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.abs(v) / vmax
    summaries = []

    def worst(values: F64, column: int) -> tuple[float, int]:
        col = values[:, column]
        if np.all(np.isnan(col)):
            return math.nan, -1
        index = int(np.nanargmax(col))
        return float(col[index]), int(steps[index])

    for i, name in enumerate(joints):
        t, ts = worst(tracking, i)
        lv, ls = worst(violation, i)
        vr, vs = worst(ratio, i)
        summaries.append(JointSummary(name, t, ts, lv, ls, vr, vs))
    pen = np.array(trace.pen)
    p_index = int(np.argmax(pen))
    total = energy(model, np.stack(trace.qpos), np.stack(trace.qvel)).sum(axis=1)
    rises = np.diff(total) if total.size > 1 else np.zeros(1)
    e_index = int(np.argmax(rises))
    summary = RunSummary(
        label=label,
        control=control,
        joints=tuple(summaries),
        peak_penetration=float(pen[p_index]),
        penetration_step=int(steps[p_index]),
        max_energy_jump=float(rises[e_index]),
        energy_step=int(steps[e_index + 1]) if total.size > 1 else -1,
        contact_pairs=dict(trace.pairs),
        unstable_at=unstable_at,
    )
    return _Measured(summary, tracking, violation, ratio, pen, rises, steps)


def _findings(run: str, joints: Sequence[str], m: _Measured, th: Thresholds) -> list[Finding]:
    tracking, violation, ratio, pen, rises = (
        m.tracking,
        m.violation,
        m.ratio,
        m.penetration,
        m.rises,
    )
    steps = m.steps
    out: list[Finding] = []
    for quantity, values, limit in (
        ("limit_violation", violation, th.max_limit_violation),
        ("velocity_ratio", ratio, th.max_velocity_ratio),
        ("tracking_error", tracking, th.max_tracking_error),
    ):
        for i, name in enumerate(joints):
            with np.errstate(invalid="ignore"):
                above = np.flatnonzero(values[:, i] > limit)
            if above.size:
                k = int(above[0])
                out.append(Finding(run, quantity, name, int(steps[k]), float(values[k, i]), limit))
    above = np.flatnonzero(pen > th.max_penetration)
    if above.size:
        k = int(above[0])
        out.append(
            Finding(run, "penetration", "", int(steps[k]), float(pen[k]), th.max_penetration)
        )
    above = np.flatnonzero(rises > th.max_energy_jump)
    if above.size:
        k = int(above[0])
        out.append(
            Finding(run, "energy_jump", "", int(steps[k + 1]), float(rises[k]), th.max_energy_jump)
        )
    return out


def resimulate(
    path: str | Path,
    mode: ResimMode,
    *,
    thresholds: Thresholds | None = None,
    allow_damaged: bool = False,
    progress: Progress | None = None,
) -> ResimReport:
    """Re-simulate the recorded joint commands of ``path`` with every controllable joint in
    ``mode`` and measure both runs (see the module docstring)."""
    if mode not in ("kinematic", "dynamic"):
        raise LevelUnavailableError(f"unknown mode {mode!r} (kinematic or dynamic)")
    th = thresholds if thresholds is not None else Thresholds()
    started = time.perf_counter()
    with open_recording(path, allow_damaged=allow_damaged) as rec:
        recorded_modes = control_modes(rec)
        recorded_robot = rebuild_run(rec)
        other_mode = "kinematic" if mode == "kinematic" else "position"
        try:
            other_robot = rebuild_run(rec, {j: other_mode for j in recorded_modes})  # type: ignore[misc]
        except HarnessError as exc:
            raise LevelUnavailableError(f"--mode {mode}: {exc}") from None
        states = read_states(rec)
        check_states_fit(rec, recorded_robot.model, states)
        inputs = read_inputs(rec, recorded_robot.model)
        dt_ns = rec.timestep_ns
    joints = list(recorded_modes)
    first, last = int(states.steps[0]), int(states.steps[-1])
    total = 2 * (last - first)

    # The recorded run, replayed from its inputs (bit for bit what was recorded).
    model = recorded_robot.model
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, states.state[0], states.state_spec)
    rec_trace = _Trace(model, joints)
    by_step = {inp.step: inp for inp in inputs}
    current = None
    for inp in inputs:
        if inp.step <= first + 1:
            current = inp
    target_rows: list[F64] = []
    for k in range(first + 1, last + 1):
        current = by_step.get(k, current)
        q_before = data.qpos[rec_trace.qadr].copy()
        if current is not None:
            advance(model, data, current)
        else:
            mujoco.mj_step(model, data)
        target_rows.append(_targets(model, joints, current, q_before))
        rec_trace.observe(k, data, dt_ns)
        if progress is not None and k % 500 == 0:
            progress(k - first, total)
    targets = np.stack(target_rows)
    # Velocity/effort joints have no target: follow their recorded positions.
    recorded_q = np.stack(rec_trace.q)
    for i, name in enumerate(joints):
        if recorded_modes[name] in ("velocity", "effort"):
            targets[:, i] = recorded_q[:, i]

    # The re-simulation in the other mode.
    sim = Simulation(other_robot, kinematic_limits="allow")
    sim.reset()
    sim.data.qpos[:] = states.qpos[0]
    sim.data.qvel[:] = states.qvel[0]
    sim.set_state(sim.get_state(), first)
    re_trace = _Trace(other_robot.model, joints)
    unstable: int | None = None
    previous: F64 | None = None
    for row, k in enumerate(range(first + 1, last + 1)):
        wanted = targets[row]
        if previous is None or not np.array_equal(wanted, previous):
            sim.set_positions(dict(zip(joints, wanted.tolist(), strict=True)))
            previous = wanted
        try:
            sim.step()
        except InstabilityError as exc:
            unstable = exc.step
            break
        re_trace.observe(k, sim.data, dt_ns)
        if progress is not None and k % 500 == 0:
            progress(last - first + k - first, total)
    if not re_trace.steps:
        raise RecordedDataError(f"{path}: the re-simulation failed at its first step")

    rec_m = _measure("recorded", _describe(recorded_modes), rec_trace, targets,
                     recorded_robot.model, run_description(recorded_robot), joints,
                     None)  # fmt: skip
    re_m = _measure("resimulated", mode, re_trace, targets, other_robot.model,
                    run_description(other_robot), joints, unstable)  # fmt: skip
    rec_summary, re_summary = rec_m.summary, re_m.summary
    findings = _findings("recorded", joints, rec_m, th) + _findings("resimulated", joints, re_m, th)
    if unstable is not None:
        findings.append(Finding("resimulated", "unstable", "", unstable, math.inf, 0.0))
    findings.sort(key=lambda f: (f.step, f.run, f.quantity, f.name))
    a_pairs, b_pairs = set(rec_summary.contact_pairs), set(re_summary.contact_pairs)
    if progress is not None:
        progress(total, total)
    return ResimReport(
        path=str(path),
        mode=mode,
        steps=last - first,
        thresholds=dict(th._asdict()),
        recorded=rec_summary,
        resimulated=re_summary,
        findings=tuple(findings),
        contacts_appearing=tuple(sorted(b_pairs - a_pairs)),
        contacts_disappearing=tuple(sorted(a_pairs - b_pairs)),
        wall_seconds=time.perf_counter() - started,
    )


def _describe(modes: Mapping[str, str]) -> str:
    kinds = sorted(set(modes.values()))
    return kinds[0] if len(kinds) == 1 else "mixed"
