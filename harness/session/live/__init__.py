"""The session's live shell: the I/O around one :class:`~harness.session.core.SessionCore`.

:class:`Session` (``session``) owns the loop thread (``loopthread``, its selector polling
while a lockstep client thinks: ``polling``), paces a realtime clock (``pacing``), freezes
the heap while it runs (``heap``), and talks to clients through a port: the embedded server
(``ports``), an external rosbridge server (``upstream``) or the ROS 2 gateway. It is built by
``startup`` and ``assembly``, records to a file (``recordfile``), waits for steps from Python
(``waiting``) and closes in one order (``teardown``); ``_cli`` is ``harness serve``.
"""

from harness.session.live.session import (
    CLOCK_MODES,
    ClockMode,
    LoggerFactory,
    Session,
    SessionTopics,
    StartMode,
)

__all__ = ["CLOCK_MODES", "ClockMode", "LoggerFactory", "Session", "SessionTopics", "StartMode"]
