"""``verify``: re-simulate a recording from its model, initial state and applied inputs and
compare the state at every recorded step, bit for bit or within tolerances.

Step numbering is :mod:`harness.sim.inputs`'s: the input recorded with ``step == k`` is applied
to the state after step ``k - 1`` and produces the state after step ``k``; each input holds
until the next one. The replay starts from the first recorded state (normally step 0).
States are captured into a preallocated block and compared as numpy arrays once per block
(bit patterns in exact mode, so ``-0.0 != 0.0`` and NaN payloads count).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np
import numpy.typing as npt

from harness.replay.errors import LevelUnavailableError, RecordedDataError
from harness.replay.layout import StateLayout, rotation_angle
from harness.replay.source import (
    check_states_fit,
    check_version,
    open_recording,
    read_inputs,
    read_states,
    resolve_model,
)
from harness.sim.inputs import AppliedInput

__all__ = [
    "BodyDelta",
    "Divergence",
    "Progress",
    "QuantityDelta",
    "VerifyLevel",
    "VerifyReport",
    "verify",
]

F64 = npt.NDArray[np.float64]
VerifyLevel = Literal["physics", "full"]
Progress = Callable[[int, int], None]
"""Called with ``(steps done, steps total)`` as the replay advances."""

_BLOCK = 1024
_MAX_LISTED = 50


@dataclass(frozen=True)
class QuantityDelta:
    """One recorded value that the replay did not reproduce."""

    component: str  # "qpos", "qvel", "ctrl", "qacc_warmstart", ... ("qpos field": the message's)
    name: str  # joint, actuator or body name
    index: int  # index within the component
    expected: float
    actual: float
    delta: float


@dataclass(frozen=True)
class BodyDelta:
    """A body whose world pose differs between the recorded and the replayed state."""

    name: str
    expected_position: tuple[float, float, float]
    actual_position: tuple[float, float, float]
    position_delta: float  # metres
    rotation_delta: float  # radians


@dataclass(frozen=True)
class Divergence:
    """The first recorded step the replay did not reproduce."""

    step: int
    sim_time_ns: int
    last_matching_step: int | None
    quantities: tuple[QuantityDelta, ...]
    differing_values: int
    bodies: tuple[BodyDelta, ...]


@dataclass(frozen=True)
class VerifyReport:
    """The outcome of :func:`verify` (``reproduced``: every recorded state matched)."""

    path: str
    reproduced: bool
    level: VerifyLevel
    atol: float
    rtol: float
    model_source: str
    mujoco_recorded: str
    mujoco_running: str
    first_step: int
    last_step: int
    steps_replayed: int
    states_compared: int
    last_matching_step: int | None
    divergence: Divergence | None
    wall_seconds: float = field(compare=False)
    notes: tuple[str, ...] = ()

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (``--report``)."""
        return asdict(self)

    def format(self) -> str:
        """A human-readable summary (the CLI's output)."""
        mode = (
            "bit-exact"
            if self.atol == 0 and self.rtol == 0
            else (f"atol={self.atol:g} rtol={self.rtol:g}")
        )
        head = (
            f"{self.path}: steps {self.first_step}..{self.last_step}, "
            f"{self.states_compared} states compared ({mode}; model from {self.model_source}; "
            f"MuJoCo {self.mujoco_running})"
        )
        lines = [head, *[f"note: {n}" for n in self.notes]]
        d = self.divergence
        if d is None:
            lines.append(f"REPRODUCED: {self.steps_replayed} steps in {self.wall_seconds:.2f} s")
            return "\n".join(lines)
        last = "none" if d.last_matching_step is None else str(d.last_matching_step)
        lines.append(
            f"DIVERGED at step {d.step} (sim time {d.sim_time_ns / 1e9:.6f} s); "
            f"last matching step: {last}; {d.differing_values} values differ"
        )
        lines.append(
            f"  {'quantity':<16} {'name':<24} {'expected':>24} {'actual':>24} {'delta':>12}"
        )
        for q in d.quantities:
            lines.append(
                f"  {q.component:<16} {q.name:<24} {q.expected!r:>24} {q.actual!r:>24} "
                f"{q.delta:>12.3g}"
            )
        if d.differing_values > len(d.quantities):
            lines.append(f"  ... {d.differing_values - len(d.quantities)} more")
        for b in d.bodies:
            lines.append(
                f"  body {b.name:<20} position delta {b.position_delta:.3g} m, "
                f"rotation delta {b.rotation_delta:.3g} rad"
            )
        return "\n".join(lines)


def _mismatch(actual: F64, expected: F64, atol: float, rtol: float) -> npt.NDArray[np.bool_]:
    """Elementwise: does ``actual`` fail to reproduce ``expected``?"""
    if atol == 0 and rtol == 0:
        out: npt.NDArray[np.bool_] = actual.view(np.uint64) != expected.view(np.uint64)
        return out
    with np.errstate(invalid="ignore"):
        close = np.abs(actual - expected) <= atol + rtol * np.abs(expected)
    same_nan = np.isnan(actual) & np.isnan(expected)
    return ~(close | same_nan)


def _write_input(model: mujoco.MjModel, data: mujoco.MjData, inp: AppliedInput) -> None:
    """What :func:`harness.sim.inputs.advance` writes before the step (kinematic writes apart)."""
    data.ctrl[:] = inp.ctrl
    if inp.mocap_pos.size:
        data.mocap_pos[:] = inp.mocap_pos.reshape(model.nmocap, 3)
        data.mocap_quat[:] = inp.mocap_quat.reshape(model.nmocap, 4)
    if inp.qfrc_applied.size:
        data.qfrc_applied[:] = inp.qfrc_applied
    else:
        data.qfrc_applied[:] = 0.0
    if inp.xfrc_applied.size:
        data.xfrc_applied[:] = inp.xfrc_applied.reshape(model.nbody, 6)
    else:
        data.xfrc_applied[:] = 0.0


def _body_deltas(
    model: mujoco.MjModel, expected_state: F64, actual_state: F64, spec: int
) -> tuple[BodyDelta, ...]:
    poses = []
    for state in (expected_state, actual_state):
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, state, spec)
        mujoco.mj_kinematics(model, data)
        poses.append((data.xpos.copy(), data.xquat.copy()))
    (pe, qe), (pa, qa) = poses
    out = []
    for b in range(1, model.nbody):
        dp = float(np.linalg.norm(pa[b] - pe[b]))
        dr = float(rotation_angle(qe[b], qa[b]))
        if dp > 0 or dr > 0 or not np.array_equal(qa[b], qe[b]):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
            out.append(
                BodyDelta(
                    name,
                    (float(pe[b][0]), float(pe[b][1]), float(pe[b][2])),
                    (float(pa[b][0]), float(pa[b][1]), float(pa[b][2])),
                    dp,
                    dr,
                )
            )
    out.sort(key=lambda d: -d.position_delta)
    return tuple(out[:_MAX_LISTED])


def verify(
    path: str | Path,
    *,
    atol: float = 0.0,
    rtol: float = 0.0,
    level: VerifyLevel = "physics",
    allow_damaged: bool = False,
    progress: Progress | None = None,
) -> VerifyReport:
    """Replay the recording at ``path`` and compare every recorded state.

    ``atol``/``rtol``: 0 (default) compares bit patterns; otherwise ``|actual - expected| <=
    atol + rtol * |expected|``. A recording from another MuJoCo version is refused unless a
    tolerance is given. ``level="full"`` also re-runs the bridge pipeline (needs the
    session's socket-free entry point; refused until it exists). ``allow_damaged``: replay
    what precedes the damage of a truncated or corrupted file.
    """
    if atol < 0 or rtol < 0 or not (math.isfinite(atol) and math.isfinite(rtol)):
        raise RecordedDataError(f"atol and rtol must be finite and >= 0, got {atol!r}, {rtol!r}")
    if level not in ("physics", "full"):
        raise LevelUnavailableError(f"unknown verify level {level!r} (physics or full)")
    if level == "full":
        from harness.replay.pipeline import check_pipeline_available

        check_pipeline_available()
    started = time.perf_counter()
    tolerant = atol > 0 or rtol > 0
    with open_recording(path, allow_damaged=allow_damaged) as rec:
        recorded_version = check_version(rec, tolerant=tolerant)
        model, model_source = resolve_model(rec)
        dt_ns = rec.timestep_ns
        if round(float(model.opt.timestep) * 1e9) != dt_ns:
            raise RecordedDataError(
                f"{rec.path}: the model's timestep {float(model.opt.timestep)!r} s is not the "
                f"recorded timestep_ns {dt_ns}"
            )
        states = read_states(rec)
        check_states_fit(rec, model, states)
        inputs = read_inputs(rec, model)
        notes: list[str] = []
        if rec.problems:
            notes.append(
                "damaged recording, replayed up to the damage: "
                + "; ".join(str(p) for p in rec.problems)
            )
    spec = states.state_spec
    steps = states.steps
    if steps.size > 1 and np.any(np.diff(steps) <= 0):
        bad = int(np.flatnonzero(np.diff(steps) <= 0)[0]) + 1
        raise RecordedDataError(
            f"{path}: physics state at step {int(steps[bad])} follows step {int(steps[bad - 1])}"
        )
    wrong_time = np.flatnonzero(states.sim_time_ns != steps * dt_ns)
    if wrong_time.size:
        i = int(wrong_time[0])
        raise RecordedDataError(
            f"{path}: physics state at step {int(steps[i])} has sim_time_ns "
            f"{int(states.sim_time_ns[i])}, not step * dt_ns = {int(steps[i]) * dt_ns}"
        )
    report = _replay(model, spec, states, inputs, atol, rtol, progress)
    steps_replayed, compared, divergence = report
    last_matching = (
        divergence.last_matching_step
        if divergence is not None
        else (int(steps[-1]) if steps.size > 1 else None)
    )
    return VerifyReport(
        path=str(path),
        reproduced=divergence is None,
        level=level,
        atol=atol,
        rtol=rtol,
        model_source=model_source,
        mujoco_recorded=recorded_version,
        mujoco_running=mujoco.__version__,
        first_step=int(steps[0]),
        last_step=int(steps[-1]),
        steps_replayed=steps_replayed,
        states_compared=compared,
        last_matching_step=last_matching,
        divergence=divergence,
        wall_seconds=time.perf_counter() - started,
        notes=tuple(notes),
    )


def _replay(
    model: mujoco.MjModel,
    spec: int,
    states: Any,
    inputs: list[AppliedInput],
    atol: float,
    rtol: float,
    progress: Progress | None,
) -> tuple[int, int, Divergence | None]:
    """Step from the first recorded state; return (steps, states compared, divergence)."""
    steps: npt.NDArray[np.int64] = states.steps
    expected: F64 = states.state
    first, last = int(steps[0]), int(steps[-1])
    total = last - first
    layout = StateLayout(model, spec)
    qpos_slice, qvel_slice = layout.slices["qpos"], layout.slices["qvel"]

    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, expected[0], spec)
    # The input in effect at the first step: the last one recorded at or before it.
    position = 0
    current: AppliedInput | None = None
    while position < len(inputs) and inputs[position].step <= first + 1:
        current = inputs[position]
        position += 1
    if current is not None:
        _write_input(model, data, current)
    kin_index = current.qpos_index if current is not None and current.qpos_index.size else None
    kin_value = current.qpos_value if kin_index is not None and current is not None else None
    vel_index = current.qvel_index if kin_index is not None and current is not None else None
    vel_value = current.qvel_value if kin_index is not None and current is not None else None
    next_input = inputs[position].step if position < len(inputs) else -1

    block = np.empty((_BLOCK, expected.shape[1]), dtype=np.float64)
    rows = [block[i] for i in range(_BLOCK)]
    row = 1  # index into the recorded states of the next state to capture
    filled = 0
    block_start = 1
    next_state = int(steps[1]) if steps.size > 1 else -1
    step_fn = mujoco.mj_step
    get_state = mujoco.mj_getState
    compared = 0

    for k in range(first + 1, last + 1):
        if k == next_input:
            current = inputs[position]
            position += 1
            next_input = inputs[position].step if position < len(inputs) else -1
            _write_input(model, data, current)
            if current.qpos_index.size:
                kin_index, kin_value = current.qpos_index, current.qpos_value
                vel_index, vel_value = current.qvel_index, current.qvel_value
            else:
                kin_index = kin_value = vel_index = vel_value = None
        if kin_index is not None:
            data.qpos[kin_index] = kin_value
            data.qvel[vel_index] = vel_value
            step_fn(model, data)
            data.qpos[kin_index] = kin_value
            data.qvel[vel_index] = vel_value
        else:
            step_fn(model, data)
        if k == next_state:
            get_state(model, data, rows[filled], spec)
            filled += 1
            row += 1
            next_state = int(steps[row]) if row < steps.size else -1
            if filled == _BLOCK or k == last:
                divergence = _compare(
                    model, layout, states, block[:filled], block_start, atol, rtol,
                    qpos_slice, qvel_slice,
                )  # fmt: skip
                compared += filled
                if divergence is not None:
                    return k - first, compared, divergence
                block_start = row
                filled = 0
                if progress is not None:
                    progress(k - first, total)
    if progress is not None:
        progress(total, total)
    return total, compared, None


def _compare(
    model: mujoco.MjModel,
    layout: StateLayout,
    states: Any,
    actual: F64,
    start: int,
    atol: float,
    rtol: float,
    qpos_slice: slice,
    qvel_slice: slice,
) -> Divergence | None:
    stop = start + actual.shape[0]
    expected: F64 = states.state[start:stop]
    bad_state = _mismatch(actual, expected, atol, rtol)
    bad_qpos = _mismatch(
        np.ascontiguousarray(actual[:, qpos_slice]), states.qpos[start:stop], atol, rtol
    )
    bad_qvel = _mismatch(
        np.ascontiguousarray(actual[:, qvel_slice]), states.qvel[start:stop], atol, rtol
    )
    bad_rows = bad_state.any(axis=1) | bad_qpos.any(axis=1) | bad_qvel.any(axis=1)
    if not bad_rows.any():
        return None
    r = int(np.flatnonzero(bad_rows)[0])
    i = start + r
    step = int(states.steps[i])
    quantities: list[QuantityDelta] = []
    for index in np.flatnonzero(bad_state[r]):
        value = layout.value(int(index))
        quantities.append(
            _delta(value.component, value.name, int(index) - _offset(layout, value.component),
                   float(expected[r, index]), float(actual[r, index]))
        )  # fmt: skip
    qpos_names, dof_names = layout.qpos_names(), layout.dof_names()
    for field_name, bad, sl, names, recorded in (
        ("qpos field", bad_qpos, qpos_slice, qpos_names, states.qpos),
        ("qvel field", bad_qvel, qvel_slice, dof_names, states.qvel),
    ):
        for index in np.flatnonzero(bad[r]):
            quantities.append(
                _delta(field_name, names[index], int(index), float(recorded[i, index]),
                       float(actual[r, sl][index]))
            )  # fmt: skip
    bodies = _body_deltas(model, expected[r], actual[r], layout.spec)
    return Divergence(
        step=step,
        sim_time_ns=int(states.sim_time_ns[i]),
        last_matching_step=int(states.steps[i - 1]) if i >= 1 else None,
        quantities=tuple(quantities[:_MAX_LISTED]),
        differing_values=len(quantities),
        bodies=bodies,
    )


def _offset(layout: StateLayout, component: str) -> int:
    return int(layout.slices[component].start)


def _delta(component: str, name: str, index: int, expected: float, actual: float) -> QuantityDelta:
    return QuantityDelta(component, name, index, expected, actual, actual - expected)
