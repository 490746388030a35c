"""``Recorder``: writes one run to an MCAP file (profile ``ros2``, every channel CDR).

Writes take the record types of :mod:`harness.recording.records` (for example
``write_physics_state(PhysicsState(...))``), are serialised under a lock (callers may be the
simulation thread and the bridge's event loop) and append to the open chunk of the
:class:`~harness.recording.writer.ChunkWriter`; a full chunk is compressed and written by the
writer's own thread (a few may wait; beyond that the caller waits): nothing can be dropped.
The cost is measured in ``bench/bench_recording.py``.

Byte-reproducible: chunks close by size (``chunk_size`` of records), never by the wall clock,
so two runs that record the same records give the same file (with a fixed ``library``).
Crash safety: a daemon thread writes the open chunk every ``flush_interval_s`` as a
provisional tail after the committed bytes (:mod:`harness.recording.tail`: a complete chunk
with its CRC and message indexes, replaced by the chunk when it closes), so a killed process
loses at most the last interval (a flush first waits for the closed chunks to be written);
the file then lacks only its summary and footer, and :class:`~harness.recording.Recording`
opens it up to the last complete chunk (``harness repair`` completes it). A flush that fails
(disk full) is raised by the next ``write_*`` call.
"""

from __future__ import annotations

import contextlib
import os
import struct
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, NamedTuple, NoReturn

import numpy as np
import numpy.typing as npt

from harness._version import __version__
from harness.recording.cdr import (
    CDR_HEADER,
    Encoder,
    Unsupported,
    bridge_frame,
    compile_encoder,
    physics_state,
    physics_state_parts,
)
from harness.recording.convert import from_rosbridge
from harness.recording.errors import RecordingWriteError
from harness.recording.layout import (
    METADATA_NAME,
    PROFILE,
    TOPIC_BRIDGE,
    TOPIC_COLLISIONS,
    TOPIC_EPOCH,
    TOPIC_INPUTS,
    TOPIC_ROSOUT,
    TOPIC_STATE,
    TYPE_APPLIED_INPUT,
    TYPE_BRIDGE_FRAME,
    TYPE_COLLISION_EVENT,
    TYPE_EPOCH,
    TYPE_PHYSICS_STATE,
    channel_metadata,
    is_latched,
    schema_text,
    typestore,
)
from harness.recording.messages import (
    applied_input_message,
    collision_event_message,
    epoch_message,
    f64,
    rosout_message,
)
from harness.recording.metadata import build_metadata, definitions_text, media_type, package_version
from harness.recording.periodic import PERIODIC_RECORDS
from harness.recording.records import (
    AppliedInput,
    BridgeFrame,
    CollisionEvent,
    Epoch,
    PhysicsState,
    RosoutRecord,
)
from harness.recording.salvage import finish_after_failure
from harness.recording.stateslot import HEAD, PhysicsStateSlot, StateRecords
from harness.recording.tail import TailFile
from harness.recording.writer import COMPRESSIONS, Buffer, ChunkWriter

__all__ = ["MAX_RECORDING_BYTES", "STATE_RING", "FlushInfo", "Recorder", "RecorderStats"]

STATE_RING = 32
"""States a physics state slot fills before they move into the chunk under the lock (the flush
thread moves those filled so far too: crash safety is unchanged)."""

MAX_RECORDING_BYTES = 16 * 2**30
"""Default size limit of one recording (16 GiB: hours of full-rate recording of a robot arm;
a runaway run stops there instead of filling the disk)."""

_F64 = np.dtype(np.float64)
_EMPTY_F64: npt.NDArray[np.float64] = np.zeros(0, np.float64)
_EMPTY_U32: npt.NDArray[np.uint32] = np.zeros(0, np.uint32)


class FlushInfo(NamedTuple):
    """What a flush made durable: every message up to ``sim_time_ns`` (``-1``: none yet)."""

    sim_time_ns: int
    messages: int
    file_bytes: int
    seconds: float


class RecorderStats(NamedTuple):
    """Counters of a recorder; ``flush_seconds_max`` is the longest a flush held writers up."""

    messages: int
    flushes: int
    file_bytes: int
    flush_seconds_total: float
    flush_seconds_max: float


def _uncompiled(value: Mapping[str, Any]) -> bytes:
    raise AssertionError("never called: marks a type not compiled yet")


_UNCOMPILED: Encoder = _uncompiled


def _compile(store: Any, msgtype: str) -> Encoder | None:
    """The compiled CDR encoder of ``msgtype`` (``None``: the type takes the generic path)."""
    try:
        return compile_encoder(store, msgtype)
    except Unsupported:
        return None


class _Channel:
    """A recorded topic: its MCAP channel id, type and the next sequence number."""

    __slots__ = ("id", "msgtype", "seq", "topic")

    def __init__(self, channel_id: int, topic: str, msgtype: str) -> None:
        self.id = channel_id
        self.topic = topic
        self.msgtype = msgtype
        self.seq = 0


class Recorder:
    """Writes one run to ``path`` (a context manager; ``close()`` writes the summary).

    ``metadata`` must hold the keys in ``layout.METADATA_REQUIRED`` (``timestep`` in seconds,
    ``integrator``, ``seed``, ``model_sha256``, ``control_modes``), all strings; versions and
    platform are added. ``attachments`` maps names to bytes (compiled MJCF, sources,
    scenario; see :func:`harness.recording.describe_run`); at least one is always written.
    ``state_every``: ``write_physics_state`` keeps steps that are multiples of it.
    ``library``: the header's library string (fix it for byte-identical files).
    ``on_flush``: called (from the flushing thread) after each flush.
    ``max_bytes``: the file's size limit (default :data:`MAX_RECORDING_BYTES`), checked at
    every flush: beyond it writes fail with :class:`RecordingWriteError` (the file is still
    closed cleanly).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        metadata: Mapping[str, str],
        attachments: Mapping[str, bytes] = {},
        compression: str = "zstd",
        state_every: int = 1,
        flush_interval_s: float = 1.0,
        chunk_size: int = 1024 * 1024,
        library: str | None = None,
        on_flush: Callable[[FlushInfo], None] | None = None,
        max_bytes: int = MAX_RECORDING_BYTES,
    ) -> None:
        if compression not in COMPRESSIONS:
            raise RecordingWriteError(
                f"compression must be one of {', '.join(COMPRESSIONS)}, got {compression!r}"
            )
        if not isinstance(state_every, int) or state_every < 1:
            raise RecordingWriteError(f"state_every must be an integer >= 1, got {state_every!r}")
        if not flush_interval_s > 0:
            raise RecordingWriteError(f"flush_interval_s must be > 0, got {flush_interval_s!r}")
        if not isinstance(max_bytes, int) or max_bytes < 1:
            raise RecordingWriteError(f"max_bytes must be an integer >= 1, got {max_bytes!r}")
        self.max_bytes = max_bytes
        self.path = Path(path)
        self.metadata = build_metadata(metadata, state_every=state_every, compression=compression)
        for name, blob in attachments.items():
            if not isinstance(blob, bytes | bytearray | memoryview):
                raise RecordingWriteError(f"attachment {name!r}: expected bytes")
        self._state_every = state_every
        self._store = typestore()
        self._types = self._store.types
        self._on_flush = on_flush
        self._encoders: dict[str, Encoder | None] = {}
        self._lock = threading.Lock()
        self._channels: dict[str, _Channel] = {}
        self._state_channel: _Channel | None = None
        self._state_slot = False
        self._bridge_channel: _Channel | None = None
        self._schemas: dict[str, int] = {}
        self._last_time = -1
        self._messages = 0
        self._dirty = False
        self._closed = False
        self._failure: BaseException | None = None
        self._flushes = 0
        self._flush_total = 0.0
        self._flush_max = 0.0
        try:
            self._stream = TailFile(self.path)  # closed in close()
        except OSError as exc:
            raise RecordingWriteError(
                f"{self.path}: cannot create recording: {exc.strerror}"
            ) from None
        try:
            self._writer = ChunkWriter(
                self._stream,
                profile=PROFILE,
                library=library or f"harness/{__version__} mcap-python/{package_version('mcap')}",
                chunk_size=chunk_size,
                compression=compression,
            )
            self._writer.add_metadata(METADATA_NAME, self.metadata)
            if not attachments:
                # An MCAP without attachments gets empty index groups that strict doctors flag.
                attachments = {"harness_msgs.txt": definitions_text()}
            for name, blob in attachments.items():
                self._writer.add_attachment(name, media_type(name), bytes(blob))
            # Header and attachments reach the file system now: a full disk (or a file size
            # limit) is reported here, before the run starts, not at the first flush.
            self._stream.flush()
            self._append = self._writer.add
        except OSError as exc:
            with contextlib.suppress(OSError):
                self._stream.close()
            if self.path.is_file():
                with contextlib.suppress(OSError):
                    self.path.unlink()
            raise RecordingWriteError(
                f"{self.path}: cannot write recording: {exc.strerror or exc}"
            ) from None
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=self._flush_loop, args=(flush_interval_s,), name="harness-recorder", daemon=True
        )
        self._thread.start()

    # -- context manager -------------------------------------------------------------------

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- writing ---------------------------------------------------------------------------

    def write_message(self, topic: str, msgtype: str, msg: Any, *, sim_time_ns: int) -> None:
        """Record ``msg`` on ``topic``: a dict in rosbridge JSON form, a rosbags object, a
        periodic record (:mod:`harness.recording.periodic`) or ``bytes``: the message's CDR,
        written as it is (see :mod:`harness.recording.templates`)."""
        if type(msg) in PERIODIC_RECORDS:
            msg = msg.cdr()
        if type(msg) is bytes:
            if not msg.startswith(CDR_HEADER):
                raise RecordingWriteError(
                    f"{topic} ({msgtype}): pre-serialised message does not start with the "
                    "little-endian CDR header 00 01 00 00"
                )
            self._write_cdr(topic, msgtype, (msg,), len(msg), sim_time_ns)
            return
        if isinstance(msg, Mapping):
            encode = self._encoders.get(msgtype, _UNCOMPILED)
            if encode is _UNCOMPILED:
                encode = self._encoders[msgtype] = _compile(self._store, msgtype)
            if encode is not None:
                try:
                    data = encode(msg)
                except Unsupported:
                    pass  # the generic path below serialises it or says what is wrong
                else:
                    self._write_cdr(topic, msgtype, (data,), len(data), sim_time_ns)
                    return
            msg = from_rosbridge(self._store, msgtype, msg, where=f"{topic} ({msgtype})")
        elif getattr(msg, "__msgtype__", msgtype) != msgtype:
            raise RecordingWriteError(f"{topic}: message is a {msg.__msgtype__}, not a {msgtype}")
        self._write(topic, msgtype, msg, sim_time_ns)

    def write_bridge_frame(self, frame: BridgeFrame) -> None:
        """Record one rosbridge frame: ``frame.data`` when ``frame.binary``, else ``frame.text``."""
        step, time_ns, direction, connection, seq, op, topic, binary, text, data = frame
        if text if binary else data:
            raise RecordingWriteError(
                f"{TOPIC_BRIDGE} seq {seq}: a binary frame carries data, a text frame "
                "text: give exactly one of text= or data="
            )
        if direction != 0 and direction != 1:
            raise RecordingWriteError(f"{TOPIC_BRIDGE} seq {seq}: direction must be 0 or 1")
        try:
            cdr = bridge_frame(
                step, time_ns, direction, connection, seq, op, topic,
                None if binary else text, data if binary else None,
            )  # fmt: skip
        except (struct.error, UnicodeEncodeError, AttributeError, TypeError) as exc:
            where = f"{TOPIC_BRIDGE} seq {seq}"
            raise RecordingWriteError(f"{where}: cannot serialise: {exc}") from None
        channel = self._bridge_channel or self._fixed(TOPIC_BRIDGE, TYPE_BRIDGE_FRAME)
        self._write_on(channel, (cdr,), len(cdr), time_ns)

    def write_physics_state(self, record: PhysicsState) -> None:
        """Record the state after ``record.step`` if the step is a multiple of ``state_every``
        (a run recording every step: :meth:`physics_state_slot`)."""
        step, time_ns, state_spec, state, qpos, qvel = record
        if step % self._state_every:
            return
        try:
            # MuJoCo's own float64 arrays go into the file as they are (no copy of their
            # bytes); anything else is converted (and checked) first.
            fast = physics_state_parts(step, time_ns, state_spec, state, qpos, qvel)
            if fast is not None:
                parts, size = fast
            else:
                where = f"{TOPIC_STATE} step {step}"
                data = physics_state(
                    step,
                    time_ns,
                    state_spec,
                    f64(state, f"{where}: state"),
                    f64(qpos, f"{where}: qpos"),
                    f64(qvel, f"{where}: qvel"),
                )
                parts, size = (data,), len(data)
        except (struct.error, TypeError) as exc:
            where = f"{TOPIC_STATE} step {step}"
            raise RecordingWriteError(f"{where}: cannot serialise: {exc}") from None
        channel = self._state_channel or self._fixed(TOPIC_STATE, TYPE_PHYSICS_STATE)
        self._write_on(channel, parts, size, time_ns)

    def physics_state_slot(
        self, state_spec: int, state_size: int, qpos: slice, qvel: slice
    ) -> PhysicsStateSlot:
        """A slot recording a run's state after each step in place: read the state into
        ``slot.state`` (``state_size`` values; ``qpos`` and ``qvel`` where MuJoCo's qpos and
        qvel lie in it), then call ``slot.write(step, sim_time_ns)``. The same messages as
        :meth:`write_physics_state` (``state_every`` applies), without a record or a layout
        per step (:mod:`harness.recording.stateslot`). One slot per recorder; write from the
        thread that writes the other messages."""
        if self._state_slot:
            raise RecordingWriteError(f"{self.path}: a recorder has one physics state slot")
        records = StateRecords(STATE_RING, 0, state_spec, state_size, qpos, qvel)
        self._state_slot = True
        ring, every = records.ring, self._state_every
        buffer, size, times, targets = ring.buffer, ring.record_size, ring.times, records.targets
        state, qpos_part, qvel_part = records.sources
        pack, length = HEAD.pack_into, 22 + records.message_size
        channel = _Channel(0, TOPIC_STATE, TYPE_PHYSICS_STATE)  # until the first write

        def write(step: int, sim_time_ns: int) -> None:
            nonlocal channel
            if step % every:
                return
            if (
                sim_time_ns < self._last_time
                or sim_time_ns < 0
                or self._closed
                or self._failure is not None
            ):
                self._slot_refusal(channel, step, sim_time_ns)
            if not channel.id:
                channel = self._fixed(TOPIC_STATE, TYPE_PHYSICS_STATE)
                ring.channel_id = channel.id
                self._writer.attach(ring)
            i = ring.count
            seq = channel.seq
            try:
                pack(
                    buffer, i * size, 5, length, channel.id, seq, sim_time_ns, sim_time_ns,
                    CDR_HEADER, step, sim_time_ns, state_spec, state_size,
                )  # fmt: skip
            except struct.error as exc:
                raise RecordingWriteError(
                    f"{TOPIC_STATE} step {step}: cannot serialise: {exc}"
                ) from None
            to_state, to_qpos, to_qvel = targets[i]
            to_state[:] = state
            to_qpos[:] = qpos_part
            to_qvel[:] = qvel_part
            times[i] = sim_time_ns
            channel.seq = seq + 1
            i += 1
            ring.count = i  # complete: a flush may move it from here on
            # Marked after it: a flush clears _dirty before it settles, so a record it
            # missed leaves _dirty set for the next one.
            self._last_time = sim_time_ns
            self._messages += 1
            self._dirty = True
            if i == STATE_RING:
                with self._lock:
                    try:
                        self._writer.settle()
                    except OSError as exc:  # a full chunk was written out: disk full
                        self._failure = exc
                        self._raise_closed()
                    ring.restart()

        return PhysicsStateSlot(records.state, write)

    def write_applied_input(self, inp: AppliedInput) -> None:
        """Record the physics input applied before ``inp.step``."""
        msg = applied_input_message(self._types, inp)
        self._write(TOPIC_INPUTS, TYPE_APPLIED_INPUT, msg, inp.sim_time_ns)

    def write_epoch(self, epoch: Epoch) -> None:
        """Record a discontinuity after ``epoch.step`` (a reset): the state the run continues
        from. Always written (``state_every`` does not apply)."""
        self._write(TOPIC_EPOCH, TYPE_EPOCH, epoch_message(self._types, epoch), epoch.sim_time_ns)

    def write_collision_event(self, record: CollisionEvent) -> None:
        """Record a collision begin (0), end (1) or near miss (2) (fields as in the .msg)."""
        msg = collision_event_message(self._types, record)
        self._write(TOPIC_COLLISIONS, TYPE_COLLISION_EVENT, msg, record.sim_time_ns)

    def write_rosout(self, record: RosoutRecord) -> None:
        """Record a ``rcl_interfaces/msg/Log`` on ``/rosout`` (levels 10/20/30/40/50)."""
        msg = rosout_message(self._types, record)
        self._write(TOPIC_ROSOUT, "rcl_interfaces/msg/Log", msg, record.sim_time_ns)

    def _write(self, topic: str, msgtype: str, msg: Any, sim_time_ns: int) -> None:
        try:
            data = self._store.serialize_cdr(msg, msgtype)
        except (TypeError, ValueError, AttributeError, OverflowError, KeyError) as exc:
            raise RecordingWriteError(f"{topic} ({msgtype}): cannot serialise: {exc}") from None
        self._write_cdr(topic, msgtype, (data,), len(data), sim_time_ns)

    def _write_cdr(
        self, topic: str, msgtype: str, parts: tuple[Buffer, ...], size: int, sim_time_ns: int
    ) -> None:
        channel = self._channels.get(topic) or self._channel(topic, msgtype)
        if channel.msgtype != msgtype:
            raise RecordingWriteError(
                f"{topic}: already recorded as {channel.msgtype}, cannot also record {msgtype}"
            )
        self._write_on(channel, parts, size, sim_time_ns)

    def _channel(self, topic: str, msgtype: str) -> _Channel:
        """The channel of ``topic``, registered on first use."""
        with self._lock:
            if self._closed or self._failure is not None:
                self._raise_closed()
            return self._channels.get(topic) or self._register(topic, msgtype)

    def _fixed(self, topic: str, msgtype: str) -> _Channel:
        """The channel of a per-step topic (state, bridge frames), kept at hand once known."""
        channel = self._channel(topic, msgtype)
        if channel.msgtype != msgtype:
            raise RecordingWriteError(
                f"{topic}: already recorded as {channel.msgtype}, cannot also record {msgtype}"
            )
        if topic == TOPIC_STATE:
            self._state_channel = channel
        elif topic == TOPIC_BRIDGE:
            self._bridge_channel = channel
        return channel

    def _write_on(
        self, channel: _Channel, parts: tuple[Buffer, ...], size: int, sim_time_ns: int
    ) -> None:
        with self._lock:
            if self._closed or self._failure is not None:
                self._raise_closed()
            if sim_time_ns < self._last_time or sim_time_ns < 0:
                self._time_error(channel, sim_time_ns)
            seq = channel.seq
            channel.seq = seq + 1
            try:
                self._append(channel.id, sim_time_ns, seq, parts, size)
            except OSError as exc:  # a full chunk was written out: disk full
                self._failure = exc
                self._raise_closed()
            self._last_time = sim_time_ns
            self._messages += 1
            self._dirty = True

    def write_metadata(self, name: str, metadata: Mapping[str, str]) -> None:
        """Add a metadata record besides the ``harness`` one (e.g. ``harness.sensors``)."""
        if name == METADATA_NAME:
            raise RecordingWriteError(f"metadata: {name!r} is written by the recorder")
        values = {str(k): str(v) for k, v in metadata.items()}
        with self._lock:
            if self._closed or self._failure is not None:
                self._raise_closed()
            self._writer.add_metadata(name, values)
            self._dirty = True

    def _register(self, topic: str, msgtype: str) -> _Channel:
        schema_id = self._schemas.get(msgtype)
        if schema_id is None:
            schema_id = self._writer.register_schema(msgtype, "ros2msg", schema_text(msgtype))
            self._schemas[msgtype] = schema_id
        channel_id = self._writer.register_channel(
            topic, "cdr", schema_id, channel_metadata(msgtype, is_latched(topic))
        )
        channel = self._channels[topic] = _Channel(channel_id, topic, msgtype)
        return channel

    def _slot_refusal(self, channel: _Channel, step: int, sim_time_ns: int) -> None:
        """Raise what a state slot's write at ``sim_time_ns`` is refused for, if anything."""
        with self._lock:
            if self._closed or self._failure is not None:
                self._raise_closed()
        if sim_time_ns < self._last_time or sim_time_ns < 0:
            self._time_error(channel, sim_time_ns)

    def _time_error(self, channel: _Channel, sim_time_ns: int) -> NoReturn:
        raise RecordingWriteError(
            f"{channel.topic}: sim_time_ns {sim_time_ns} is before the last recorded "
            f"{self._last_time}: recorded time must not go backwards"
        )

    def _raise_closed(self) -> None:
        if self._failure is not None:
            raise RecordingWriteError(
                f"{self.path}: recording failed: {self._failure}"
            ) from self._failure
        raise RecordingWriteError(f"{self.path}: recorder is closed")

    # -- flushing and closing --------------------------------------------------------------

    def flush(self) -> None:
        """Close the open chunk now: everything recorded so far is committed to the file
        (a chunk boundary here: call it at the same point of two runs to keep their files
        identical; the flush thread keeps the open chunk on disk without closing it)."""
        info = None
        with self._lock:
            if self._closed or self._failure is not None:
                self._raise_closed()
            info = self._flush_locked(provisional=False)
        if info is not None and self._on_flush is not None:
            self._on_flush(info)

    def checkpoint(self) -> None:
        """Put everything recorded so far on disk without closing the open chunk (what the
        flush thread does every ``flush_interval_s``): the file's bytes once closed do not
        depend on when, or whether, this is called."""
        info = None
        with self._lock:
            if self._closed or self._failure is not None:
                self._raise_closed()
            info = self._flush_locked(provisional=True)
        if info is not None and self._on_flush is not None:
            self._on_flush(info)

    def _flush_locked(self, *, provisional: bool) -> FlushInfo | None:
        if not self._dirty:
            return None
        # Before the slot's ring is settled: a state slot writes without the lock, so a
        # state written meanwhile sets _dirty again and is not counted as flushed.
        self._dirty = False
        last_time, messages = self._last_time, self._messages
        start = time.perf_counter()
        try:
            if provisional:
                tail = self._writer.provisional()  # after every closed chunk is written
                if tail is not None:
                    self._stream.write_tail(tail)
            else:
                self._writer.flush()
        except OSError as exc:
            self._failure = exc
            raise RecordingWriteError(f"{self.path}: recording failed: {exc}") from exc
        seconds = time.perf_counter() - start
        self._flushes += 1
        self._flush_total += seconds
        self._flush_max = max(self._flush_max, seconds)
        size = self._stream.size
        if size > self.max_bytes:
            # Further writes fail; close() still finishes a valid file.
            self._failure = RecordingWriteError(
                f"recording is {size / 2**20:.1f} MiB, over its "
                f"{self.max_bytes / 2**20:g} MiB limit (max_bytes): recording stopped"
            )
            raise self._failure
        return FlushInfo(last_time, messages, size, seconds)

    def _flush_loop(self, interval: float) -> None:
        while not self._stop.wait(interval):
            info = None
            with self._lock:
                if self._closed or self._failure is not None:
                    return
                try:
                    info = self._flush_locked(provisional=True)
                except Exception as exc:
                    # _flush_locked keeps an OSError as the failure: close() finishes the
                    # file at its last complete flush from it
                    self._failure = self._failure or exc
                    return
            if info is not None and self._on_flush is not None:
                self._on_flush(info)

    @property
    def stats(self) -> RecorderStats:
        """Messages written, flushes and their cost, bytes on disk so far."""
        with self._lock:
            size = self._stream.size if not self._stream.closed else self.path.stat().st_size
            return RecorderStats(
                self._messages, self._flushes, size, self._flush_total, self._flush_max
            )

    def close(self) -> None:
        """Write the last chunk, the summary and the footer; close the file (idempotent)."""
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join()
        with self._lock:
            if self._closed:
                return
            self._closed = True
            if not isinstance(self._failure, OSError):
                try:
                    self._writer.finish()
                    self._stream.close()
                except OSError as exc:
                    self._failure = exc
            if isinstance(self._failure, OSError):  # disk full: keep what was flushed
                self._writer.abandon()
                raise RecordingWriteError(
                    # the committed bytes end at a record boundary: a failed write never
                    # advances them (a provisional tail after them is cut off)
                    finish_after_failure(
                        self._stream, self.path, self._failure, self._stream.tell(), self._messages
                    )
                ) from None
        if self._failure is not None:
            raise RecordingWriteError(
                f"{self.path}: recording failed: {self._failure}"
            ) from self._failure
