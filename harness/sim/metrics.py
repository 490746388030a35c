"""Joint-behaviour metrics over a run, as array computations.

They compare how joints behaved (kinematic vs dynamic re-simulation, goldens): limit
violation ``max(q - hi, lo - q, 0)``, tracking error ``|q - q_cmd|``, speed against the URDF
velocity limit (which MuJoCo ignores), peak penetration, energy jumps, warning counters.

Energy is computed here from recorded ``qpos``/``qvel`` on a scratch ``MjData`` with
``mj_energyPos``/``mj_energyVel``: the simulated model is never switched to ``mjENBL_ENERGY``,
so recorded physics does not depend on whether anyone asked for energy.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from harness.sim.contacts import ContactSet

if TYPE_CHECKING:
    from harness.sim.simulation import Simulation

__all__ = [
    "JointLimitArrays",
    "JointMetrics",
    "Trace",
    "TraceArrays",
    "energy",
    "energy_jumps",
    "joint_limits",
    "limit_violation",
    "peak_penetration",
    "summarize",
    "tracking_error",
    "velocity_ratio",
]

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]


class JointLimitArrays(NamedTuple):
    """Per-joint limits in ``sim.joint_names`` order (``±inf``/``nan`` where there is none)."""

    lower: F64
    upper: F64
    velocity: F64
    effort: F64


def joint_limits(sim: Simulation) -> JointLimitArrays:
    """Position limits from the model, velocity and effort limits from the description
    (falling back to the model's joint force range for effort)."""
    model = sim.model
    n = len(sim.joint_names)
    lower = np.full(n, -np.inf)
    upper = np.full(n, np.inf)
    velocity = np.full(n, np.nan)
    effort = np.full(n, np.nan)
    for i, name in enumerate(sim.joint_names):
        jid = model.joint(name).id
        if model.jnt_limited[jid]:
            lower[i], upper[i] = model.jnt_range[jid]
        if model.jnt_actfrclimited[jid]:
            effort[i] = max(abs(v) for v in model.jnt_actfrcrange[jid])
        if sim.description is not None:
            try:
                limits = sim.description.joint(name).limits
            except KeyError:
                continue
            if limits.velocity:
                velocity[i] = abs(limits.velocity)
            if limits.effort:
                effort[i] = abs(limits.effort)
    return JointLimitArrays(lower, upper, velocity, effort)


def limit_violation(positions: F64, lower: F64, upper: F64) -> F64:
    """``max(q - hi, lo - q, 0)`` elementwise (shape of ``positions``)."""
    out: F64 = np.maximum(np.maximum(positions - upper, lower - positions), 0.0)
    return out


def tracking_error(positions: F64, commands: F64) -> F64:
    """``|q - q_cmd|`` elementwise."""
    out: F64 = np.abs(positions - commands)
    return out


def velocity_ratio(velocities: F64, limits: F64) -> F64:
    """``|qvel| / limit`` elementwise (NaN where a joint has no velocity limit); above 1 is a
    violation of the URDF velocity limit."""
    with np.errstate(invalid="ignore", divide="ignore"):
        out: F64 = np.abs(velocities) / limits
    return out


def peak_penetration(contacts: Iterable[ContactSet]) -> F64:
    """The deepest penetration per step (0 for steps without touching contacts)."""
    out: F64 = np.array(
        [max(0.0, float(c.depth.max())) if c.size else 0.0 for c in contacts], dtype=np.float64
    )
    return out


def energy(model: mujoco.MjModel, qpos: F64, qvel: F64) -> F64:
    """Potential and kinetic energy per row of ``qpos``/``qvel``: shape ``(T, 2)``."""
    scratch = mujoco.MjData(model)
    qpos2 = np.atleast_2d(qpos)
    qvel2 = np.atleast_2d(qvel)
    out = np.empty((qpos2.shape[0], 2), dtype=np.float64)
    for t in range(qpos2.shape[0]):
        scratch.qpos[:] = qpos2[t]
        scratch.qvel[:] = qvel2[t]
        mujoco.mj_kinematics(model, scratch)
        mujoco.mj_comPos(model, scratch)
        mujoco.mj_makeM(model, scratch)
        mujoco.mj_energyPos(model, scratch)
        mujoco.mj_energyVel(model, scratch)
        out[t] = scratch.energy
    return out


def energy_jumps(total: F64, threshold: float) -> I64:
    """Indices ``t`` where total energy rose by more than ``threshold`` from ``t - 1`` (energy
    injected by teleports and limit violations; passive physics only loses energy)."""
    rises = np.diff(np.asarray(total, dtype=np.float64))
    out: I64 = (np.flatnonzero(rises > threshold) + 1).astype(np.int64)
    return out


class TraceArrays(NamedTuple):
    """One row per step: ``steps`` (T,), per-joint ``positions``/``velocities``/``commands``/
    ``efforts`` (T, J), full ``qpos`` (T, nq) and ``qvel`` (T, nv), ``penetration`` (T,)."""

    steps: I64
    positions: F64
    velocities: F64
    commands: F64
    efforts: F64
    qpos: F64
    qvel: F64
    penetration: F64


class Trace:
    """An observer recording what metrics need after every step::

    trace = Trace(); remove = sim.add_observer(trace); sim.step(1000); arrays = trace.arrays()
    """

    def __init__(self) -> None:
        self._rows: list[tuple[int, F64, F64, F64, F64, F64, F64, float]] = []

    def __call__(self, sim: Simulation) -> None:
        depth = sim.data.contact.dist[: sim.data.ncon]
        self._rows.append(
            (
                sim.step_index,
                sim.joint_positions(),
                sim.joint_velocities(),
                sim.joint_commands(),
                sim.joint_efforts(),
                np.array(sim.data.qpos, dtype=np.float64),
                np.array(sim.data.qvel, dtype=np.float64),
                max(0.0, -float(depth.min())) if depth.size else 0.0,
            )
        )

    def attach(self, sim: Simulation) -> Callable[[], None]:
        """Register with ``sim``; returns the remover."""
        return sim.add_observer(self)

    def arrays(self) -> TraceArrays:
        """The recorded rows as arrays."""
        if not self._rows:
            raise ValueError("the trace is empty: no step was taken while it was attached")
        cols = list(zip(*self._rows, strict=True))
        return TraceArrays(
            steps=np.array(cols[0], dtype=np.int64),
            positions=np.stack(cols[1]),
            velocities=np.stack(cols[2]),
            commands=np.stack(cols[3]),
            efforts=np.stack(cols[4]),
            qpos=np.stack(cols[5]),
            qvel=np.stack(cols[6]),
            penetration=np.array(cols[7], dtype=np.float64),
        )


class JointMetrics(NamedTuple):
    """Run summary; per-joint arrays in ``joint_names`` order. ``max_tracking_error`` is NaN
    for velocity- and effort-controlled joints (they have no position command)."""

    joint_names: tuple[str, ...]
    max_limit_violation: F64
    max_tracking_error: F64
    max_velocity_ratio: F64
    max_effort: F64
    peak_penetration: float
    max_energy_rise: float
    warnings: dict[str, int]


def summarize(sim: Simulation, trace: TraceArrays, *, with_energy: bool = True) -> JointMetrics:
    """Summarise a trace recorded from ``sim``."""
    limits = joint_limits(sim)
    positional = np.array([m in ("kinematic", "position") for m in sim.control.values()])
    tracking = tracking_error(trace.positions, trace.commands).max(axis=0)
    tracking[~positional] = np.nan
    rise = 0.0
    if with_energy and trace.qpos.shape[0] > 1:
        total = energy(sim.model, trace.qpos, trace.qvel).sum(axis=1)
        rise = float(np.diff(total).max())
    velocity = velocity_ratio(np.abs(trace.velocities).max(axis=0), limits.velocity)
    return JointMetrics(
        joint_names=sim.joint_names,
        max_limit_violation=limit_violation(trace.positions, limits.lower, limits.upper).max(
            axis=0
        ),
        max_tracking_error=tracking,
        max_velocity_ratio=velocity,
        max_effort=np.abs(trace.efforts).max(axis=0),
        peak_penetration=float(trace.penetration.max()),
        max_energy_rise=rise,
        warnings=sim.warning_counts(),
    )
