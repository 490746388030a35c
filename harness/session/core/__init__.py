"""The session's engine, sans-I/O: no sockets, no threads, no wall clock.

:class:`SessionCore` (:mod:`~harness.session.core.engine`) is everything one run does between
two step boundaries; a live run (:mod:`harness.session.live`), ``harness replay`` and
re-simulation drive it alike, with frames in at step boundaries and frames, records and
events out. Its rooms, leaves first:

- ``names`` (checking a ROS name of the options), ``topics`` (topic types, nodes, message
  builders), ``stepping`` (a ``/harness/step`` request), ``frames`` (the recorded form of
  frames and markers), ``epochs`` (resets), ``urdf_text`` (a robot's description text);
- ``markers``: the recorded inputs that are not client frames, and replaying them;
- ``bridge``: the session's rosbridge protocol core, the :class:`~.bridge.Graph` it publishes
  on and the ``/rosout`` sink;
- ``tf`` and ``channels``: every robot's ``/tf`` tree, joints and topics;
- ``control``: the ros2_control controllers on the bridge; ``options``: what a core does
  (:class:`CoreOptions`) and the shell's option groups;
- ``wiring`` (the graph set up at start), ``services`` (``/harness/*``), ``engine``.

Imports point down this list only: ``tests/structure/test_import_cycles.py`` checks that no
module of ``harness`` is part of an import cycle, and ``tests/structure/test_session_layers.py``
that no module here imports an I/O or wall-clock module, the live shell or a recording
submodule (records go to the recorder as the types :mod:`harness.recording` exports).
"""

from harness.session.core.control import controllers_from_metadata, controllers_option
from harness.session.core.engine import (
    CLOCK_MODES,
    DEFAULT_MAX_STEP_REQUEST,
    FAILURE_PREFIX,
    LOG_NAME,
    MARKER_CALL_TIMEOUT,
    MARKER_CLOSE,
    MARKER_DISCONNECT,
    MARKER_PYTHON,
    MARKER_TRANSPORT_STATUS,
    MARKERS,
    START_MODES,
    ClockMode,
    CoreOptions,
    Graph,
    MessageCallback,
    RecordSink,
    RobotChannels,
    ServiceHandler,
    SessionBridge,
    SessionCore,
    SessionTopics,
    StartMode,
    is_marker,
)

__all__ = [
    "CLOCK_MODES",
    "DEFAULT_MAX_STEP_REQUEST",
    "FAILURE_PREFIX",
    "LOG_NAME",
    "MARKERS",
    "MARKER_CALL_TIMEOUT",
    "MARKER_CLOSE",
    "MARKER_DISCONNECT",
    "MARKER_PYTHON",
    "MARKER_TRANSPORT_STATUS",
    "START_MODES",
    "ClockMode",
    "CoreOptions",
    "Graph",
    "MessageCallback",
    "RecordSink",
    "RobotChannels",
    "ServiceHandler",
    "SessionBridge",
    "SessionCore",
    "SessionTopics",
    "StartMode",
    "controllers_from_metadata",
    "controllers_option",
    "is_marker",
]
