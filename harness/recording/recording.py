"""``Recording``: open a recording, check it, iterate and decode its messages.

Opening reads the whole file once, every chunk decompressed and CRC-checked: a complete file
through its summary and message indexes (``index_scan``), anything else by walking every
record (``scan``), so a truncated or corrupted file opens up to its last good chunk with a
:class:`~harness.recording.errors.RecordingDamagedWarning` naming the byte offset (a reader
that reads everything once anyway can defer the chunk checks to the reads:
``defer_chunk_checks``). Iteration then decompresses only the chunks that can hold what is
asked for (the most recent are kept, up to 16 MiB), and in indexed files reads only the
records asked for. Messages are decoded with a typestore
built from the file's own schemas (as rosbags and Foxglove do);
:meth:`Recording.physics_state_arrays` and :meth:`Recording.physics_state_blocks` decode
physics states in bulk, straight into numpy arrays.
"""

from __future__ import annotations

import functools
import mmap
import os
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from harness.recording.bulk import decode_physics_states, empty_physics_states
from harness.recording.chunks import chunk_messages, gather, message_offsets, read_chunk_data
from harness.recording.errors import (
    RecordingDamagedError,
    RecordingDamagedWarning,
    RecordingFormatError,
)
from harness.recording.layout import (
    FORMAT_VERSION,
    METADATA_NAME,
    PROFILE,
    TOPIC_BRIDGE,
    TOPIC_COLLISIONS,
    TOPIC_EPOCH,
    TOPIC_INPUTS,
    TOPIC_STATE,
    TYPE_PHYSICS_STATE,
)
from harness.recording.records import (
    AppliedInput,
    BridgeFrame,
    CollisionEvent,
    Epoch,
    PhysicsState,
    PhysicsStateArrays,
    RecordedMessage,
)
from harness.recording.scan import Expected, index_scan, scan
from harness.recording.scanned import I64, ChunkInfo, Problem, Scan, problems_text

__all__ = ["LostRange", "Recording", "TopicInfo"]

_KEPT_BYTES = 16 * 2**20
"""Decompressed chunks kept for the next reads, the most recent up to this many bytes (so a
reader of states and inputs side by side, block by block, decompresses each chunk once)."""


@functools.lru_cache(maxsize=16)
def _typestore_for(schemas: tuple[tuple[str, bytes], ...]) -> Typestore:
    """A typestore of these ``ros2msg`` schemas (shared: recordings of one harness version
    carry the same ones, and building a store generates code)."""
    store = get_typestore(Stores.EMPTY)
    for name, text in schemas:
        store.register(get_types_from_msg(text.decode("utf-8"), name))
    return store


def _brief(exc: BaseException) -> str:
    """``exc``'s message on one line, at most 200 characters."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 200 else text[:197] + "..."


class LostRange(NamedTuple):
    """A damaged stretch ``[offset, end)`` of the file that was passed over: the messages of
    steps ``first_step..last_step`` (``None``: to the end) may be missing."""

    offset: int
    end: int
    first_step: int
    last_step: int | None
    what: str


class TopicInfo(NamedTuple):
    """A recorded topic: its type and how many messages it holds."""

    topic: str
    msgtype: str
    messages: int


class Recording:
    """A recording opened for reading (a context manager; ``close()`` releases the file).

    Raises :class:`~harness.recording.errors.RecordingFormatError` for an empty or non-MCAP
    file, a profile other than ``ros2``, a missing ``harness`` metadata record (both checked
    before any chunk is decompressed) or a format version newer than this harness reads, and
    :class:`~harness.recording.errors.RecordingLimitError` for a file over a record limit
    (:mod:`harness.recording.inflate`). Damage warns (or raises with ``strict=True``).

    ``defer_chunk_checks``: for a complete file, check each chunk's CRC and message index
    when the chunk is first read instead of when opening (opening then decompresses
    nothing; its data-section CRC already covers the compressed bytes). For a reader that
    reads the whole file once anyway, that saves a decompression of everything; the price is
    that damage inside a chunk raises :class:`~harness.recording.errors.RecordingDamagedError`
    from the read that finds it (:meth:`check_chunks` checks what no read touched), and
    :attr:`problems` cannot list it beforehand.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        strict: bool = False,
        defer_chunk_checks: bool = False,
    ) -> None:
        self.path = Path(path)
        self._recent: dict[int, bytes] = {}
        try:
            with open(self.path, "rb") as f:
                size = os.fstat(f.fileno()).st_size
                self._mmap = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) if size else None
        except OSError as exc:
            raise RecordingFormatError(f"{self.path}: cannot open: {exc.strerror}") from None
        self._buf = memoryview(self._mmap) if self._mmap is not None else memoryview(b"")
        try:
            # Not a harness recording: refused before a chunk is decompressed.
            expect = Expected(PROFILE, METADATA_NAME)
            found = index_scan(
                self._buf, str(self.path), check_chunks=not defer_chunk_checks, expect=expect
            )
            self._scan = (
                found if found is not None else scan(self._buf, str(self.path), expect=expect)
            )
            self._check()
        except BaseException:
            self.close()
            raise
        self._store: Typestore | None = None
        if self._scan.problems:
            text = self.problem_text()
            if strict:
                self.close()
                raise RecordingFormatError(f"{self.path}: damaged: {text}")
            where = self._scan.truncated_at
            warnings.warn(
                RecordingDamagedWarning(
                    f"{self.path}: {text}"
                    + (
                        f"; opened up to byte {where} ({len(self._scan.chunks)} good chunks, "
                        f"{self._scan.message_count} messages)"
                        if where is not None
                        else ""
                    )
                    + "".join(
                        f"; steps {r.first_step}.."
                        f"{'the end' if r.last_step is None else r.last_step} may be missing "
                        f"(bytes {r.offset}..{r.end} passed over)"
                        for r in self.lost
                    )
                ),
                stacklevel=2,
            )

    def _chunk_data(self, chunk: ChunkInfo) -> bytes:
        """The decompressed records of ``chunk`` (one of the last few read, or read now)."""
        data = self._recent.get(chunk.offset)
        if data is None:
            data = read_chunk_data(self._buf, chunk, self._scan)
            kept = len(data)
            for offset, older in reversed(list(self._recent.items())):
                kept += len(older)
                if kept > _KEPT_BYTES:
                    del self._recent[offset]
            self._recent[chunk.offset] = data
        return data

    def check_chunks(self) -> None:
        """Check every chunk whose checks were deferred and that was not read since
        (``defer_chunk_checks``); raises
        :class:`~harness.recording.errors.RecordingDamagedError` at the first damaged one."""
        by_offset = {c.offset: c for c in self._scan.chunks}
        for offset in sorted(self._scan.unchecked):
            read_chunk_data(self._buf, by_offset[offset], self._scan)

    def _record_offsets(self, chunk: ChunkInfo, data: bytes, channels: set[int]) -> I64 | None:
        """Where the records of ``channels`` start in ``chunk`` (ascending); ``None`` when the
        chunk holds none of them."""
        index = self._scan.message_index.get(chunk.offset)
        found = (
            {c: index[c] for c in channels if c in index}
            if index is not None
            else message_offsets(data, channels)
        )
        if not found:
            return None
        if len(found) == 1:
            return next(iter(found.values()))
        return np.sort(np.concatenate(list(found.values())))

    def _check(self) -> None:
        s = self._scan
        if s.header.profile != PROFILE:
            raise RecordingFormatError(
                f"{self.path}: MCAP profile is {s.header.profile!r}, not {PROFILE!r}: "
                "not a harness recording"
            )
        records = [m for m in s.metadata if m.name == METADATA_NAME]
        if not records:
            raise RecordingFormatError(
                f"{self.path}: no {METADATA_NAME!r} metadata record: not a harness recording"
            )
        self.metadata: dict[str, str] = dict(records[0].metadata)
        raw_version = self.metadata.get("format_version", "")
        if not raw_version.isdigit():
            raise RecordingFormatError(
                f"{self.path}: metadata 'format_version' is {raw_version!r}, not an integer"
            )
        self.format_version = int(raw_version)
        if self.format_version > FORMAT_VERSION:
            raise RecordingFormatError(
                f"{self.path}: recording format version {self.format_version} is newer than "
                f"this harness reads ({FORMAT_VERSION}); upgrade harness"
            )
        raw_dt = self.metadata.get("timestep_ns", "")
        if not raw_dt.isdigit() or int(raw_dt) == 0:
            raise RecordingFormatError(
                f"{self.path}: metadata 'timestep_ns' is {raw_dt!r}, not a positive integer"
            )
        self.timestep_ns = int(raw_dt)

    # -- lifecycle -------------------------------------------------------------------------

    def __enter__(self) -> Recording:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the file."""
        buf = getattr(self, "_buf", None)
        mm = getattr(self, "_mmap", None)
        self._mmap = None
        self._recent = {}
        try:
            if buf is not None:
                buf.release()
            if mm is not None:
                mm.close()
        except BufferError:
            pass  # a caller still holds a view: the map is released when that goes

    # -- what the file holds ---------------------------------------------------------------

    @property
    def scan(self) -> Scan:
        """The raw findings of the opening pass (chunks, counts, problems, CRCs checked)."""
        return self._scan

    @property
    def lost(self) -> list[LostRange]:
        """What each damaged stretch passed over cost, as a range of steps: the messages
        logged after the last message before it and before the first message after it, the
        bounds included (messages of one step may lie on both sides); ``last_step`` is
        ``None`` when nothing readable follows. Empty for a sound file."""
        out: list[LostRange] = []
        chunks = self._scan.chunks
        dt = self.timestep_ns
        for skipped in self._scan.skipped:
            before = [c.end_time for c in chunks if c.offset < skipped.offset and c.messages]
            after = [c.start_time for c in chunks if c.offset >= skipped.end and c.messages]
            first = max(before) // dt if before else 0
            last = min(after) // dt if after else None
            out.append(LostRange(skipped.offset, skipped.end, first, last, skipped.what))
        return out

    @property
    def problems(self) -> list[Problem]:
        """Damage found when opening (empty for a sound file)."""
        return list(self._scan.problems)

    def problem_text(self, limit: int = 5) -> str:
        """The damage found when opening, on one line: the first ``limit`` problems, then
        how many more there are ("" for a sound file)."""
        return problems_text(self._scan.problems, limit)

    @property
    def complete(self) -> bool:
        """True when the file was closed properly and nothing is damaged (with
        ``defer_chunk_checks``: nothing found so far)."""
        return not self._scan.problems and self._scan.has_summary

    @property
    def profile(self) -> str:
        return str(self._scan.header.profile)

    @property
    def library(self) -> str:
        return str(self._scan.header.library)

    @property
    def topics(self) -> dict[str, TopicInfo]:
        """Every channel's topic, type and message count (in channel order)."""
        s = self._scan
        out: dict[str, TopicInfo] = {}
        for cid, channel in sorted(s.channels.items()):
            schema = s.schemas.get(channel.schema_id)
            msgtype = schema.name if schema is not None else ""
            out[channel.topic] = TopicInfo(channel.topic, msgtype, s.counts.get(cid, 0))
        return out

    @property
    def message_count(self) -> int:
        return self._scan.message_count

    @property
    def end_time_ns(self) -> int:
        """Sim time of the last message (``-1`` when there are none)."""
        return self._scan.end_time

    def time_range(self, topic: str) -> tuple[int, int]:
        """Sim time of the first and of the last message on ``topic`` (``(-1, -1)``: none)."""
        ranges = [
            r
            for cid, r in self._scan.time_ranges.items()
            if self._scan.channels[cid].topic == topic
        ]
        if not ranges:
            return -1, -1
        return min(r[0] for r in ranges), max(r[1] for r in ranges)

    @property
    def first_step(self) -> int:
        return max(self._scan.start_time, 0) // self.timestep_ns

    @property
    def last_step(self) -> int:
        return max(self._scan.end_time, 0) // self.timestep_ns

    @property
    def all_metadata(self) -> dict[str, dict[str, str]]:
        """Every metadata record by name (the ``harness`` one is :attr:`metadata`)."""
        return {m.name: dict(m.metadata) for m in self._scan.metadata}

    @property
    def attachment_names(self) -> list[str]:
        return [a.name for a in self._scan.attachments]

    def attachment(self, name: str) -> bytes:
        """The bytes of attachment ``name``."""
        for info in self._scan.attachments:
            if info.name == name:
                if info.damaged:
                    raise RecordingDamagedError(
                        f"{self.path}: {info.damaged} (attachment record at byte {info.offset})"
                    )
                return bytes(self._buf[info.data_offset : info.data_offset + info.data_length])
        raise RecordingFormatError(
            f"{self.path}: no attachment {name!r} (has: {', '.join(self.attachment_names)})"
        )

    @property
    def attachments(self) -> dict[str, bytes]:
        """Every intact attachment by name (damaged ones are left out: see :attr:`problems`)."""
        return {a.name: self.attachment(a.name) for a in self._scan.attachments if not a.damaged}

    # -- iterating -------------------------------------------------------------------------

    def _typestore(self) -> Typestore:
        if self._store is None:
            for schema in self._scan.schemas.values():
                if schema.encoding != "ros2msg":
                    raise RecordingFormatError(
                        f"{self.path}: schema {schema.name!r} is {schema.encoding!r}, not ros2msg"
                    )
            try:
                self._store = _typestore_for(
                    tuple(sorted((str(x.name), bytes(x.data)) for x in self._scan.schemas.values()))
                )
            except Exception as exc:  # the file's schemas are data: any failure is the file's
                raise RecordingFormatError(
                    f"{self.path}: the file's schemas do not define message types: {_brief(exc)}"
                ) from None
        return self._store

    def _deserialize(self, store: Typestore, raw: bytes, msgtype: str, log_time: int) -> Any:
        try:
            return store.deserialize_cdr(raw, msgtype)
        except Exception as exc:  # a message of the file, typed by the file's own schemas
            raise RecordingFormatError(
                f"{self.path}: message of log time {log_time} does not decode as "
                f"{msgtype!r}: {_brief(exc)}"
            ) from None

    def decode(self, message: RecordedMessage) -> Any:
        """The rosbags object of ``message`` (typed by the file's own schema)."""
        store = self._typestore()
        return self._deserialize(store, message.data, message.msgtype, message.sim_time_ns)

    def messages(
        self,
        topics: str | Iterable[str] | None = None,
        *,
        start_step: int | None = None,
        stop_step: int | None = None,
        decode: bool = False,
    ) -> Iterator[RecordedMessage]:
        """Messages in recorded (time) order, of ``topics`` (all when ``None``), whose sim time
        lies in ``[start_step, stop_step)`` steps; ``decode`` fills ``RecordedMessage.msg``."""
        wanted = {topics} if isinstance(topics, str) else None if topics is None else set(topics)
        s = self._scan
        channels = {
            cid: (c.topic, s.schemas[c.schema_id].name if c.schema_id in s.schemas else "")
            for cid, c in s.channels.items()
            if wanted is None or c.topic in wanted
        }
        if not channels:
            return
        wanted_ids = set(channels)
        lo = -1 if start_step is None else start_step * self.timestep_ns
        hi = None if stop_step is None else stop_step * self.timestep_ns
        store = self._typestore() if decode else None
        for chunk in s.chunks:
            if chunk.end_time < lo or (hi is not None and chunk.start_time >= hi):
                continue
            if chunk.channels.isdisjoint(channels):
                continue
            chunk_data = self._chunk_data(chunk)
            offsets = self._record_offsets(chunk, chunk_data, wanted_ids)
            if offsets is None:
                continue
            for cid, seq, log_time, data in chunk_messages(chunk_data, offsets):
                if cid not in channels or log_time < lo or (hi is not None and log_time >= hi):
                    continue
                topic, msgtype = channels[cid]
                raw = bytes(data)
                msg = (
                    self._deserialize(store, raw, msgtype, log_time) if store is not None else None
                )
                yield RecordedMessage(topic, msgtype, log_time, seq, raw, msg)

    def physics_state_arrays(
        self, start_step: int | None = None, stop_step: int | None = None
    ) -> PhysicsStateArrays:
        """The recorded physics states in ``[start_step, stop_step)`` as arrays (the same
        values as :meth:`physics_states`, bit for bit), decoded in bulk from the chunks.

        Raises :class:`~harness.recording.errors.RecordingFormatError` when the states change
        size or state spec within the range (they cannot form one array)."""
        arrays = decode_physics_states(list(self._state_records(start_step, stop_step)))
        if arrays is not None:
            return arrays
        return self._physics_state_arrays_slowly(start_step, stop_step)

    def physics_state_blocks(
        self, start_step: int | None = None, stop_step: int | None = None, *, rows: int = 4096
    ) -> Iterator[PhysicsStateArrays]:
        """:meth:`physics_state_arrays` in consecutive blocks of whole chunks, about ``rows``
        states each, for reading a long recording in little memory. Blocks may differ in
        layout; within one block it is uniform (else the block raises
        :class:`~harness.recording.errors.RecordingFormatError`)."""
        pieces: list[tuple[bytes, I64]] = []
        count = 0
        for piece in self._state_records(start_step, stop_step):
            pieces.append(piece)
            count += piece[1].size
            if count >= rows:
                yield self._block(pieces)
                pieces, count = [], 0
        if pieces:
            yield self._block(pieces)

    def _block(self, pieces: list[tuple[bytes, I64]]) -> PhysicsStateArrays:
        arrays = decode_physics_states(pieces)
        if arrays is not None:
            return arrays
        (head, head_at), (tail, tail_at) = pieces[0], pieces[-1]
        first = int(gather(np.frombuffer(head, dtype=np.uint8), head_at[:1] + 15, "<u8")[0])
        last = int(gather(np.frombuffer(tail, dtype=np.uint8), tail_at[-1:] + 15, "<u8")[0])
        return self._physics_state_arrays_slowly(
            first // self.timestep_ns, last // self.timestep_ns + 1
        )

    def _state_records(
        self, start_step: int | None, stop_step: int | None
    ) -> Iterator[tuple[bytes, I64]]:
        """Each chunk holding physics states in ``[start_step, stop_step)``: its decompressed
        data and where their message records start (ascending)."""
        s = self._scan
        channels = {
            cid
            for cid, c in s.channels.items()
            if c.topic == TOPIC_STATE
            and c.schema_id in s.schemas
            and s.schemas[c.schema_id].name == TYPE_PHYSICS_STATE
        }
        if not channels:
            return
        lo = -1 if start_step is None else start_step * self.timestep_ns
        hi = None if stop_step is None else stop_step * self.timestep_ns
        for chunk in s.chunks:
            if chunk.end_time < lo or (hi is not None and chunk.start_time >= hi):
                continue
            if chunk.channels.isdisjoint(channels):
                continue
            data = self._chunk_data(chunk)
            offsets = self._record_offsets(chunk, data, channels)
            if offsets is None:
                continue
            if chunk.start_time < lo or (hi is not None and chunk.end_time >= hi):
                times = gather(np.frombuffer(data, dtype=np.uint8), offsets + 15, "<u8")
                inside = times.astype(np.int64) >= lo
                if hi is not None:
                    inside &= times.astype(np.int64) < hi
                offsets = offsets[inside]
            if offsets.size:
                yield data, offsets

    def _physics_state_arrays_slowly(
        self, start_step: int | None, stop_step: int | None
    ) -> PhysicsStateArrays:
        states = list(self.physics_states(start_step, stop_step))
        if not states:
            return empty_physics_states()
        first = states[0]
        shape = (first.state.size, first.qpos.size, first.qvel.size, first.state_spec)
        for s in states:
            if (s.state.size, s.qpos.size, s.qvel.size, s.state_spec) != shape:
                raise RecordingFormatError(
                    f"{self.path}: physics state at step {s.step} has {s.state.size} state, "
                    f"{s.qpos.size} qpos, {s.qvel.size} qvel values and state_spec "
                    f"{s.state_spec}; the first (step {first.step}) has {shape[0]}, "
                    f"{shape[1]}, {shape[2]} and {shape[3]}: the states change layout"
                )
        return PhysicsStateArrays(
            np.array([s.step for s in states], dtype=np.int64),
            np.array([s.sim_time_ns for s in states], dtype=np.int64),
            first.state_spec,
            np.stack([np.asarray(s.state, dtype=np.float64) for s in states]),
            np.stack([np.asarray(s.qpos, dtype=np.float64) for s in states]),
            np.stack([np.asarray(s.qvel, dtype=np.float64) for s in states]),
        )

    def _decoded(self, topic: str, start_step: int | None, stop_step: int | None) -> Iterator[Any]:
        for m in self.messages(topic, start_step=start_step, stop_step=stop_step, decode=True):
            yield m.msg

    def bridge_frames(
        self, start_step: int | None = None, stop_step: int | None = None
    ) -> Iterator[BridgeFrame]:
        """Every rosbridge frame in and out, in recorded order."""
        for m in self._decoded(TOPIC_BRIDGE, start_step, stop_step):
            yield BridgeFrame(
                int(m.step),
                int(m.sim_time_ns),
                int(m.direction),
                int(m.connection),
                int(m.seq),
                m.op,
                m.topic,
                bool(m.binary),
                m.text,
                bytes(m.data),
            )

    def applied_inputs(
        self, start_step: int | None = None, stop_step: int | None = None
    ) -> Iterator[AppliedInput]:
        """The physics inputs in step order (each holds until the next)."""
        for m in self._decoded(TOPIC_INPUTS, start_step, stop_step):
            yield AppliedInput(
                int(m.step),
                int(m.sim_time_ns),
                m.ctrl,
                tuple(m.kinematic_joints),
                m.qpos_index,
                m.qpos_value,
                m.qvel_index,
                m.qvel_value,
                m.mocap_pos,
                m.mocap_quat,
                m.qfrc_applied,
                m.xfrc_applied,
            )

    def physics_states(
        self, start_step: int | None = None, stop_step: int | None = None
    ) -> Iterator[PhysicsState]:
        """The recorded physics states in step order."""
        for m in self._decoded(TOPIC_STATE, start_step, stop_step):
            yield PhysicsState(
                int(m.step), int(m.sim_time_ns), int(m.state_spec), m.state, m.qpos, m.qvel
            )

    def epochs(self, start_step: int | None = None, stop_step: int | None = None) -> list[Epoch]:
        """The discontinuities (resets) in step order: after each one's ``step`` the run
        continues from its ``state`` (empty for a run without resets)."""
        return [
            Epoch(
                int(m.step),
                int(m.sim_time_ns),
                int(m.epoch),
                m.reason,
                int(m.state_spec),
                m.state,
                m.qpos,
                m.qvel,
            )
            for m in self._decoded(TOPIC_EPOCH, start_step, stop_step)
        ]

    def collision_events(
        self, start_step: int | None = None, stop_step: int | None = None
    ) -> Iterator[CollisionEvent]:
        """Collision begin/end/near-miss events in step order."""
        for m in self._decoded(TOPIC_COLLISIONS, start_step, stop_step):
            p, n = m.position, m.normal
            yield CollisionEvent(
                int(m.step),
                int(m.sim_time_ns),
                int(m.kind),
                m.robot,
                m.body1,
                m.body2,
                m.geom1,
                m.geom2,
                float(m.penetration),
                float(m.normal_force),
                (float(p.x), float(p.y), float(p.z)),
                (float(n.x), float(n.y), float(n.z)),
                int(m.duration_ns),
                float(m.distance),
                # Absent from recordings made before these fields existed.
                int(getattr(m, "begin_step", 0)),
                int(getattr(m, "end_step", 0)),
            )
