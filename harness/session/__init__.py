"""The session: one run of a simulated robot on the rosbridge bridge (:class:`Session`, a thin
shell around the sans-I/O :class:`SessionCore`) and ``harness serve``. Its rooms: the robots'
topics (``channels.py``), the bridge and graph (``bridge.py``), the graph set-up at start
(``wiring.py``), the ``/harness/*`` services (``services.py``), recorded frames
(``frames.py``), resets (``epochs.py``), markers (``markers.py``), controllers
(``control.py``), ``/tf`` (``tf.py``), and the shell's pieces outside its hot path
(``assembly.py``, ``loopthread.py``, ``recordfile.py``, ``waiting.py``, ``teardown.py``); the
command topics it serves live in :mod:`harness.controllers.command_topics`."""

from harness.controllers.command_topics import FORWARD_TOPICS, Trajectory
from harness.session.control import controllers_from_metadata
from harness.session.core import (
    DEFAULT_MAX_STEP_REQUEST,
    FAILURE_PREFIX,
    LOG_NAME,
    MARKERS,
    START_MODES,
    CoreOptions,
    RecordSink,
    SessionCore,
    StartMode,
    is_marker,
)
from harness.session.errors import (
    ClientTimeoutError,
    CommandRefused,
    SessionClosedError,
    SessionConfigError,
    SessionError,
    SimTimeoutError,
)
from harness.session.options import LoadOptions, RecordOptions, TransportOptions
from harness.session.session import CLOCK_MODES, ClockMode, LoggerFactory, Session, SessionTopics

__all__ = [
    "CLOCK_MODES",
    "DEFAULT_MAX_STEP_REQUEST",
    "FAILURE_PREFIX",
    "FORWARD_TOPICS",
    "LOG_NAME",
    "MARKERS",
    "START_MODES",
    "ClientTimeoutError",
    "ClockMode",
    "CommandRefused",
    "CoreOptions",
    "LoadOptions",
    "LoggerFactory",
    "RecordOptions",
    "RecordSink",
    "Session",
    "SessionClosedError",
    "SessionConfigError",
    "SessionCore",
    "SessionError",
    "SessionTopics",
    "SimTimeoutError",
    "StartMode",
    "Trajectory",
    "TransportOptions",
    "controllers_from_metadata",
    "is_marker",
]
