"""``--level full``: re-run the recorded incoming bridge frames through a fresh protocol core
and session pipeline without sockets, and compare applied inputs and outgoing frames.

That needs the session's socket-free entry point (frames in at a step, frames and applied
inputs out). Until :mod:`harness.session` provides one, the full level is refused with this
explanation rather than pretending: physics verification is unaffected.
"""

from __future__ import annotations

import importlib

from harness.replay.errors import LevelUnavailableError

__all__ = ["ENTRY_POINT", "check_pipeline_available"]

ENTRY_POINT = "harness.session:replay_pipeline"
"""Where the socket-free pipeline is expected: ``replay_pipeline(recording) -> iterator of
(step, applied input, outgoing frames)``."""


def check_pipeline_available() -> None:
    """Raise :class:`LevelUnavailableError` unless the session's socket-free pipeline exists."""
    module_name, attribute = ENTRY_POINT.split(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError:
        module = None
    if module is None or not callable(getattr(module, attribute, None)):
        raise LevelUnavailableError(
            f"--level full needs the session's socket-free pipeline ({ENTRY_POINT}), which this "
            "harness build does not provide yet; use --level physics (the default), which "
            "verifies the physics bit for bit"
        )
    raise LevelUnavailableError(
        f"--level full: {ENTRY_POINT} exists but harness.replay does not drive it yet; use "
        "--level physics"
    )
