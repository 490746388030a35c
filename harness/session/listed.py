"""Listed, not controllable joints moved to :mod:`harness.controllers.listed` (re-exported)."""

from harness.controllers.listed import CONSISTENT, ListedJoints

__all__ = ["CONSISTENT", "ListedJoints"]
