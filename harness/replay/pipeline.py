"""``--level full``: re-run a session recording's incoming bridge frames through a fresh
session core without sockets and compare everything it produces with the recording.

The core is :class:`harness.session.core.SessionCore`, the code the live
:class:`~harness.session.Session` runs (protocol, command handling, publishing schedule,
services, recording outputs), rebuilt from the recording: the robot from its source
attachments (physics from ``model.mjb`` when attached), the session options from the metadata
(:meth:`~harness.session.core.CoreOptions.from_metadata`). Each recorded incoming frame and
marker is applied at the step boundary it was recorded at (``step - 1``); between them the
core steps as recorded (a ``/harness/step`` call steps inside the core, Python or free-running
steps are taken up to the next frame's step, then up to the last recorded step). Compared, in
the order they are produced, bit for bit: every ``/harness/bridge`` frame (step, sim time,
direction, connection, seq, op, topic, exact text or bytes), every applied input and every
physics state. The first difference ends the replay and is reported.

A run that failed (any exception while stepping, e.g. a logger that raised; the session's
FATAL ``/rosout`` event records where) fails the re-run the same way: it stops at that step
and :attr:`PipelineReport.failure` says why. A re-run that fails where the run did not, runs
on where it failed, or fails with another message diverges (kind ``failure``).

Replayable clock modes: all three. ``lockstep`` steps only on recorded requests; ``fast`` and
``realtime`` steps by themselves, but the step at which each frame took effect is recorded,
which is all the core needs (wall-clock pacing never reaches the core). Inputs that are not
client frames are recorded as markers (a socket closing, a wall-clock service-call timeout, a
status the transport sent by itself, Python ``command``/``set_positions``/``reset``/
``pause`` calls). A client-mode session's link to the external server is one connection of
its bridge, recorded and re-run like any client's. Refused: client-mode recordings made
before that (no ``upstream`` in the metadata: no frames to replay), recordings made with
``record_bridge_frames=False`` and recordings not made by a session. Not reproducible from the
file: frames published by Python loggers (pass the same ``loggers``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np
import numpy.typing as npt

from harness.errors import HarnessError
from harness.events import EventHub, Level, Logger
from harness.models import LoadedRobot, LoadedWorld
from harness.recording import (
    TOPIC_EPOCH,
    AppliedInput,
    BridgeFrame,
    Epoch,
    PhysicsState,
    PhysicsStateSlot,
    Recording,
    forwarding_slot,
)
from harness.replay.errors import LevelUnavailableError, RecordedDataError
from harness.replay.sensor_check import SensorCheck
from harness.replay.source import open_recording, read_states, rebuild_run, resolve_model
from harness.session.core import (
    FAILURE_PREFIX,
    LOG_NAME,
    CoreOptions,
    SessionCore,
    is_marker,
)
from harness.sim import ARRAY_FIELDS, differing, same_bits

__all__ = ["MismatchKind", "PipelineMismatch", "PipelineReport", "replay_pipeline"]

MismatchKind = Literal["frame", "input", "state", "schedule", "sensor", "failure"]
_EXCERPT = 160


@dataclass(frozen=True)
class PipelineMismatch:
    """The first thing the re-run pipeline did not reproduce. ``kind``: an outgoing or
    incoming ``frame``, an applied ``input``, a physics ``state``, the ``schedule`` (a
    frame recorded at a step the re-run had already passed), a ``sensor`` message or the
    run's ``failure`` (the recorded run stopped with an error the re-run did not raise at
    the same step, or the other way round). ``what`` says which field
    differs; ``expected``/``actual`` are excerpts around the first difference ("" when
    there is no such record)."""

    kind: MismatchKind
    step: int
    sim_time_ns: int
    connection: int | None
    direction: str  # "in", "out" or "" (inputs, states)
    op: str
    topic: str
    what: str
    expected: str
    actual: str
    index: int  # position in the recorded sequence of its kind

    def format(self) -> str:
        """Lines for the CLI."""
        where = f"step {self.step} (sim time {self.sim_time_ns / 1e9:.6f} s)"
        if self.kind == "frame":
            head = (
                f"PIPELINE DIVERGED at {where}: {self.direction}going frame #{self.index} on "
                f"connection {self.connection}, op {self.op or '-'!r}, topic "
                f"{self.topic or '-'!r}: {self.what}"
            )
        else:
            head = f"PIPELINE DIVERGED at {where}: {self.kind} #{self.index}: {self.what}"
        return "\n".join(
            [
                head,
                f"  expected: {self.expected or '(none)'}",
                f"  actual:   {self.actual or '(none)'}",
            ]
        )


@dataclass(frozen=True)
class PipelineReport:
    """The outcome of :func:`replay_pipeline`."""

    reproduced: bool
    steps: int
    frames_compared: int
    inputs_compared: int
    states_compared: int
    markers: int
    mismatch: PipelineMismatch | None
    wall_seconds: float = dataclasses.field(compare=False)
    notes: tuple[str, ...] = ()
    failure: str = ""
    """Why the re-run stopped (``"step N: text"``), as the live run did; "" when it ran on."""

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return asdict(self)

    def format(self) -> str:
        """A human-readable summary."""
        lines = [f"note: {n}" for n in self.notes]
        if self.failure:
            lines.append(f"the run failed at {self.failure}")
        counts = (
            f"{self.frames_compared} bridge frames ({self.markers} markers), "
            f"{self.inputs_compared} applied inputs, {self.states_compared} states"
        )
        if self.mismatch is None:
            lines.append(f"PIPELINE REPRODUCED: {counts} over {self.steps} steps")
        else:
            lines.append(self.mismatch.format())
            lines.append(f"  matched before it: {counts}")
        return "\n".join(lines)


def _excerpt(expected: str, actual: str) -> tuple[str, str]:
    """Both texts around their first difference (``...`` where cut)."""
    n = min(len(expected), len(actual))
    i = next((j for j in range(n) if expected[j] != actual[j]), n)
    start = max(0, i - _EXCERPT // 2)

    def cut(text: str) -> str:
        part = text[start : start + _EXCERPT]
        return ("..." if start else "") + part + ("..." if start + _EXCERPT < len(text) else "")

    return cut(expected), cut(actual)


def _payload_text(frame: BridgeFrame) -> str:
    return frame.data.hex() if frame.binary else frame.text


class _Checker:
    """A :class:`~harness.session.core.RecordSink` comparing what the core writes with the
    recording, as it is written; keeps the first mismatch and ignores everything after it."""

    def __init__(
        self,
        model: mujoco.MjModel,
        frames: Sequence[BridgeFrame],
        inputs: Sequence[AppliedInput],
        state_steps: npt.NDArray[np.int64],
        states: npt.NDArray[np.float64],
        dt_ns: int,
        epochs: Sequence[Epoch] = (),
    ) -> None:
        self.model = model
        self.epochs = epochs
        self.epoch_at = 0
        self.frames = frames
        self.inputs = inputs
        self.state_steps = state_steps
        self.states = states
        self.dt_ns = dt_ns
        self.frame_at = 0
        self.input_at = 0
        self.state_at = 0
        self.markers = 0
        self.mismatch: PipelineMismatch | None = None
        self.sensors: SensorCheck | None = None

    def _fail(self, mismatch: PipelineMismatch) -> None:
        if self.mismatch is None:
            self.mismatch = mismatch

    # -- RecordSink ------------------------------------------------------------------

    def write_message(self, topic: str, msgtype: str, msg: Any, *, sim_time_ns: int) -> None:
        """Published messages are built from the state and commands compared here; sensor
        messages are compared too (:mod:`harness.replay.sensor_check`)."""
        if self.sensors is not None and self.mismatch is None:
            what = self.sensors.check(topic, msgtype, msg, sim_time_ns)
            if what is not None:
                step = sim_time_ns // self.dt_ns
                self._fail(
                    PipelineMismatch(
                        "sensor", step, sim_time_ns, None, "", "", topic, what, "", "",
                        self.sensors.compared,
                    )
                )  # fmt: skip

    def write_bridge_frame(self, frame: BridgeFrame) -> None:
        if self.mismatch is not None:
            return
        actual = frame
        i = self.frame_at
        self.frame_at += 1
        if i >= len(self.frames):
            self._frame_mismatch(i, None, actual, "the re-run produced a frame the recording lacks")
            return
        expected = self.frames[i]
        skip: tuple[str, ...] = ()
        if (
            self.sensors is not None
            and frame.direction == 1
            and self.sensors.skips_payload(frame.topic)
        ):
            skip = ("text", "data")  # an image from another renderer: compared on its own
        for name in ("direction", "connection", "op", "topic", "binary", "text", "data",
                     "step", "sim_time_ns", "seq"):  # fmt: skip
            if name not in skip and getattr(expected, name) != getattr(actual, name):
                self._frame_mismatch(i, expected, actual, f"{name} differs")
                return
        if is_marker(frame.direction, frame.connection, frame.op, frame.topic):
            self.markers += 1

    def _frame_mismatch(
        self, i: int, expected: BridgeFrame | None, actual: BridgeFrame | None, what: str
    ) -> None:
        ref = expected if expected is not None else actual
        assert ref is not None
        exp_text = _payload_text(expected) if expected is not None else ""
        act_text = _payload_text(actual) if actual is not None else ""
        exp_text, act_text = _excerpt(exp_text, act_text)
        if expected is not None and actual is not None and what != "text differs":
            exp_text = f"step {expected.step} seq {expected.seq} conn {expected.connection} " + (
                exp_text
            )
            act_text = f"step {actual.step} seq {actual.seq} conn {actual.connection} " + act_text
        self._fail(
            PipelineMismatch(
                kind="frame",
                step=ref.step,
                sim_time_ns=ref.sim_time_ns,
                connection=ref.connection,
                direction="in" if ref.direction == 0 else "out",
                op=ref.op,
                topic=ref.topic,
                what=what,
                expected=exp_text,
                actual=act_text,
                index=i,
            )
        )

    def write_applied_input(self, inp: AppliedInput) -> None:
        if self.mismatch is not None:
            return
        step = inp.step
        i = self.input_at
        self.input_at += 1
        if i >= len(self.inputs) or self.inputs[i].step > step:
            self._fail(self._input_missing(i, step, "the re-run applied a new input here"))
            return
        expected = self.inputs[i]
        if expected.step < step:
            self._fail(self._input_missing(i, expected.step, "the re-run applied no new input"))
            return
        if tuple(expected.kinematic_joints) != tuple(inp.kinematic_joints):
            self._fail(
                self._input(i, step, "kinematic_joints differ", expected.kinematic_joints,
                            tuple(inp.kinematic_joints))
            )  # fmt: skip
            return
        for name in ARRAY_FIELDS:
            dtype = np.uint32 if name.endswith("_index") else np.float64
            want = np.asarray(getattr(expected, name), dtype=dtype).reshape(-1)
            got = np.asarray(getattr(inp, name), dtype=dtype).reshape(-1)
            if same_bits(want, got):
                continue
            if want.shape != got.shape:
                self._fail(self._input(i, step, f"{name} has {got.size} values, not {want.size}",
                                       want.tolist(), got.tolist()))  # fmt: skip
                return
            j = int(np.flatnonzero(differing(want, got))[0])
            label = f"{name}[{j}]"
            if name == "ctrl":
                actuator = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_ACTUATOR, j)
                label += f" ({actuator})" if actuator else ""
            self._fail(self._input(i, step, f"{label} differs", want[j].item(), got[j].item()))
            return

    def _input(self, i: int, step: int, what: str, expected: Any, actual: Any) -> PipelineMismatch:
        return PipelineMismatch(
            kind="input",
            step=step,
            sim_time_ns=step * self.dt_ns,
            connection=None,
            direction="",
            op="",
            topic="/harness/inputs",
            what=what,
            expected=repr(expected),
            actual=repr(actual),
            index=i,
        )

    def _input_missing(self, i: int, step: int, what: str) -> PipelineMismatch:
        recorded = self.inputs[i].step if i < len(self.inputs) else None
        return self._input(
            i,
            step,
            what,
            f"next recorded input at step {recorded}" if recorded is not None else "none",
            f"an input at step {step}" if "new input here" in what else "none",
        )

    def after_step(self, k: int) -> None:
        """Inputs the recording has at or before step ``k`` and the re-run did not apply."""
        if self.mismatch is None and self.input_at < len(self.inputs):
            expected = self.inputs[self.input_at]
            if expected.step <= k:
                self._fail(
                    self._input_missing(
                        self.input_at, expected.step, "the re-run applied no new input"
                    )
                )

    def physics_state_slot(
        self, state_spec: int, state_size: int, qpos: slice, qvel: slice
    ) -> PhysicsStateSlot:
        return forwarding_slot(self.write_physics_state, state_spec, state_size, qpos, qvel)

    def write_physics_state(self, record: PhysicsState) -> None:
        if self.mismatch is not None:
            return
        step, sim_time_ns = record.step, record.sim_time_ns
        i = self.state_at
        self.state_at += 1
        if i >= len(self.state_steps) or int(self.state_steps[i]) != step:
            recorded = int(self.state_steps[i]) if i < len(self.state_steps) else None
            self._fail(
                PipelineMismatch(
                    "state", step, sim_time_ns, None, "", "", "/harness/state",
                    "the re-run recorded a state the recording does not have here",
                    f"state at step {recorded}" if recorded is not None else "none",
                    f"state at step {step}", i,
                )
            )  # fmt: skip
            return
        got = np.asarray(record.state, dtype=np.float64)
        want = self.states[i]
        if not same_bits(got, want):
            j = int(np.flatnonzero(differing(got, want))[0])
            self._fail(
                PipelineMismatch(
                    "state", step, sim_time_ns, None, "", "", "/harness/state",
                    f"state value {j} differs", repr(float(want[j])), repr(float(got[j])), i,
                )
            )  # fmt: skip

    def write_epoch(self, epoch: Epoch) -> None:
        if self.mismatch is not None:
            return
        step, reason, number = epoch.step, epoch.reason, epoch.epoch
        i = self.epoch_at
        self.epoch_at += 1
        expected = self.epochs[i] if i < len(self.epochs) else None
        what = ""
        if expected is None:
            what = "the re-run reset here; the recording has no epoch"
        elif (expected.step, expected.epoch, expected.reason) != (step, number, reason):
            what = f"epoch {number} ({reason}) after step {step} differs"
        elif not same_bits(
            np.asarray(epoch.state, dtype=np.float64), np.asarray(expected.state, np.float64)
        ):
            what = f"epoch {number}: the state it continues from differs"
        if what:
            self._fail(
                PipelineMismatch(
                    "state", step, epoch.sim_time_ns, None, "", "", TOPIC_EPOCH, what,
                    "none" if expected is None
                    else f"epoch {expected.epoch} ({expected.reason}) after step {expected.step}",
                    f"epoch {number} ({reason}) after step {step}", i,
                )
            )  # fmt: skip


def _recorded_failure(rec: Recording, stop: int | None) -> tuple[int, str] | None:
    """The step and text of the recorded run's failure (the session's FATAL ``/rosout``
    event, :meth:`SessionCore.fail`), None when it ran on."""
    for message in rec.messages("/rosout", stop_step=stop, decode=True):
        log = message.msg
        text = str(log.msg)
        fatal = int(log.level) >= int(Level.FATAL) and log.name == LOG_NAME
        if fatal and text.startswith(FAILURE_PREFIX):
            return message.sim_time_ns // rec.timestep_ns, text.removeprefix(FAILURE_PREFIX)
    return None


def _failure_mismatch(
    recorded: tuple[int, str] | None, core: SessionCore, dt_ns: int
) -> PipelineMismatch | None:
    """The re-run's failure against the recorded one (None when they agree)."""
    actual = None
    if core.failure is not None and core.failure_step is not None:
        actual = (core.failure_step, str(core.failure))
    if actual == recorded:
        return None
    ref = recorded if recorded is not None else actual
    assert ref is not None
    what = (
        "the re-run did not fail (a failing Python logger? pass the same loggers)"
        if actual is None
        else "the recorded run did not fail here"
        if recorded is None
        else "the re-run failed differently"
    )

    def text(failure: tuple[int, str] | None) -> str:
        return "ran on" if failure is None else f"step {failure[0]}: {failure[1]}"

    return PipelineMismatch(
        "failure", ref[0], ref[0] * dt_ns, None, "", "", "/rosout", what,
        text(recorded), text(actual), 0,
    )  # fmt: skip


def _session_robot(rec: Recording) -> LoadedRobot | LoadedWorld:
    robot = rebuild_run(rec)
    expected = rec.metadata.get("model_sha256", "")
    if expected and robot.sha256 != expected:
        raise RecordedDataError(
            f"{rec.path}: the source attachments rebuild to a model whose MJCF SHA-256 "
            f"{robot.sha256[:12]}... is not the recorded {expected[:12]}...: --level full needs "
            "the robot the session ran"
        )
    model, _ = resolve_model(rec)  # the exact binary model when attached
    return dataclasses.replace(robot, model=model)


def replay_pipeline(
    path: str | Path,
    *,
    allow_damaged: bool = False,
    loggers: Iterable[Logger] = (),
    progress: Callable[[int, int], None] | None = None,
) -> PipelineReport:
    """Re-run the session recording at ``path`` through a fresh :class:`SessionCore` and
    compare its frames, inputs and states with the recording (see the module docstring).
    Raises :class:`LevelUnavailableError` for recordings the pipeline cannot re-run."""
    started = time.perf_counter()
    with open_recording(path, allow_damaged=allow_damaged) as rec:
        metadata = rec.metadata
        if "clock" not in metadata:
            raise LevelUnavailableError(
                f"{path}: not a session recording (no 'clock' in the metadata): --level full "
                "re-runs a Session's bridge pipeline; use --level physics"
            )
        if metadata.get("transport") == "client" and "upstream" not in metadata:
            raise LevelUnavailableError(
                f"{path}: recorded by an older session in client mode (connected to an "
                "external rosbridge server): its bridge frames were not recorded, so --level full "
                "cannot re-run them; use --level physics"
            )
        if metadata.get("bridge_frames") == "false":
            raise LevelUnavailableError(
                f"{path}: recorded with record_bridge_frames=False (scenario "
                "recording.bridge_frames: false): there are no bridge frames to re-run, so "
                "--level full cannot; use --level physics"
            )
        try:
            options = CoreOptions.from_metadata(metadata)
        except HarnessError as exc:
            raise RecordedDataError(f"{path}: {exc}") from None
        robot = _session_robot(rec)
        # A damaged stretch ends what can be re-run: frames after it depend on what it held.
        stop = rec.lost[0].first_step if rec.lost else None
        frames = list(rec.bridge_frames(None, stop))
        inputs = list(rec.applied_inputs(None, stop))
        states = read_states(rec, None, stop)
        epochs = rec.epochs(None, stop)
        recorded_failure = _recorded_failure(rec, stop)
        dt_ns = rec.timestep_ns
        notes = [
            "damaged recording, re-ran up to the first damage: "
            + "; ".join(str(p) for p in rec.problems)
        ] if rec.problems else []  # fmt: skip
        made: list[SessionCore] = []
        sensor_check = SensorCheck(
            rec, lambda: made[0].sensors.renderer_info if made and made[0].sensors else None
        )
    checker = _Checker(robot.model, frames, inputs, states.steps, states.state, dt_ns, epochs)
    hub = EventHub()
    for logger in loggers:
        hub.add_logger(logger)
    core = SessionCore(robot, options, recorder=checker, hub=hub)
    made.append(core)
    checker.sensors = sensor_check if sensor_check.topics else None
    bridge = core.bridge
    assert bridge is not None
    sim = core.sim
    final = max(
        [int(states.steps[-1])]
        + [f.step if f.direction == 1 else f.step - 1 for f in frames]
        + [i.step for i in inputs]
    )

    def advance_to(target: int) -> None:
        while sim.step_index < target and checker.mismatch is None and core.failure is None:
            # advance() keeps any failure as core.failure (as live): compared below
            with contextlib.suppress(Exception):
                core.advance()
            core.record_frames()
            bridge.drain()
            checker.after_step(sim.step_index)
            if recorded_failure is not None and sim.step_index >= recorded_failure[0]:
                failed = _failure_mismatch(recorded_failure, core, dt_ns)
                first = checker.mismatch
                if failed is not None and (first is None or first.step >= failed.step):
                    checker.mismatch = failed  # the cause of what differs at this step
            if progress is not None:
                progress(sim.step_index, final)

    core.start()
    core.publish_initial()
    core.record_frames()
    bridge.drain()
    for frame in frames:
        if checker.mismatch is not None:
            break
        if frame.direction != 0:
            continue
        target = frame.step - 1
        advance_to(target)
        if checker.mismatch is not None:
            break
        if sim.step_index != target:
            checker._fail(
                PipelineMismatch(
                    "schedule", frame.step, frame.sim_time_ns, frame.connection, "in", frame.op,
                    frame.topic,
                    f"recorded as applied before step {frame.step}, but the re-run is at step "
                    f"{sim.step_index}" + (f" and failed: {core.failure}" if core.failure else ""),
                    f"boundary before step {frame.step}", f"step {sim.step_index}",
                    checker.frame_at,
                )
            )  # fmt: skip
            break
        core.replay_frame(frame.connection, frame.op, frame.topic, frame.payload)
        core.record_frames()
        bridge.drain()
        checker.after_step(sim.step_index)  # a /harness/step call steps inside the frame
    advance_to(final)
    if checker.mismatch is None:
        core.finish()
        bridge.drain()
    if checker.mismatch is None:
        failed = _failure_mismatch(recorded_failure, core, dt_ns)
        if failed is not None:
            checker._fail(failed)
    if checker.mismatch is None and checker.frame_at < len(frames):
        checker._frame_mismatch(
            checker.frame_at, frames[checker.frame_at], None, "the re-run did not produce it"
        )
    if checker.mismatch is None and checker.input_at < len(inputs):
        checker.after_step(inputs[checker.input_at].step)
    missing = sensor_check.missing() if sensor_check.topics else None
    if checker.mismatch is None and missing is not None:
        checker._fail(
            PipelineMismatch("sensor", sim.step_index, sim.sim_time_ns, None, "", "", "",
                             missing, "", "", sensor_check.compared)
        )  # fmt: skip
    if sensor_check.compared:
        notes.append(f"{sensor_check.compared} sensor messages compared")
    notes.extend(sensor_check.notes)
    if checker.mismatch is None and checker.state_at < len(states.steps):
        i = checker.state_at
        step = int(states.steps[i])
        checker._fail(
            PipelineMismatch(
                "state", step, step * dt_ns, None, "", "", "/harness/state",
                "the re-run did not record this state", f"state at step {step}", "none", i,
            )
        )  # fmt: skip
    if checker.mismatch is None and checker.epoch_at < len(epochs):
        e = epochs[checker.epoch_at]
        checker._fail(
            PipelineMismatch(
                "state", e.step, e.sim_time_ns, None, "", "", TOPIC_EPOCH,
                "the re-run did not reset here", f"epoch {e.epoch} ({e.reason}) after step "
                f"{e.step}", "none", checker.epoch_at,
            )
        )  # fmt: skip
    return PipelineReport(
        reproduced=checker.mismatch is None,
        steps=sim.step_index,
        frames_compared=checker.frame_at,
        inputs_compared=checker.input_at,
        states_compared=checker.state_at,
        markers=checker.markers,
        mismatch=checker.mismatch,
        wall_seconds=time.perf_counter() - started,
        notes=tuple(notes),
        failure=""
        if core.failure is None
        else f"step {core.failure_step}: {type(core.failure).__name__}: {core.failure}",
    )
