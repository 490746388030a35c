"""The child recording of a resumed run: what its metadata says about where it comes from.

A resumed run records a new file. It holds the run re-derived from the parent's inputs up to
the resume step (so it keeps the parent's step numbers and replays on its own with
``harness replay CHILD``: nothing in it refers to the parent's bytes), then everything after
the step: the fork edits (recorded as that step's input), the live clients' frames, the ghost
peers' outgoing frames. Its ``harness`` metadata is the parent's run description (robot,
options, transport) plus:

- ``resumed_from``: the parent recording's file name;
- ``resumed_from_sha256``: the SHA-256 of the parent's bytes;
- ``resumed_at_step``: the step the run was resumed at;
- ``resumed_edits``: the fork edits as JSON (``[]`` without any).

``harness diff PARENT CHILD`` compares the two from step 0: the first divergence it reports
lies after the fork.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path

__all__ = [
    "META_EDITS",
    "META_PARENT",
    "META_PARENT_SHA256",
    "META_STEP",
    "RECORDER_KEYS",
    "child_metadata",
    "parent_of",
]

META_PARENT = "resumed_from"
META_PARENT_SHA256 = "resumed_from_sha256"
META_STEP = "resumed_at_step"
META_EDITS = "resumed_edits"
RECORDER_KEYS = (
    "format_version",
    "harness_version",
    "mujoco_version",
    "numpy_version",
    "python_version",
    "platform",
    "state_every",
    "compression",
    "fingerprint",
)
"""Keys the recorder writes itself (:class:`~harness.recording.Recorder`): not copied from
the parent."""


def child_metadata(
    parent: Mapping[str, str],
    parent_path: Path,
    parent_sha256: str,
    step: int,
    edits: Sequence[Mapping[str, object]] = (),
) -> dict[str, str]:
    """The child's ``harness`` metadata: the parent's run description (without what the
    recorder writes itself) and where the child comes from."""
    out = {k: v for k, v in parent.items() if k not in RECORDER_KEYS}
    out.update(
        {
            META_PARENT: parent_path.name,
            META_PARENT_SHA256: parent_sha256,
            META_STEP: str(step),
            META_EDITS: json.dumps(list(edits), sort_keys=True),
        }
    )
    return out


def parent_of(metadata: Mapping[str, str]) -> tuple[str, str, int] | None:
    """``(parent file name, parent SHA-256, step)`` of a child recording's metadata, None for
    a recording that was not resumed."""
    if META_STEP not in metadata:
        return None
    return (
        metadata.get(META_PARENT, ""),
        metadata.get(META_PARENT_SHA256, ""),
        int(metadata[META_STEP]),
    )
