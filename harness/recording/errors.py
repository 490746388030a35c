"""Errors and warnings of :mod:`harness.recording` (all :class:`~harness.errors.RecordingError`)."""

from __future__ import annotations

from harness.errors import RecordingError

__all__ = [
    "RecordingBusyError",
    "RecordingDamagedError",
    "RecordingDamagedWarning",
    "RecordingFormatError",
    "RecordingLimitError",
    "RecordingWriteError",
]


class RecordingWriteError(RecordingError):
    """A recording could not be written (file, arguments, time going backwards, writer failure)."""


class RecordingBusyError(RecordingWriteError):
    """Another writer (another session, in this process or another) holds the recording path:
    refused before a byte of the file changed. ``pid`` is the holder's process id (None when it
    could not be learnt)."""

    def __init__(self, message: str, path: str, pid: int | None) -> None:
        super().__init__(message)
        self.path = path
        self.pid = pid


class RecordingFormatError(RecordingError):
    """A file is not a recording this harness can read (empty, not MCAP, wrong profile,
    missing ``harness`` metadata, newer format version, unusable damage)."""


class RecordingLimitError(RecordingFormatError):
    """A file holds more records than a reader walks (per chunk or per file, limits of
    :mod:`harness.recording.inflate`): refused as soon as a walk passes the limit."""


class RecordingDamagedError(RecordingFormatError):
    """Damage found while reading a chunk whose checks were deferred (``defer_chunk_checks``):
    the message names the chunk's byte offset."""


class RecordingDamagedWarning(UserWarning):
    """A recording is truncated or corrupted: it was opened up to the last good chunk."""
