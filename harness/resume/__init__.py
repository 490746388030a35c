"""Resume any recording at any step: the run continues bit-exactly from there and a live
client takes over (``harness serve --from RUN.mcap --at STEP``, ``Session.resume(path,
step=K)``).

The session core is brought to the step by running the recorded inputs through it
(:mod:`harness.resume.seek`; correctness comes from the inputs, nothing is restored from a
pickle), fork edits are applied at the step (:mod:`harness.resume.edits`), and a live shell
takes the core over (:mod:`harness.resume.fork` makes the fork; the shell is
:class:`harness.session.Session`, ``Session.resume``): the recorded clients become ghost peers,
attaching clients may be pre-rolled with the recorded traffic before the step
(:mod:`harness.resume.preroll`), and the resumed run records a child recording naming its
parent (:mod:`harness.resume.child`).
"""

from __future__ import annotations

from harness.resume.child import (
    META_EDITS,
    META_PARENT,
    META_PARENT_SHA256,
    META_STEP,
    child_metadata,
    parent_of,
)
from harness.resume.edits import EDIT_KINDS, Edit, apply_edits, parse_edit, parse_edits
from harness.resume.errors import (
    ForkEditError,
    ResumeError,
    ResumeStepError,
    ResumeVersionError,
)
from harness.resume.fork import close_fork, open_fork
from harness.resume.preroll import install_preroll, preroll_frames
from harness.resume.seek import Fork, ForkSink, file_sha256, resolve_step, seek

__all__ = [
    "EDIT_KINDS",
    "META_EDITS",
    "META_PARENT",
    "META_PARENT_SHA256",
    "META_STEP",
    "Edit",
    "Fork",
    "ForkEditError",
    "ForkSink",
    "ResumeError",
    "ResumeStepError",
    "ResumeVersionError",
    "apply_edits",
    "child_metadata",
    "close_fork",
    "file_sha256",
    "install_preroll",
    "open_fork",
    "parent_of",
    "parse_edit",
    "parse_edits",
    "preroll_frames",
    "resolve_step",
    "seek",
]
