"""Errors of :mod:`harness.replay` (all :class:`~harness.errors.ReplayError`)."""

from __future__ import annotations

from typing import Any

from harness.errors import ReplayError

__all__ = [
    "LevelUnavailableError",
    "ModelAttachmentError",
    "PlatformMismatchError",
    "RecordedDataError",
    "SourceLeftOutWarning",
    "UnsafeRecordingError",
    "VersionMismatchError",
]


class VersionMismatchError(ReplayError):
    """The recording was made with another MuJoCo version and no tolerance was given."""


class PlatformMismatchError(VersionMismatchError):
    """The recording was made on another platform (its fingerprint differs: CPU features,
    MuJoCo build, numpy/BLAS, C library) and an exact comparison was asked for."""

    def __init__(self, message: str, fingerprints: tuple[Any, Any] = (None, None)) -> None:
        super().__init__(message)
        self.fingerprints = fingerprints
        """The two :class:`~harness.recording.fingerprint.Fingerprint`\\ s compared."""


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
