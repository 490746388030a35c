"""Recording to MCAP (profile ``ros2``, every channel CDR) and reading recordings back.

Write with :class:`Recorder`, read with :class:`Recording`, build the metadata and
attachments of a run with :func:`describe_run`, rewrite a damaged file's intact parts with
:func:`harness.recording.repair.repair`, make a complete file of the flushed prefix of one
still being written with :func:`complete_prefix`. Layout: :mod:`harness.recording.layout`.
"""

from __future__ import annotations

from harness.recording.convert import from_rosbridge, to_plain
from harness.recording.copying import copy_recording
from harness.recording.describe import LoadedRobotLike, RunDescription, describe_run
from harness.recording.errors import (
    RecordingBusyError,
    RecordingDamagedError,
    RecordingDamagedWarning,
    RecordingFormatError,
    RecordingLimitError,
    RecordingWriteError,
)
from harness.recording.fingerprint import (
    Fingerprint,
    PlatformComparison,
    compare_fingerprints,
    platform_fingerprint,
    recorded_fingerprint,
)
from harness.recording.layout import (
    ATTACHMENT_MODEL,
    ATTACHMENT_MODEL_BINARY,
    ATTACHMENT_SOURCE_PREFIX,
    FORMAT_VERSION,
    TOPIC_BRIDGE,
    TOPIC_CLOCK,
    TOPIC_EPOCH,
    TOPIC_STATE,
    is_latched,
    typestore,
)
from harness.recording.meshes import mesh_attachment_name
from harness.recording.periodic import ClockRecord, JointStateRecord, TfRecord
from harness.recording.recorder import FlushInfo, Recorder, RecorderStats
from harness.recording.recording import LostRange, Recording, TopicInfo
from harness.recording.records import (
    AppliedInput,
    BridgeFrame,
    CollisionEvent,
    Epoch,
    PhysicsState,
    PhysicsStateArrays,
    RecordedMessage,
    RosoutRecord,
)
from harness.recording.snapshot import complete_prefix
from harness.recording.sourcelinks import (
    ATTACHMENT_SOURCE_LINKS,
    ATTACHMENT_SOURCE_REFS,
    MAX_LINKED_BYTES,
    PROJECT_REFERENCE_REFUSAL,
    parse_source_links,
)
from harness.recording.stateslot import PhysicsStateSlot, forwarding_slot
from harness.recording.tail import TailFile

__all__ = [
    "ATTACHMENT_MODEL",
    "ATTACHMENT_MODEL_BINARY",
    "ATTACHMENT_SOURCE_LINKS",
    "ATTACHMENT_SOURCE_PREFIX",
    "ATTACHMENT_SOURCE_REFS",
    "FORMAT_VERSION",
    "MAX_LINKED_BYTES",
    "PROJECT_REFERENCE_REFUSAL",
    "TOPIC_BRIDGE",
    "TOPIC_CLOCK",
    "TOPIC_EPOCH",
    "TOPIC_STATE",
    "AppliedInput",
    "BridgeFrame",
    "ClockRecord",
    "CollisionEvent",
    "Epoch",
    "Fingerprint",
    "FlushInfo",
    "JointStateRecord",
    "LoadedRobotLike",
    "LostRange",
    "PhysicsState",
    "PhysicsStateArrays",
    "PhysicsStateSlot",
    "PlatformComparison",
    "RecordedMessage",
    "Recorder",
    "RecorderStats",
    "Recording",
    "RecordingBusyError",
    "RecordingDamagedError",
    "RecordingDamagedWarning",
    "RecordingFormatError",
    "RecordingLimitError",
    "RecordingWriteError",
    "RosoutRecord",
    "RunDescription",
    "TailFile",
    "TfRecord",
    "TopicInfo",
    "compare_fingerprints",
    "complete_prefix",
    "copy_recording",
    "describe_run",
    "forwarding_slot",
    "from_rosbridge",
    "is_latched",
    "mesh_attachment_name",
    "parse_source_links",
    "platform_fingerprint",
    "recorded_fingerprint",
    "to_plain",
    "typestore",
]
