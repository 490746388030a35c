"""``Recording``: open a recording, check it, iterate and decode its messages.

Opening walks the whole file once (``scan``: every chunk decompressed and CRC-checked), so a
truncated or corrupted file opens up to its last good chunk with a
:class:`~harness.recording.errors.RecordingDamagedWarning` naming the byte offset; iteration
then reads only the chunks that can hold what is asked for. Messages are decoded with a
typestore built from the file's own schemas (as rosbags and Foxglove do).
"""

from __future__ import annotations

import mmap
import os
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from harness.recording.errors import RecordingDamagedWarning, RecordingFormatError
from harness.recording.layout import (
    FORMAT_VERSION,
    METADATA_NAME,
    PROFILE,
    TOPIC_BRIDGE,
    TOPIC_COLLISIONS,
    TOPIC_INPUTS,
    TOPIC_STATE,
)
from harness.recording.records import (
    AppliedInput,
    BridgeFrame,
    CollisionEvent,
    PhysicsState,
    RecordedMessage,
)
from harness.recording.scan import Problem, Scan, chunk_messages, scan

__all__ = ["Recording", "TopicInfo"]


class TopicInfo(NamedTuple):
    """A recorded topic: its type and how many messages it holds."""

    topic: str
    msgtype: str
    messages: int


class Recording:
    """A recording opened for reading (a context manager; ``close()`` releases the file).

    Raises :class:`~harness.recording.errors.RecordingFormatError` for an empty or non-MCAP
    file, a profile other than ``ros2``, a missing ``harness`` metadata record or a format
    version newer than this harness reads. Damage warns (or raises with ``strict=True``).
    """

    def __init__(self, path: str | os.PathLike[str], *, strict: bool = False) -> None:
        self.path = Path(path)
        try:
            with open(self.path, "rb") as f:
                size = os.fstat(f.fileno()).st_size
                self._mmap = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) if size else None
        except OSError as exc:
            raise RecordingFormatError(f"{self.path}: cannot open: {exc.strerror}") from None
        self._buf = memoryview(self._mmap) if self._mmap is not None else memoryview(b"")
        try:
            self._scan = scan(self._buf, str(self.path))
            self._check()
        except BaseException:
            self.close()
            raise
        self._store: Typestore | None = None
        if self._scan.problems:
            text = "; ".join(str(p) for p in self._scan.problems)
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
                ),
                stacklevel=2,
            )

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
    def problems(self) -> list[Problem]:
        """Damage found when opening (empty for a sound file)."""
        return list(self._scan.problems)

    @property
    def complete(self) -> bool:
        """True when the file was closed properly and nothing is damaged."""
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
    def start_time_ns(self) -> int:
        """Sim time of the first message (``-1`` when there are none)."""
        return self._scan.start_time

    @property
    def end_time_ns(self) -> int:
        """Sim time of the last message (``-1`` when there are none)."""
        return self._scan.end_time

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
                return bytes(self._buf[info.data_offset : info.data_offset + info.data_length])
        raise RecordingFormatError(
            f"{self.path}: no attachment {name!r} (has: {', '.join(self.attachment_names)})"
        )

    @property
    def attachments(self) -> dict[str, bytes]:
        """Every attachment by name."""
        return {name: self.attachment(name) for name in self.attachment_names}

    # -- iterating -------------------------------------------------------------------------

    def _typestore(self) -> Typestore:
        if self._store is None:
            store = get_typestore(Stores.EMPTY)
            for schema in self._scan.schemas.values():
                if schema.encoding != "ros2msg":
                    raise RecordingFormatError(
                        f"{self.path}: schema {schema.name!r} is {schema.encoding!r}, not ros2msg"
                    )
                store.register(get_types_from_msg(schema.data.decode("utf-8"), schema.name))
            self._store = store
        return self._store

    def decode(self, message: RecordedMessage) -> Any:
        """The rosbags object of ``message`` (typed by the file's own schema)."""
        return self._typestore().deserialize_cdr(message.data, message.msgtype)

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
        lo = -1 if start_step is None else start_step * self.timestep_ns
        hi = None if stop_step is None else stop_step * self.timestep_ns
        store = self._typestore() if decode else None
        for chunk in s.chunks:
            if chunk.end_time < lo or (hi is not None and chunk.start_time >= hi):
                continue
            if chunk.channels.isdisjoint(channels):
                continue
            for cid, seq, log_time, data in chunk_messages(self._buf, chunk):
                if cid not in channels or log_time < lo or (hi is not None and log_time >= hi):
                    continue
                topic, msgtype = channels[cid]
                raw = bytes(data)
                msg = store.deserialize_cdr(raw, msgtype) if store is not None else None
                yield RecordedMessage(topic, msgtype, log_time, seq, raw, msg)

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
            )
