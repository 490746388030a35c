"""Measuring the two runs of a re-simulation alike and judging where they differ.

:class:`Trace` collects one run's rows step by step; :func:`position_targets` reads the
position target of each joint from a recorded applied input; :func:`measure` turns a trace
into a :class:`~harness.replay.resim_report.RunSummary` and the per-step arrays;
:func:`differences` lists the :class:`~harness.replay.resim_report.Finding` of each step at
which the re-simulation leaves the recording (see :mod:`harness.replay.resim`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models import RobotModel
from harness.replay.resim_report import Finding, JointSummary, RunSummary, Thresholds
from harness.sim.collisions import CollisionTracker
from harness.sim.inputs import AppliedInput
from harness.sim.metrics import energy

__all__ = [
    "F64",
    "Measured",
    "Trace",
    "differences",
    "joint_unit",
    "measure",
    "position_targets",
]

F64 = npt.NDArray[np.float64]


class Trace:
    """Per-step rows of one run: the positions and speeds of ``joints``, the whole state,
    the deepest penetration, and the first step each body pair came into contact."""

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
        """Add the row of ``step`` (``data`` after it was computed)."""
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


def position_targets(
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


class Measured(NamedTuple):
    """One run measured: its summary and the per-step values behind it (rows by step)."""

    summary: RunSummary
    tracking: F64
    violation: F64
    ratio: F64
    penetration: F64
    rises: F64
    steps: npt.NDArray[np.int64]


def measure(
    label: str,
    control: str,
    trace: Trace,
    targets: F64,
    model: mujoco.MjModel,
    description: RobotModel,
    joints: Sequence[str],
    unstable_at: int | None,
) -> Measured:
    """Measure one run's ``trace`` against ``targets`` (a row per step) and the limits of
    ``model`` and ``description``; ``unstable_at``: the step it went unstable at, if it did."""
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
        summaries.append(JointSummary(name, t, ts, lv, ls, vr, vs, joint_unit(model, name)))
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
    return Measured(summary, tracking, violation, ratio, pen, rises, steps)


def joint_unit(model: mujoco.MjModel, joint: str) -> str:
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


def differences(
    joints: Sequence[str], units: Sequence[str], rec: Measured, re: Measured,
    rec_q: F64, re_q: F64, th: Thresholds,
) -> list[Finding]:  # fmt: skip
    """Where the re-simulation differs from the recording: the first step of each
    difference beyond ``th`` (see :mod:`harness.replay.resim`)."""
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
