"""Errors of the explore package."""

from __future__ import annotations

from harness.errors import ConfigError, HarnessError

__all__ = ["ExploreConfigError", "ExploreError"]


class ExploreError(HarnessError):
    """The search could not run to an end (a worker died, a backend could not be reached)."""


class ExploreConfigError(ConfigError):
    """A scenario's ``explore`` section (or an option of ``harness explore``) is invalid; the
    message is one line naming the file, the key path and what is wrong."""
