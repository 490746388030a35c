"""``verify``: re-simulate a recording from its model, initial state and applied inputs and
compare the state at every recorded step, bit for bit or within tolerances.

Step numbering is :mod:`harness.sim.inputs`'s: the input recorded with ``step == k`` is applied
to the state after step ``k - 1`` and produces the state after step ``k``; each input holds
until the next one. The replay starts from the first recorded state (normally step 0).

The physics level streams: recorded states are decoded in blocks straight from the chunks
(:func:`harness.replay.source.state_blocks`) and the inputs read as the replay reaches them,
so each chunk is decompressed and checked once (its CRC when first read; chunks the replay
does not read are checked at the end). Between input changes the simulation runs as one
:meth:`mujoco.batch.Batch.rollout`, which records every step's state in C (bit-identical to
a loop of ``mj_step``); inputs that write kinematic joints are stepped one by one, as
:func:`harness.sim.inputs.advance` does. Each segment's states are compared with the
recorded ones as numpy arrays (bit patterns in exact mode, so ``-0.0 != 0.0`` and NaN
payloads count).
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import mujoco
import numpy as np
import numpy.typing as npt

from harness.recording import TOPIC_STATE, Epoch, Recording, RecordingDamagedError
from harness.replay.errors import LevelUnavailableError, RecordedDataError
from harness.replay.layout import StateLayout, rotation_angle
from harness.replay.platforms import check_platform
from harness.replay.source import (
    RecordedStates,
    check_chunks,
    check_version,
    open_recording,
    read_inputs,
    resolve_model,
    state_blocks,
)
from harness.sim import AppliedInput, differing, same_bits, write_input

if TYPE_CHECKING:
    from harness.replay.pipeline import PipelineReport

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

_SEGMENT = 4096
"""The most steps stepped (and compared) as one block."""
_BLOCK_ROWS = 4096
"""About how many recorded states are read (decoded) at a time."""
_INTEGRATION = int(mujoco.mjtState.mjSTATE_INTEGRATION)
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
    pipeline: PipelineReport | None = None
    """``level="full"``: the bridge pipeline re-run (:mod:`harness.replay.pipeline`)."""

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
        pipeline = [self.pipeline.format()] if self.pipeline is not None else []
        if d is None:
            lines.append(
                f"{'PHYSICS ' if pipeline else ''}REPRODUCED: {self.steps_replayed} steps in "
                f"{self.wall_seconds:.2f} s"
            )
            return "\n".join(lines + pipeline)
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
        return "\n".join(lines + pipeline)


def _mismatch(actual: F64, expected: F64, atol: float, rtol: float) -> npt.NDArray[np.bool_]:
    """Elementwise: does ``actual`` fail to reproduce ``expected``?"""
    if atol == 0 and rtol == 0:
        return differing(actual, expected).reshape(actual.shape)
    with np.errstate(invalid="ignore"):
        close = np.abs(actual - expected) <= atol + rtol * np.abs(expected)
    same_nan = np.isnan(actual) & np.isnan(expected)
    return ~(close | same_nan)


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
    atol + rtol * |expected|``. A recording from another MuJoCo version or another platform
    (:mod:`harness.replay.platforms`) is refused unless a tolerance is given.
    ``level="full"`` also re-runs the session's bridge pipeline and
    compares every frame, applied input and state bit for bit
    (:func:`harness.replay.pipeline.replay_pipeline`; refused on another MuJoCo version and
    for recordings it cannot re-run). ``allow_damaged``: replay
    what precedes the damage of a truncated or corrupted file.
    """
    if atol < 0 or rtol < 0 or not (math.isfinite(atol) and math.isfinite(rtol)):
        raise RecordedDataError(f"atol and rtol must be finite and >= 0, got {atol!r}, {rtol!r}")
    if level not in ("physics", "full"):
        raise LevelUnavailableError(f"unknown verify level {level!r} (physics or full)")
    started = time.perf_counter()
    tolerant = atol > 0 or rtol > 0
    # Every chunk is read once by the replay: its checks are made then, not on opening too.
    with open_recording(
        path, allow_damaged=allow_damaged, defer_chunk_checks=not allow_damaged
    ) as rec:
        recorded_version = check_version(rec, tolerant=tolerant)
        platform = check_platform(rec, tolerant=tolerant, level=level)
        model, model_source = resolve_model(rec)
        dt_ns = rec.timestep_ns
        if round(float(model.opt.timestep) * 1e9) != dt_ns:
            raise RecordedDataError(
                f"{rec.path}: the model's timestep {float(model.opt.timestep)!r} s is not the "
                f"recorded timestep_ns {dt_ns}"
            )
        # States are read block by block as the replay reaches them (little memory; each
        # block is checked by state_blocks: sizes, state spec, step order, sim time). The
        # first is read now: a model that does not fit is reported before anything else.
        blocks = state_blocks(rec, model, rows=_BLOCK_ROWS, stop_step=_stop(rec, 0))
        head = next(blocks)
        epochs = _epochs(rec, model, head.state_spec)
        notes: list[str] = [platform] if platform else []
        if epochs:
            notes.append(
                f"{len(epochs)} epoch(s) (resets) after step(s) "
                + ", ".join(str(e.step) for e in epochs[:10])
                + (" ..." if len(epochs) > 10 else "")
                + ": the replay continues from each recorded reset state"
            )
        if rec.problems:
            notes.append("damaged recording, replayed what is intact: " + rec.problem_text())
        first_ns, last_ns = rec.time_range(TOPIC_STATE)
        total = max(last_ns - first_ns, 0) // dt_ns
        inputs = _Inputs(rec, model)
        report = _replay(
            model, itertools.chain([head], blocks), inputs, atol, rtol, progress, total, epochs
        )
        last_done = report[3] + report[0]
        # Past each damaged stretch, the replay starts again from the next recorded state.
        for i, lost in enumerate(rec.lost):
            if report[2] is not None or lost.last_step is None:
                break
            kinematic = any(inp.qpos_index.size for inp in inputs.items)
            resume = _resume_step(rec, model, lost.last_step, kinematic)
            if resume is None:
                break
            try:
                blocks = state_blocks(
                    rec, model, rows=_BLOCK_ROWS, start_step=resume, stop_step=_stop(rec, i + 1)
                )
                head = next(blocks)
            except RecordedDataError:
                break  # no state recorded after this stretch
            notes.append(
                f"bytes {lost.offset}..{lost.end} damaged: steps {lost.first_step}.."
                f"{lost.last_step} may be missing; replayed again from step {int(head.steps[0])}"
            )
            inputs = _Inputs(rec, model, start=resume)
            part = _replay(
                model, itertools.chain([head], blocks), inputs, atol, rtol, progress, total,
                epochs,
            )  # fmt: skip
            report = (report[0] + part[0], report[1] + part[1], part[2], report[3])
            last_done = part[3] + part[0]
        check_chunks(rec)
    pipeline: PipelineReport | None = None
    if level == "full":
        from harness.replay.pipeline import replay_pipeline

        if recorded_version != mujoco.__version__:
            raise LevelUnavailableError(
                f"{path}: recorded with MuJoCo {recorded_version}, this is MuJoCo "
                f"{mujoco.__version__}: --level full compares frames bit for bit and needs the "
                "same version; use --level physics with a tolerance"
            )
        pipeline = replay_pipeline(path, allow_damaged=allow_damaged)
    steps_replayed, compared, divergence, first_step = report
    last_matching = (
        divergence.last_matching_step
        if divergence is not None
        else (last_done if compared else None)
    )
    return VerifyReport(
        path=str(path),
        reproduced=divergence is None and (pipeline is None or pipeline.reproduced),
        level=level,
        atol=atol,
        rtol=rtol,
        model_source=model_source,
        mujoco_recorded=recorded_version,
        mujoco_running=mujoco.__version__,
        first_step=first_step,
        last_step=last_ns // dt_ns,
        steps_replayed=steps_replayed,
        states_compared=compared,
        last_matching_step=last_matching,
        divergence=divergence,
        wall_seconds=time.perf_counter() - started,
        notes=tuple(notes),
        pipeline=pipeline,
    )


def _stop(rec: Recording, i: int) -> int | None:
    """Where the ``i``-th intact stretch of ``rec`` ends (a step bound; ``None``: the end):
    before the steps the next damaged stretch may have lost."""
    lost = rec.lost
    return lost[i].first_step + 1 if i < len(lost) else None


def _resume_step(rec: Recording, model: mujoco.MjModel, after: int, kinematic: bool) -> int | None:
    """The first step from which a replay can start again after a damaged stretch ending
    at step ``after``: the next recorded state (it holds ctrl, applied forces and mocap
    poses); when the run writes kinematic joints (held outside the state), the state before
    the next recorded input, which says what they hold."""
    if not kinematic:
        return after
    following = next(iter(rec.applied_inputs(after + 1)), None)
    return following.step - 1 if following is not None else None


class _Inputs:
    """The applied inputs, read from the recording as the replay reaches them (so that the
    chunks are decompressed once, for the inputs and states they hold together); ``start``:
    the first step whose inputs are read (after a damaged stretch)."""

    def __init__(self, rec: Recording, model: mujoco.MjModel, start: int = 0) -> None:
        self.rec, self.model = rec, model
        self.items: list[AppliedInput] = []
        self.loaded = start  # inputs of steps from start and below this are in items

    def load(self, stop_step: int) -> None:
        """Make sure every input of a step below ``stop_step`` is in :attr:`items`."""
        if stop_step > self.loaded:
            after = self.items[-1].step if self.items else -1
            self.items += read_inputs(self.rec, self.model, self.loaded, stop_step, after=after)
            self.loaded = stop_step


def _epochs(rec: Recording, model: mujoco.MjModel, spec: int) -> list[Epoch]:
    """The recorded epochs (resets), checked against ``model`` and the states' spec."""
    try:
        epochs = rec.epochs()
    except RecordingDamagedError as exc:
        raise RecordedDataError(f"{rec.path}: the recording is damaged ({exc})") from None
    size = int(mujoco.mj_stateSize(model, spec))
    previous = -1
    for e in epochs:
        where = f"{rec.path}: epoch {e.epoch} ({e.reason}) after step {e.step}"
        if e.state_spec != spec or e.state.size != size:
            raise RecordedDataError(
                f"{where}: its state has {e.state.size} values of spec {e.state_spec}; the "
                f"recorded states have {size} of spec {spec}"
            )
        if e.step < previous:
            raise RecordedDataError(f"{where} follows an epoch after step {previous}")
        if e.sim_time_ns != e.step * rec.timestep_ns:
            raise RecordedDataError(f"{where}: sim_time_ns {e.sim_time_ns} is not step * dt_ns")
        previous = e.step
    return epochs


def _replay(
    model: mujoco.MjModel,
    blocks: Iterator[RecordedStates],
    queue: _Inputs,
    atol: float,
    rtol: float,
    progress: Progress | None,
    total: int,
    epochs: Sequence[Epoch] = (),
) -> tuple[int, int, Divergence | None, int]:
    """Step from the first recorded state; return (steps, states compared, divergence, first
    step). ``blocks``: the recorded states in order (the first row of the first is the start).

    The run is cut into segments at input changes, block ends and every ``_SEGMENT`` steps.
    A segment whose input writes no kinematic joint is one :meth:`mujoco.batch.Batch.rollout`
    (every step's state recorded in C; bit-identical to a loop of ``mj_step``, and the
    batch's row is the ``mjSTATE_INTEGRATION`` state, so handing the state over is exact);
    one with kinematic writes is stepped here as :func:`harness.sim.inputs.advance` does (the
    joints are written before and after each step, which no batched call can do). Each
    segment's states are compared with the recorded ones as one block. Segments also end
    at each epoch (a reset): the state recorded for its step is compared, then the replay
    continues from the epoch's state (the input after a reset is always recorded).
    """
    block = next(blocks)
    spec = block.state_spec
    first = int(block.steps[0])
    layout = StateLayout(model, spec)
    qpos_slice, qvel_slice = layout.slices["qpos"], layout.slices["qvel"]

    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, block.state[0], spec)
    queue.load(int(block.steps[-1]) + 2)
    inputs = queue.items
    # The input in effect at the first step: the last one recorded at or before it.
    position = 0
    current: AppliedInput | None = None
    while position < len(inputs) and inputs[position].step <= first + 1:
        current = inputs[position]
        position += 1
    if current is not None:
        write_input(model, data, current)
    next_input = inputs[position].step if position < len(inputs) else -1

    scratch = np.empty((_SEGMENT, block.state.shape[1]), dtype=np.float64)
    batch: _Batch | None = None
    epoch_at = 0
    while epoch_at < len(epochs) and epochs[epoch_at].step < first:
        epoch_at += 1
    row = 1  # index into the block of the next recorded state to compare
    compared = 0
    done = first  # the last step taken
    matched = first  # the last step whose state matched
    while True:
        steps = block.steps
        block_last = int(steps[-1])
        while done < block_last:
            while epoch_at < len(epochs) and epochs[epoch_at].step == done:
                mujoco.mj_setState(model, data, epochs[epoch_at].state, spec)
                epoch_at += 1
                current = None  # the reset state holds the inputs until the next recorded one
            if done + 1 == next_input:
                current = inputs[position]
                position += 1
                next_input = inputs[position].step if position < len(inputs) else -1
                write_input(model, data, current)
            end = min(block_last, done + _SEGMENT)
            if next_input > done + 1:
                end = min(end, next_input - 1)
            if epoch_at < len(epochs):
                end = min(end, epochs[epoch_at].step)
            count = end - done
            if current is not None and current.qpos_index.size:
                _step_kinematic(model, data, current, scratch[:count], spec)
            else:
                if batch is None:
                    batch = _Batch(model, spec)
                batch.rollout(data, scratch[:count])
            stop_row = int(np.searchsorted(steps, end, side="right"))
            if stop_row > row:
                taken = steps[row:stop_row] - (done + 1)
                actual = scratch[:count] if taken.size == count else scratch[taken]
                divergence = _compare(
                    model, layout, block, actual, row, matched, atol, rtol,
                    qpos_slice, qvel_slice,
                )  # fmt: skip
                compared += stop_row - row
                if divergence is not None:
                    return end - first, compared, divergence, first
                matched = int(steps[stop_row - 1])
                row = stop_row
            done = end
            if progress is not None:
                progress(done - first, max(total, done - first))
        following = next(blocks, None)
        if following is None:
            break
        block, row = following, 0
        queue.load(int(block.steps[-1]) + 2)
        if next_input < 0 and position < len(inputs):
            next_input = inputs[position].step
    if progress is not None:
        progress(done - first, done - first)
    return done - first, compared, None, first


class _Batch:
    """One simulation of ``model`` in a :class:`mujoco.batch.Batch` on the calling thread."""

    def __init__(self, model: mujoco.MjModel, spec: int) -> None:
        from mujoco.batch import Batch

        self.model = model
        self.spec = spec
        self.batch = Batch(model, nsim=1, nthread=1)

    def rollout(self, data: mujoco.MjData, out: F64) -> None:
        """Take ``len(out)`` steps from ``data``'s state with its inputs held; the state
        (``spec``) after each step goes to a row of ``out``, the final state back to ``data``."""
        row = self.batch.state[0]
        mujoco.mj_getState(self.model, data, row, _INTEGRATION)
        count = out.shape[0]
        self.batch.rollout(
            count, record=(self.spec,), out={self.spec: out.reshape(1, count, out.shape[1])}
        )
        mujoco.mj_setState(self.model, data, row, _INTEGRATION)


def _step_kinematic(
    model: mujoco.MjModel, data: mujoco.MjData, inp: AppliedInput, out: F64, spec: int
) -> None:
    """``len(out)`` steps of :func:`harness.sim.inputs.advance` with ``inp`` (already written,
    kinematic joints apart), the state after each into a row of ``out``."""
    qpos_index, qpos_value = inp.qpos_index, inp.qpos_value
    qvel_index, qvel_value = inp.qvel_index, inp.qvel_value
    step, get_state = mujoco.mj_step, mujoco.mj_getState
    for target in out:
        data.qpos[qpos_index] = qpos_value
        data.qvel[qvel_index] = qvel_value
        step(model, data)
        data.qpos[qpos_index] = qpos_value
        data.qvel[qvel_index] = qvel_value
        get_state(model, data, target, spec)


def _compare(
    model: mujoco.MjModel,
    layout: StateLayout,
    states: RecordedStates,
    actual: F64,
    start: int,
    matched: int,
    atol: float,
    rtol: float,
    qpos_slice: slice,
    qvel_slice: slice,
) -> Divergence | None:
    stop = start + actual.shape[0]
    expected: F64 = states.state[start:stop]
    if (
        atol == 0
        and rtol == 0
        and same_bits(actual, expected)
        and same_bits(actual[:, qpos_slice], states.qpos[start:stop])
        and same_bits(actual[:, qvel_slice], states.qvel[start:stop])
    ):
        return None  # the common case, decided in one pass; the rest finds what differs
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
        last_matching_step=int(states.steps[i - 1]) if r >= 1 else matched,
        quantities=tuple(quantities[:_MAX_LISTED]),
        differing_values=len(quantities),
        bodies=bodies,
    )


def _offset(layout: StateLayout, component: str) -> int:
    return int(layout.slices[component].start)


def _delta(component: str, name: str, index: int, expected: float, actual: float) -> QuantityDelta:
    return QuantityDelta(component, name, index, expected, actual, actual - expected)
