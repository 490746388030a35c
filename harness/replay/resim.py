"""Kinematic <-> dynamic re-simulation: the measurable version of "jumping"
(``harness replay FILE --actuation kinematic|servo``).

The recorded joint commands are the *position targets* the recorded run applied, read from
the applied inputs: for a joint driven by a position actuator, its ``ctrl`` value; for a
kinematic joint, the ``qpos_value`` written for it. Joints recorded in velocity or effort mode
have no position target: the re-simulation uses their recorded positions as targets. The
other mode re-simulates these targets from the recorded initial configuration with every
controllable joint ``kinematic`` (written each step, limits *not* clamped: that is what
teleporting does) or a ``servo`` (position servos with the model's default gains, clamped to
the joint range as a servo's ctrlrange is): the :class:`~harness.vocabulary.Actuation` of the
re-simulation (``position``/``dynamic``, its earlier spellings, are accepted with a
:class:`DeprecationWarning`). The robot is rebuilt from the recording's source
attachments with :func:`harness.models.load_robot` (a world of several robots with
:func:`harness.models.load_world`: :func:`harness.replay.source.rebuild_run`; its joints are
named by their MuJoCo, prefixed, names). The re-simulation is stepped by a
:class:`~harness.session.SessionCore`, the engine of a live run, given the targets as Python
position commands (no controllers, clients, sockets or threads); the recorded run is replayed
from its applied inputs, as ``harness replay`` does.

Both runs (the recorded one, replayed from its own inputs, and the re-simulation) are
measured the same way, per step: tracking error ``|q - q_target|``, limit violation
``max(q - hi, lo - q, 0)``, speed against the description's velocity limits, peak
penetration of any contact, total energy rise between steps, and which body pairs touch.

The re-simulation is judged against the recording, not against absolute limits: a
:class:`Finding` is the first step at which the two runs differ, either the re-simulated
position of a joint leaving the recorded one by more than ``max_tracking_error``
(``deviation``), or one run exceeding a threshold at a step where the other does not (a
recorded teleport past a joint limit that a servo cannot follow; a servo that overshoots
where the recording did not). What both runs do alike is the recording's own behaviour, shown
in the table but not a finding. When the requested actuation is the recorded control
(``servo`` for position servos), the re-simulation is the same run, and the report says so.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from harness.errors import HarnessError
from harness.models import RobotModel
from harness.recording import Epoch
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
from harness.sim import InstabilityError
from harness.sim.collisions import CollisionTracker
from harness.sim.inputs import AppliedInput, advance
from harness.sim.metrics import energy
from harness.vocabulary import ACTUATIONS, Actuation, LimitPolicy

__all__ = [
    "Finding",
    "JointSummary",
    "ResimReport",
    "RunSummary",
    "Thresholds",
    "parse_actuation",
    "resimulate",
]

F64 = npt.NDArray[np.float64]


def parse_actuation(value: object) -> Actuation:
    """``value`` as an :class:`~harness.vocabulary.Actuation`; its earlier spellings
    (``position``, ``dynamic``: control modes, not actuations) with a
    :class:`DeprecationWarning`; a :class:`LevelUnavailableError` for anything else."""
    try:
        actuation = Actuation.parse(value, "re-simulation")
    except ValueError as exc:
        raise LevelUnavailableError(str(exc)) from None
    if Actuation.deprecated(value):
        warnings.warn(
            f"re-simulation actuation {value!r} is deprecated: use {actuation.value!r} "
            f"(one of {', '.join(ACTUATIONS)})",
            DeprecationWarning,
            stacklevel=3,
        )
    return actuation


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
    """The first step at which the two runs differ in ``quantity`` of ``name``: ``run`` is
    the run that exceeded the threshold there (``"recorded"`` or ``"resimulated"``; for a
    ``deviation``, always ``"resimulated"``), ``value`` its value; ``recorded_value`` and
    ``resimulated_value`` both runs' values at that step, in ``unit``."""

    run: str  # "recorded" or "resimulated"
    quantity: str  # deviation, tracking_error, limit_violation, velocity_ratio, penetration,
    # energy_jump, unstable
    name: str  # joint name ("" for whole-run quantities)
    step: int
    value: float
    threshold: float
    recorded_value: float = math.nan
    resimulated_value: float = math.nan
    unit: str = ""

    def format(self) -> str:
        """One line."""
        what = f"{self.name} {self.quantity}".strip()
        unit = f" {self.unit}" if self.unit else ""
        if self.quantity == "unstable":
            return f"step {self.step:>6}  the re-simulation became unstable (MuJoCo warning)"
        if self.quantity == "deviation":
            return (
                f"step {self.step:>6}  {what}: re-simulated {self.resimulated_value:.4g}{unit}, "
                f"recorded {self.recorded_value:.4g}{unit}: {self.value:.4g}{unit} apart "
                f"(threshold {self.threshold:g}{unit})"
            )
        only = "recording" if self.run == "recorded" else "re-simulation"
        return (
            f"step {self.step:>6}  {what}: recorded {self.recorded_value:.4g}{unit}, "
            f"re-simulated {self.resimulated_value:.4g}{unit}: only the {only} exceeds "
            f"{self.threshold:g}{unit}"
        )


@dataclass(frozen=True)
class JointSummary:
    """One joint's worst values in one run, with the step of each (-1: never above 0);
    ``unit``: of its positions (``rad`` for hinges, ``m`` for slides)."""

    joint: str
    max_tracking_error: float
    tracking_step: int
    max_limit_violation: float
    violation_step: int
    max_velocity_ratio: float
    velocity_step: int
    unit: str = "rad"


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
    """Recorded run and re-simulation side by side (``passed``: no finding, i.e. the
    re-simulation behaves as the recording did within the thresholds)."""

    path: str
    actuation: Actuation
    steps: int
    thresholds: dict[str, float]
    recorded: RunSummary
    resimulated: RunSummary
    findings: tuple[Finding, ...]
    contacts_appearing: tuple[str, ...]
    contacts_disappearing: tuple[str, ...]
    wall_seconds: float
    notes: tuple[str, ...] = ()
    recorded_reproduced: bool = True
    """Whether replaying the recorded run from its inputs gave the recorded states."""

    @property
    def passed(self) -> bool:
        """True when the re-simulation differs from the recording in nothing measured."""
        return not self.findings

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return {**asdict(self), "passed": self.passed}

    def format(self) -> str:
        """A legend, the side-by-side table, one line per finding and a verdict."""
        a, b = self.recorded, self.resimulated
        lines = [
            f"{self.path}: {self.steps} steps, recorded ({a.control}) vs re-simulated "
            f"({b.control})",
            *[f"note: {n}" for n in self.notes],
            "legend: each cell is recorded | re-simulated: the worst value of the run and, "
            "after @, the step it was reached at; '-': no limit in the description",
        ]

        def cell(value: float, step: int) -> str:
            text = "-" if math.isnan(value) else f"{value:.4g}"
            if step >= 0 and not math.isnan(value) and value > 0:
                text += f" @{step}"
            return text

        def pair(x: float, xs: int, y: float, ys: int) -> tuple[str, str]:
            return cell(x, xs), cell(y, ys)

        header = ("joint", "unit", "tracking error", "limit violation", "speed / limit")
        rows: list[tuple[str, str, tuple[str, str], tuple[str, str], tuple[str, str]]] = []
        for ja, jb in zip(a.joints, b.joints, strict=True):
            rows.append(
                (
                    ja.joint,
                    ja.unit,
                    pair(
                        ja.max_tracking_error,
                        ja.tracking_step,
                        jb.max_tracking_error,
                        jb.tracking_step,
                    ),
                    pair(
                        ja.max_limit_violation,
                        ja.violation_step,
                        jb.max_limit_violation,
                        jb.violation_step,
                    ),
                    pair(
                        ja.max_velocity_ratio,
                        ja.velocity_step,
                        jb.max_velocity_ratio,
                        jb.velocity_step,
                    ),
                )
            )
        rows.append(
            ("peak penetration", "m",
             pair(a.peak_penetration, a.penetration_step, b.peak_penetration,
                  b.penetration_step), ("", ""), ("", ""))
        )  # fmt: skip
        rows.append(
            ("max energy jump", "J",
             pair(a.max_energy_jump, a.energy_step, b.max_energy_jump, b.energy_step),
             ("", ""), ("", ""))
        )  # fmt: skip
        w_name = max(len(header[0]), *(len(r[0]) for r in rows))
        w_unit = max(len(header[1]), *(len(r[1]) for r in rows))
        widths = [
            (max(len(r[i][0]) for r in rows), max(len(r[i][1]) for r in rows)) for i in (2, 3, 4)
        ]

        def both(p: tuple[str, str], w: tuple[int, int]) -> str:
            if not p[0] and not p[1]:
                return " " * (w[0] + 3 + w[1])
            return f"{p[0]:>{w[0]}} | {p[1]:<{w[1]}}"

        heads = [f"{h:^{w[0] + 3 + w[1]}}" for h, w in zip(header[2:], widths, strict=True)]
        lines.append(f"  {header[0]:<{w_name}}  {header[1]:<{w_unit}}  " + "  ".join(heads))
        for r in rows:
            cells = "  ".join(both(p, w) for p, w in zip(r[2:], widths, strict=True))
            lines.append(f"  {r[0]:<{w_name}}  {r[1]:<{w_unit}}  {cells}".rstrip())
        for run in (a, b):
            if run.unstable_at is not None:
                lines.append(f"  {run.label}: UNSTABLE at step {run.unstable_at}")
        if self.contacts_appearing:
            lines.append(f"  contacts only when re-simulated: {', '.join(self.contacts_appearing)}")
        if self.contacts_disappearing:
            lines.append(f"  contacts only when recorded: {', '.join(self.contacts_disappearing)}")
        if self.findings:
            lines.append(
                f"findings: where the re-simulation ({b.control}) differs from the recording "
                f"({a.control}) beyond a threshold, first step of each:"
            )
            lines += [f"  {f.format()}" for f in self.findings]
            lines.append(
                f"VERDICT: DIFFERENT: {len(self.findings)} finding(s); the recorded motion "
                f"does not carry over to {self.actuation} control as it is"
            )
        else:
            lines.append(
                f"VERDICT: SAME BEHAVIOUR: the re-simulation ({self.actuation}) stays within every "
                "threshold of the recording"
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
        summaries.append(JointSummary(name, t, ts, lv, ls, vr, vs, _unit(model, name)))
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


def _unit(model: mujoco.MjModel, joint: str) -> str:
    """The unit of a joint's position: ``m`` for a slide, ``rad`` otherwise."""
    return (
        "m"
        if int(model.jnt_type[model.joint(joint).id]) == int(mujoco.mjtJoint.mjJNT_SLIDE)
        else "rad"
    )


def _first_apart(run_values: F64, other_values: F64, limit: float) -> tuple[int, bool] | None:
    """The first row where exactly one of the two runs is above ``limit`` (and whether it is
    the first run), or ``None``."""
    with np.errstate(invalid="ignore"):
        above_a = run_values > limit
        above_b = other_values > limit
    apart = np.flatnonzero(above_a != above_b)
    if not apart.size:
        return None
    k = int(apart[0])
    return k, bool(above_a[k])


def _differences(
    joints: Sequence[str], units: Sequence[str], rec: _Measured, re: _Measured,
    rec_q: F64, re_q: F64, th: Thresholds,
) -> list[Finding]:  # fmt: skip
    """Where the re-simulation differs from the recording (see the module docstring)."""
    n = min(rec.steps.size, re.steps.size)
    steps = rec.steps[:n]
    out: list[Finding] = []
    deviation = np.abs(re_q[:n] - rec_q[:n])
    for i, name in enumerate(joints):
        above = np.flatnonzero(deviation[:, i] > th.max_tracking_error)
        if above.size:
            k = int(above[0])
            out.append(
                Finding("resimulated", "deviation", name, int(steps[k]), float(deviation[k, i]),
                        th.max_tracking_error, float(rec_q[k, i]), float(re_q[k, i]), units[i])
            )  # fmt: skip
    for quantity, a, b, limit, unit_of in (
        ("limit_violation", rec.violation, re.violation, th.max_limit_violation, True),
        ("velocity_ratio", rec.ratio, re.ratio, th.max_velocity_ratio, False),
    ):
        for i, name in enumerate(joints):
            found = _first_apart(a[:n, i], b[:n, i], limit)
            if found is not None:
                k, in_recorded = found
                x, y = float(a[k, i]), float(b[k, i])
                out.append(
                    Finding("recorded" if in_recorded else "resimulated", quantity, name,
                            int(steps[k]), x if in_recorded else y, limit, x, y,
                            units[i] if unit_of else "")
                )  # fmt: skip
    found = _first_apart(rec.penetration[:n], re.penetration[:n], th.max_penetration)
    if found is not None:
        k, in_recorded = found
        x, y = float(rec.penetration[k]), float(re.penetration[k])
        out.append(
            Finding("recorded" if in_recorded else "resimulated", "penetration", "",
                    int(steps[k]), x if in_recorded else y, th.max_penetration, x, y, "m")
        )  # fmt: skip
    m = min(rec.rises.size, re.rises.size, max(n - 1, 0))
    found = _first_apart(rec.rises[:m], re.rises[:m], th.max_energy_jump)
    if found is not None:
        k, in_recorded = found
        x, y = float(rec.rises[k]), float(re.rises[k])
        out.append(
            Finding("recorded" if in_recorded else "resimulated", "energy_jump", "",
                    int(steps[k + 1]), x if in_recorded else y, th.max_energy_jump, x, y, "J")
        )  # fmt: skip
    return out


def _same_mode_note(modes: Mapping[str, str], actuation: Actuation) -> str:
    """Say so when the requested actuation is the mode (some) joints were recorded in."""
    same = "kinematic" if actuation is Actuation.KINEMATIC else "position"
    joints = [j for j, m in modes.items() if m == same]
    if not joints:
        return ""
    if len(joints) == len(modes):
        return (
            f"every joint was recorded in {same} mode: re-simulating with {actuation} "
            "actuation re-runs the recorded control, so only differences of the "
            "re-simulation's setup (servo gains, unclamped kinematic limits) can show"
        )
    return f"joints {', '.join(joints)} were recorded in {same} mode already"


def resimulate(
    path: str | Path,
    actuation: Actuation | str,
    *,
    thresholds: Thresholds | None = None,
    allow_damaged: bool = False,
    progress: Progress | None = None,
) -> ResimReport:
    """Re-simulate the recorded joint commands of ``path`` with every controllable joint
    driven as ``actuation`` says (``kinematic`` or ``servo``) and measure both runs (see the
    module docstring)."""
    mode = parse_actuation(actuation)
    th = thresholds if thresholds is not None else Thresholds()
    started = time.perf_counter()
    with open_recording(path, allow_damaged=allow_damaged) as rec:
        recorded_modes = control_modes(rec)
        recorded_robot = rebuild_run(rec)
        other_mode = "kinematic" if mode == "kinematic" else "position"
        try:
            other_robot = rebuild_run(rec, {j: other_mode for j in recorded_modes})  # type: ignore[misc]
        except HarnessError as exc:
            raise LevelUnavailableError(f"--actuation {mode}: {exc}") from None
        states = read_states(rec)
        check_states_fit(rec, recorded_robot.model, states)
        inputs = read_inputs(rec, recorded_robot.model)
        # Resets: both runs start again from the recorded state after each one.
        resets: dict[int, list[Epoch]] = {}
        for epoch in rec.epochs():
            resets.setdefault(epoch.step, []).append(epoch)
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
        for epoch in resets.get(k - 1, ()):
            mujoco.mj_setState(model, data, epoch.state, epoch.state_spec)
            current = None  # the reset state holds the inputs until the next recorded one
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
    # The recorded run must replay as recorded, or the comparison means little.
    replayed = np.stack(rec_trace.qpos)
    rows = states.steps[1:] - (first + 1)
    reproduced = bool(
        np.array_equal(replayed[rows].view(np.uint64), states.qpos[1:].view(np.uint64))
    )
    # Velocity/effort joints have no target: follow their recorded positions.
    recorded_q = np.stack(rec_trace.q)
    for i, name in enumerate(joints):
        if recorded_modes[name] in ("velocity", "effort"):
            targets[:, i] = recorded_q[:, i]

    # The re-simulation in the other mode: a session core (the engine of a live run) taking
    # the targets as Python position commands, without controllers (nothing else commands
    # the joints), recorder, clients, sockets or threads.
    from harness.session import CoreOptions, SessionCore

    options = CoreOptions(kinematic_limits=LimitPolicy.ALLOW, controllers="none")
    core = SessionCore(other_robot, options, graph=_NoGraph())
    core.start()
    sim = core.sim
    sim.reset()
    sim.data.qpos[:] = states.qpos[0]
    sim.data.qvel[:] = states.qvel[0]
    sim.set_state(sim.get_state(), first)
    re_trace = _Trace(other_robot.model, joints)
    unstable: int | None = None
    previous: F64 | None = None
    for row, k in enumerate(range(first + 1, last + 1)):
        for epoch in resets.get(k - 1, ()):
            sim.reset()
            sim.data.qpos[:] = epoch.qpos
            sim.data.qvel[:] = epoch.qvel
            state = sim.get_state()
            state[0] = epoch.step * dt_ns / 1e9  # mjSTATE_TIME: step numbering continues
            sim.set_state(state, epoch.step)
            previous = None
        wanted = targets[row]
        if previous is None or not np.array_equal(wanted, previous):
            core.set_positions(dict(zip(joints, wanted.tolist(), strict=True)))
            previous = wanted
        try:
            core.advance()
        except InstabilityError as exc:
            unstable = exc.step
            break
        re_trace.observe(k, sim.data, dt_ns)
        if progress is not None and k % 500 == 0:
            progress(last - first + k - first, total)
    core.finish()
    if not re_trace.steps:
        raise RecordedDataError(f"{path}: the re-simulation failed at its first step")

    rec_m = _measure("recorded", _describe(recorded_modes), rec_trace, targets,
                     recorded_robot.model, run_description(recorded_robot), joints,
                     None)  # fmt: skip
    re_m = _measure("resimulated", str(mode), re_trace, targets, other_robot.model,
                    run_description(other_robot), joints, unstable)  # fmt: skip
    rec_summary, re_summary = rec_m.summary, re_m.summary
    units = [_unit(recorded_robot.model, j) for j in joints]
    findings = _differences(
        joints, units, rec_m, re_m, np.stack(rec_trace.q), np.stack(re_trace.q), th
    )
    if unstable is not None:
        findings.append(Finding("resimulated", "unstable", "", unstable, math.inf, 0.0))
    findings.sort(key=lambda f: (f.step, f.run, f.quantity, f.name))
    a_pairs, b_pairs = set(rec_summary.contact_pairs), set(re_summary.contact_pairs)
    if progress is not None:
        progress(total, total)
    return ResimReport(
        path=str(path),
        actuation=mode,
        steps=last - first,
        thresholds=dict(th._asdict()),
        recorded=rec_summary,
        resimulated=re_summary,
        findings=tuple(findings),
        contacts_appearing=tuple(sorted(b_pairs - a_pairs)),
        contacts_disappearing=tuple(sorted(a_pairs - b_pairs)),
        wall_seconds=time.perf_counter() - started,
        notes=tuple(
            n
            for n in (
                _same_mode_note(recorded_modes, mode),
                ""
                if reproduced
                else "the recorded run did not replay bit for bit from its inputs (another "
                "MuJoCo version?): its column is the replay's, not the recording's",
            )
            if n
        ),
        recorded_reproduced=reproduced,
    )


class _NoGraph:
    """The graph of a core no client is connected to: nothing subscribes, so what is
    published goes nowhere (spares the core a bridge and its message types)."""

    def has_subscribers(self, topic: str) -> bool:
        return False

    def advertise(self, topic: str, type: str, *, node: str, latch: bool = False) -> None:
        pass

    def publish(
        self, topic: str, type: str, msg: Mapping[str, Any], now_ns: int, *, latch: bool = False
    ) -> None:
        pass

    def subscribe(self, topic: str, type: str, callback: Any, *, node: str = "") -> None:
        pass

    def serve(self, service: str, type: str, handler: Any, *, node: str = "") -> None:
        pass

    def status(self, connection: int, level: str, text: str) -> None:
        pass


def _describe(modes: Mapping[str, str]) -> str:
    kinds = sorted(set(modes.values()))
    return kinds[0] if len(kinds) == 1 else "mixed"
