"""Errors of :mod:`harness.replay` (all :class:`~harness.errors.ReplayError`)."""

from __future__ import annotations

from harness.errors import ReplayError

__all__ = [
    "LevelUnavailableError",
    "ModelAttachmentError",
    "RecordedDataError",
    "SourceLeftOutWarning",
    "UnsafeRecordingError",
    "VersionMismatchError",
]


class VersionMismatchError(ReplayError):
    """The recording was made with another MuJoCo version and no tolerance was given."""


class ModelAttachmentError(ReplayError):
    """No attachment of the recording yields the model it was recorded with."""


class UnsafeRecordingError(ModelAttachmentError):
    """The recording asks for what a rebuild from a recording never does: expanding xacro,
    reading a file outside its attachments (:mod:`harness.replay.gate`)."""


class RecordedDataError(ReplayError):
    """The recorded states or inputs are missing, damaged or inconsistent with the model."""


class LevelUnavailableError(ReplayError):
    """A replay level or mode cannot run with what the recording or this harness provides."""


class SourceLeftOutWarning(UserWarning):
    """A source attachment was left out of a rebuild (a xacro source: never expanded)."""
