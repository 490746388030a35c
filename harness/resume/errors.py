"""Errors of :mod:`harness.resume` (all :class:`~harness.errors.ReplayError`: a recording that
cannot be continued is a recording that cannot be re-run up to the step asked for)."""

from __future__ import annotations

from harness.errors import ReplayError

__all__ = ["ForkEditError", "ResumeError", "ResumeStepError", "ResumeVersionError"]


class ResumeError(ReplayError):
    """A recording cannot be resumed at the step asked for (damaged before it, diverging
    before it, not a session recording, ...)."""


class ResumeStepError(ResumeError):
    """The step asked for is not one the recording can be resumed at (beyond its end,
    negative, inside a ``/harness/step`` request of a client)."""


class ResumeVersionError(ResumeError):
    """The recording was made by another MuJoCo or harness version: the re-run that brings
    the core to the step is bit-exact only on the same versions."""


class ForkEditError(ResumeError):
    """A fork edit (``--set``) names something the run does not have or a value it cannot
    take."""
