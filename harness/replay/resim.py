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

This module plans the actuation and steps both runs; the measuring and judging are
:mod:`harness.replay.resim_measure`, the report :mod:`harness.replay.resim_report`.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from harness.errors import HarnessError
from harness.recording import Epoch
from harness.replay.errors import LevelUnavailableError, RecordedDataError
from harness.replay.resim_measure import (
    F64,
    Trace,
    differences,
    joint_unit,
    measure,
    position_targets,
)
from harness.replay.resim_report import Finding, ResimReport, Thresholds
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
from harness.sim.inputs import advance
from harness.vocabulary import ACTUATIONS, Actuation, LimitPolicy

__all__ = ["parse_actuation", "resimulate"]


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
    rec_trace = Trace(model, joints)
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
        target_rows.append(position_targets(model, joints, current, q_before))
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
    from harness.session.core import CoreOptions, SessionCore

    options = CoreOptions(kinematic_limits=LimitPolicy.ALLOW, controllers="none")
    core = SessionCore(other_robot, options, graph=_NoGraph())
    core.start()
    sim = core.sim
    sim.reset()
    sim.data.qpos[:] = states.qpos[0]
    sim.data.qvel[:] = states.qvel[0]
    sim.set_state(sim.get_state(), first)
    re_trace = Trace(other_robot.model, joints)
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

    rec_m = measure("recorded", _describe(recorded_modes), rec_trace, targets,
                     recorded_robot.model, run_description(recorded_robot), joints,
                     None)  # fmt: skip
    re_m = measure("resimulated", str(mode), re_trace, targets, other_robot.model,
                    run_description(other_robot), joints, unstable)  # fmt: skip
    rec_summary, re_summary = rec_m.summary, re_m.summary
    units = [joint_unit(recorded_robot.model, j) for j in joints]
    findings = differences(
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
