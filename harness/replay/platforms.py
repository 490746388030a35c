"""Which platform a recording was made on, compared with this one (``harness replay``) or with
another recording's (``harness diff``, golden checks): bit-exact claims are made only on the
same platform fingerprint (:mod:`harness.recording.fingerprint`), as only on the same MuJoCo
version (:func:`harness.replay.source.check_version`).

- the same fingerprint: nothing to say;
- another one: an exact comparison is refused in one line naming the parts that differ and
  how to compare with tolerances; with tolerances, one note says so and they are used;
- a recording made before fingerprints were recorded: one note, nothing refused.
"""

from __future__ import annotations

from collections.abc import Mapping

from harness.recording import (
    Fingerprint,
    PlatformComparison,
    Recording,
    compare_fingerprints,
    platform_fingerprint,
    recorded_fingerprint,
)
from harness.replay.errors import LevelUnavailableError, PlatformMismatchError, RecordedDataError

__all__ = [
    "PHYSICS_TOLERANCES",
    "check_platform",
    "check_platforms",
    "fingerprint_of",
    "platform_note",
]

PHYSICS_TOLERANCES = ("joint_position", "joint_velocity", "link_position", "link_rotation")
"""The :class:`~harness.replay.Tolerances` fields whose 0 makes a diff exact in the last bit."""

_UNKNOWN = "(made before harness recorded one): platforms not compared"


def fingerprint_of(rec: Recording) -> Fingerprint | None:
    """``rec``'s platform fingerprint (``None``: recorded before there was one)."""
    try:
        return recorded_fingerprint(rec.metadata, str(rec.path))
    except ValueError as exc:
        raise RecordedDataError(str(exc)) from None


def check_platform(rec: Recording, *, tolerant: bool, level: str = "physics") -> str | None:
    """Replay: compare ``rec``'s platform with this one. Refuses a bit-exact replay (not
    ``tolerant``, or ``level="full"``, which compares frames bit for bit) of a recording
    from another platform; returns the note for the report (``None``: same platform)."""
    recorded, here = fingerprint_of(rec), platform_fingerprint()
    found = compare_fingerprints(recorded, here, ("in the recording", "here"))
    if found.same is None:
        return f"{found.text} {_UNKNOWN}"
    if found.same:
        return None
    if level == "full":
        raise LevelUnavailableError(
            f"{rec.path}: recorded on another platform ({found.text}): --level full compares "
            "frames bit for bit and needs the same platform; use --level physics with a "
            "tolerance"
        )
    if not tolerant:
        raise PlatformMismatchError(
            f"{rec.path}: recorded on another platform ({found.text}): bit-exact replay holds "
            "only on the same platform (CPU features, MuJoCo build and libraries change the "
            "last bits); compare with tolerances instead, e.g. --atol 1e-6 --rtol 1e-6",
            (recorded, here),
        )
    return f"recorded on another platform ({found.text}): compared within the tolerances"


def check_platforms(
    a: Recording, b: Recording, tolerances: Mapping[str, float]
) -> PlatformComparison:
    """Diff: compare the platforms of ``a`` and ``b``. Refuses an exact comparison (every
    :data:`PHYSICS_TOLERANCES` 0) of recordings from different platforms in one line."""
    pair = fingerprint_of(a), fingerprint_of(b)
    found = compare_fingerprints(*pair)
    if found.same is False and not any(tolerances.get(n, 0) for n in PHYSICS_TOLERANCES):
        raise PlatformMismatchError(
            f"{a.path} and {b.path} were recorded on different platforms ({found.text}): an "
            "exact comparison holds only on one platform; compare with tolerances, e.g. "
            "--joint-position 1e-9 --joint-velocity 1e-7 (joint_position=1e-9, "
            "joint_velocity=1e-7 in Python)",
            pair,
        )
    return found


def platform_note(found: PlatformComparison) -> str | None:
    """The diff report's note on the platforms (``None``: the same one)."""
    if found.same is None:
        return f"{found.text} {_UNKNOWN}"
    if found.same:
        return None
    return f"recorded on different platforms ({found.text}): compared within the tolerances"
