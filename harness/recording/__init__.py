"""Recording to MCAP (profile ``ros2``, every channel CDR) and reading recordings back.

Write with :class:`Recorder`, read with :class:`Recording`, build the metadata and
attachments of a run with :func:`describe_run`, rewrite a damaged file's intact parts with
:func:`harness.recording.repair.repair`, make a complete file of the flushed prefix of one
still being written with :func:`complete_prefix`. Layout: :mod:`harness.recording.layout`.
"""

from __future__ import annotations

from harness.recording.convert import to_plain
from harness.recording.describe import LoadedRobotLike, RunDescription, describe_run
from harness.recording.errors import (
    RecordingDamagedError,
    RecordingDamagedWarning,
    RecordingFormatError,
    RecordingLimitError,
    RecordingWriteError,
)
from harness.recording.layout import FORMAT_VERSION
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
from harness.recording.stateslot import PhysicsStateSlot

__all__ = [
    "FORMAT_VERSION",
    "AppliedInput",
    "BridgeFrame",
    "ClockRecord",
    "CollisionEvent",
    "Epoch",
    "FlushInfo",
    "JointStateRecord",
    "LoadedRobotLike",
    "LostRange",
    "PhysicsState",
    "PhysicsStateArrays",
    "PhysicsStateSlot",
    "RecordedMessage",
    "Recorder",
    "RecorderStats",
    "Recording",
    "RecordingDamagedError",
    "RecordingDamagedWarning",
    "RecordingFormatError",
    "RecordingLimitError",
    "RecordingWriteError",
    "RosoutRecord",
    "RunDescription",
    "TfRecord",
    "TopicInfo",
    "complete_prefix",
    "describe_run",
    "to_plain",
]
