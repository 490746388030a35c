"""A ROS name given to a session (namespace, topic), checked with the session's error.

A leaf of :mod:`harness.session.core`: the options check the names they are given and the
engine the names it derives from them, the same way, without importing each other.
"""

from __future__ import annotations

from harness.names import NameKind, check_name
from harness.session.errors import SessionConfigError

__all__ = ["check_session_name"]


def check_session_name(value: str, what: str, kind: NameKind = "topic") -> str:
    """``value`` when it is a valid ROS name of ``kind``, else :class:`SessionConfigError`
    naming ``what`` (see :func:`harness.names.check_name`)."""
    return check_name(value, what, kind, SessionConfigError)
