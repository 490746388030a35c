"""Replay: determinism verification with a first-divergence report, kinematic <-> dynamic
re-simulation, playback of recorded bridge traffic, and the diff engine of golden tests.

- :func:`verify` -> :class:`VerifyReport` (``harness replay FILE``)
- :func:`resimulate` -> :class:`ResimReport` (``harness replay FILE --actuation kinematic|servo``)
- :func:`diff` -> :class:`DiffReport` with :class:`Tolerances` (``harness diff A B``)
- :class:`Player` (``harness play FILE``)
"""

from __future__ import annotations

from harness.replay.diff import DiffEntry, DiffReport, Tolerances, diff
from harness.replay.errors import (
    LevelUnavailableError,
    ModelAttachmentError,
    PlatformMismatchError,
    RecordedDataError,
    VersionMismatchError,
)
from harness.replay.play import Player
from harness.replay.resim import resimulate
from harness.replay.resim_report import Finding, ResimReport, Thresholds
from harness.replay.source import open_recording, rebuild_run, resolve_model
from harness.replay.verify import (
    BodyDelta,
    Divergence,
    QuantityDelta,
    VerifyReport,
    verify,
)

__all__ = [
    "BodyDelta",
    "DiffEntry",
    "DiffReport",
    "Divergence",
    "Finding",
    "LevelUnavailableError",
    "ModelAttachmentError",
    "PlatformMismatchError",
    "Player",
    "QuantityDelta",
    "RecordedDataError",
    "ResimReport",
    "Thresholds",
    "Tolerances",
    "VerifyReport",
    "VersionMismatchError",
    "diff",
    "open_recording",
    "rebuild_run",
    "resimulate",
    "resolve_model",
    "verify",
]
