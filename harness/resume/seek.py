"""Bring a fresh session core to step ``k`` of a recording by running the recorded inputs
through it: the seek behind ``harness serve --from RUN.mcap --at K``.

The core is the one a live :class:`~harness.session.Session` runs (:class:`SessionCore`),
rebuilt from the recording as ``harness replay --level full`` rebuilds it (the robot from its
source attachments, the exact binary model when attached, the options from the metadata).
Every recorded incoming frame and marker that took effect before step ``k`` (``step <= k``)
is applied at the step boundary it was recorded at, and the core steps as recorded in
between; so the controllers, trajectories and goals in flight, filters, odometry, the sensors'
noise streams, the clock, the bridge graph (every recorded client's connection, subscriptions,
advertised topics, services, goals) and the latched topics are what they were at ``k``,
because they are computed, not restored. The frames recorded at the boundary after step ``k``
(``step == k + 1``) are not applied: they are the continuation a live client (or a test
feeding the parent's frames) provides.

While it seeks, every physics state the core records is compared bit for bit with the
recording's state at that step: a re-run that does not reproduce the recording up to ``k``
is refused (a resumed run would not be the recorded world). What the core records during the
seek goes to the child recording when there is one (:mod:`harness.resume.child`): the child
holds the re-derived run up to ``k`` (the parent's step numbers), then what happens after.

Refused, one line each (:mod:`harness.resume.errors`): a step beyond the recording, a
damaged stretch at or before the step, a recording of another MuJoCo or harness version, a
step inside a client's ``/harness/step`` request (the message names the steps around it), a
run that failed before the step, a recording that is not a replayable session recording.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness._version import __version__
from harness.errors import HarnessError
from harness.events import EventHub, Logger, RecordingSink
from harness.models import LoadedRobot, LoadedWorld
from harness.recording import (
    AppliedInput,
    BridgeFrame,
    Epoch,
    PhysicsStateSlot,
    Recorder,
    Recording,
)
from harness.replay import open_recording, rebuild_run, resolve_model
from harness.resume.child import child_metadata
from harness.resume.errors import ResumeError, ResumeStepError, ResumeVersionError
from harness.session.core import CoreOptions, SessionCore

__all__ = ["Fork", "file_sha256", "resolve_step", "seek"]

F64 = npt.NDArray[np.float64]


@dataclass
class Fork:
    """A core brought to :attr:`step` of the recording at :attr:`parent`, ready for a live
    shell (``Session.resume``) or to be driven directly (tests, bench)."""

    core: SessionCore
    """The core at :attr:`step`: started, its graph and clock as recorded."""
    recorder: Recorder | None
    """The child recording (None when the resumed run records nothing)."""
    sink: ForkSink
    """What the core records into (the child recorder, behind the seek's state check)."""
    parent: Path
    parent_sha256: str
    step: int
    parent_last_step: int
    """The last step the parent recording holds."""
    ghosts: tuple[int, ...]
    """The recorded clients' connections still open at :attr:`step` (ghost peers: their
    subscriptions, advertised topics and goals live on in the core, what is sent to them is
    recorded, not sent)."""
    frames_applied: int
    states_checked: int
    seek_seconds: float


def file_sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def resolve_step(
    path: Path, last_step: int, dt_ns: int, step: int | None, at_time: float | None
) -> int:
    """The step to resume at: ``step``, or the step nearest ``at_time`` seconds of sim time,
    or the recording's last step when neither is given. Refuses a step outside
    ``0..last_step`` (:class:`ResumeStepError`)."""
    if step is not None and at_time is not None:
        raise ResumeStepError("give the step (--at) or the sim time (--at-time), not both")
    where = f"{path}: "
    if at_time is not None:
        if not (isinstance(at_time, int | float) and np.isfinite(at_time) and at_time >= 0):
            raise ResumeStepError(f"{where}--at-time must be >= 0 seconds, not {at_time!r}")
        step = round(round(float(at_time) * 1e9) / dt_ns)
    if step is None:
        step = last_step
    if isinstance(step, bool) or not isinstance(step, int) or step < 0:
        raise ResumeStepError(f"{where}--at must be a step >= 0, not {step!r}")
    if step > last_step:
        raise ResumeStepError(
            f"{where}step {step} is beyond the recording: it ends at step {last_step} "
            f"({last_step * dt_ns / 1e9:g} s of sim time)"
        )
    return step


class ForkSink:
    """The core's :class:`~harness.session.RecordSink` of a resumed run: everything goes to
    the child recorder (when there is one); while :attr:`checking`, each physics state is
    also compared with the parent's state at that step (:meth:`check`)."""

    def __init__(self, recorder: Recorder | None, parent: Path) -> None:
        self.recorder = recorder
        self.parent = parent
        self.checking = True
        self.checked = 0
        self._expected: Iterator[tuple[int, F64]] = iter(())
        self._next: tuple[int, F64] | None = None
        self.mismatch = ""

    def expect(self, states: Iterator[tuple[int, F64]]) -> None:
        """The parent's states, ``(step, state)`` in step order, to compare while seeking."""
        self._expected = states
        self._next = next(states, None)

    def check(self, step: int, state: F64) -> None:
        """Compare the core's state after ``step`` with the parent's (steps the parent did
        not record are skipped); the first difference is kept in :attr:`mismatch`."""
        if self.mismatch:
            return
        while self._next is not None and self._next[0] < step:
            self._next = next(self._expected, None)
        if self._next is None or self._next[0] != step:
            return
        want = self._next[1]
        if want.shape != state.shape or want.tobytes() != state.tobytes():
            differs = np.flatnonzero(want.view(np.uint64) != state.view(np.uint64))
            at = int(differs[0]) if want.shape == state.shape and differs.size else 0
            self.mismatch = (
                f"{self.parent}: the re-run diverged from the recording at step {step} (state "
                f"value {at}: recorded {float(want.flat[at])!r}, re-run {float(state.flat[at])!r})"
                f": it cannot be resumed past it (harness replay {self.parent} --level full "
                "shows why)"
            )
        self.checked += 1

    # -- RecordSink ------------------------------------------------------------------------

    def write_message(self, topic: str, msgtype: str, msg: Any, *, sim_time_ns: int) -> None:
        if self.recorder is not None:
            self.recorder.write_message(topic, msgtype, msg, sim_time_ns=sim_time_ns)

    def write_bridge_frame(self, frame: BridgeFrame) -> None:
        if self.recorder is not None:
            self.recorder.write_bridge_frame(frame)

    def write_applied_input(self, inp: AppliedInput) -> None:
        if self.recorder is not None:
            self.recorder.write_applied_input(inp)

    def write_epoch(self, epoch: Epoch) -> None:
        if self.recorder is not None:
            self.recorder.write_epoch(epoch)

    def write_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """A metadata record (the sensors' configuration) for the child recording."""
        if self.recorder is not None:
            self.recorder.write_metadata(name, data)

    def physics_state_slot(
        self, state_spec: int, state_size: int, qpos: slice, qvel: slice
    ) -> PhysicsStateSlot:
        inner = (
            None
            if self.recorder is None
            else self.recorder.physics_state_slot(state_spec, state_size, qpos, qvel)
        )
        state = inner.state if inner is not None else np.zeros(state_size, dtype=np.float64)
        record = inner.write if inner is not None else None

        def write(step: int, sim_time_ns: int) -> None:
            if self.checking:
                self.check(step, state)
            if record is not None:
                record(step, sim_time_ns)

        return PhysicsStateSlot(state, write)


def _check_recording(rec: Recording, path: Path, step_hint: str) -> None:
    metadata = rec.metadata
    if "clock" not in metadata:
        raise ResumeError(
            f"{path}: not a session recording (no 'clock' in the metadata): only a Session's "
            "recording holds the inputs a resume re-runs"
        )
    if metadata.get("bridge_frames") == "false":
        raise ResumeError(
            f"{path}: recorded with record_bridge_frames=False: without its bridge frames "
            "the run cannot be re-run to a step"
        )
    if metadata.get("transport") == "client" and "upstream" not in metadata:
        raise ResumeError(
            f"{path}: recorded by an older session in client mode: its bridge frames were not "
            "recorded, so it cannot be re-run to a step"
        )
    for key, running in (("mujoco_version", mujoco.__version__), ("harness_version", __version__)):
        recorded = metadata.get(key, "")
        if recorded != running:
            what = key.split("_")[0].replace("mujoco", "MuJoCo")
            raise ResumeVersionError(
                f"{path}: recorded with {what} {recorded or '(unknown)'}, this is {what} "
                f"{running}: a resume re-runs the recording bit for bit, which only the same "
                f"version does (resume {step_hint} with {what} {recorded or 'of the recording'})"
            )


def _check_damage(rec: Recording, path: Path, step: int) -> None:
    for lost in rec.lost:
        if lost.first_step <= step:
            last = "the end" if lost.last_step is None else f"step {lost.last_step}"
            earlier = (
                f"resume at step {lost.first_step - 1} or earlier, or "
                if lost.first_step > 0
                else ""
            )
            raise ResumeError(
                f"{path}: damaged before step {step} (bytes {lost.offset}..{lost.end}, steps "
                f"{lost.first_step} to {last} lost: {lost.what}): a resume re-runs every input "
                f"before the step; {earlier}rewrite it with harness repair"
            )


def _rebuild(rec: Recording, path: Path) -> LoadedRobot | LoadedWorld:
    robot = rebuild_run(rec)
    expected = rec.metadata.get("model_sha256", "")
    if expected and robot.sha256 != expected:
        raise ResumeError(
            f"{path}: the source attachments rebuild to a model whose MJCF SHA-256 "
            f"{robot.sha256[:12]}... is not the recorded {expected[:12]}...: a resume needs "
            "the robot the session ran"
        )
    model, _ = resolve_model(rec)
    return dataclasses.replace(robot, model=model)


def _parent_states(rec: Recording, stop: int) -> Iterator[tuple[int, F64]]:
    for block in rec.physics_state_blocks(None, stop, rows=4096):
        for i, step in enumerate(block.steps):
            yield int(step), block.state[i]


def seek(
    path: str | Path,
    *,
    step: int | None = None,
    at_time: float | None = None,
    record_to: str | Path | None = None,
    edits: Sequence[Mapping[str, object]] = (),
    loggers: Iterable[Logger] = (),
    progress: Callable[[int, int], None] | None = None,
) -> Fork:
    """The core of the recording at ``path`` brought to ``step`` (or to the step at
    ``at_time`` seconds; the last step when neither is given) by re-running the recorded
    inputs; ``record_to``: the child recording (its metadata names the parent, its SHA-256
    and the step; ``edits``: the fork edits it will carry, as JSON-ready mappings, for its
    metadata). See the module docstring for what is refused."""
    started = time.perf_counter()
    path = Path(path)
    hint = f"at {step}" if step is not None else "it"
    recorder: Recorder | None = None
    try:
        with open_recording(path, allow_damaged=True) as rec:
            _check_recording(rec, path, hint)
            parent_sha256 = file_sha256(path)
            dt_ns = rec.timestep_ns
            last = rec.last_step
            k = resolve_step(path, last, dt_ns, step, at_time)
            _check_damage(rec, path, k)
            try:
                options = CoreOptions.from_metadata(rec.metadata)
            except HarnessError as exc:
                raise ResumeError(f"{path}: {exc}") from None
            robot = _rebuild(rec, path)
            if record_to is not None:
                recorder = Recorder(
                    record_to,
                    metadata=child_metadata(rec.metadata, path, parent_sha256, k, edits),
                    attachments=rec.attachments,
                    state_every=options.state_every,
                )
            sink = ForkSink(recorder, path)
            sink.expect(_parent_states(rec, k + 1))
            hub = EventHub()
            if recorder is not None:
                hub.add_sink(RecordingSink(recorder))
            for logger in loggers:
                hub.add_logger(logger)
            core = SessionCore(robot, options, recorder=sink, hub=hub)
            applied = _drive(core, sink, rec.bridge_frames(None, k + 1), k, path, progress)
    except BaseException:
        if recorder is not None:  # a resume that did not start leaves no child behind
            recorder.close()
            with contextlib.suppress(OSError):
                recorder.path.unlink()
        raise
    sink.checking = False
    bridge = core.bridge
    assert bridge is not None
    return Fork(
        core=core,
        recorder=recorder,
        sink=sink,
        parent=path,
        parent_sha256=parent_sha256,
        step=k,
        parent_last_step=last,
        ghosts=tuple(bridge.connections),
        frames_applied=applied,
        states_checked=sink.checked,
        seek_seconds=time.perf_counter() - started,
    )


def _drive(
    core: SessionCore,
    sink: ForkSink,
    frames: Iterable[BridgeFrame],
    k: int,
    path: Path,
    progress: Callable[[int, int], None] | None,
) -> int:
    """Apply every recorded incoming frame and marker with ``step <= k`` at its boundary,
    stepping as recorded in between, then step to ``k``; returns the frames applied."""
    bridge = core.bridge
    assert bridge is not None
    sim = core.sim

    def settle() -> None:
        core.record_frames()
        bridge.drain()  # what went to the recorded clients then
        if sink.mismatch:
            raise ResumeError(sink.mismatch)
        if core.failure is not None:
            raise ResumeStepError(
                f"{path}: the run failed at step {core.failure_step} ({core.failure}), before "
                f"step {k}: resume at step {max(0, (core.failure_step or 1) - 1)} or earlier"
            )

    def advance_to(target: int) -> None:
        while sim.step_index < target:
            with contextlib.suppress(Exception):  # core.failure, reported by settle()
                core.advance()
            settle()
            if progress is not None:
                progress(sim.step_index, k)

    core.start()
    core.publish_initial()
    settle()
    applied = 0
    for frame in frames:
        if frame.direction != 0 or frame.step > k:
            continue
        before = frame.step - 1
        advance_to(before)
        if sim.step_index != before:
            raise ResumeError(
                f"{path}: a frame recorded before step {frame.step} finds the re-run at step "
                f"{sim.step_index}: the recording does not re-run (harness replay {path} "
                "--level full shows why)"
            )
        try:
            core.replay_frame(frame.connection, frame.op, frame.topic, frame.payload)
        except HarnessError as exc:
            raise ResumeError(f"{path}: frame before step {frame.step}: {exc}") from None
        applied += 1
        if sim.step_index > k:
            raise ResumeStepError(
                f"{path}: step {k} lies inside connection {frame.connection}'s "
                f"{frame.topic or frame.op} request (steps {before}..{sim.step_index}): resume "
                f"at step {before} or {sim.step_index}"
            )
        settle()
    advance_to(k)
    return applied
