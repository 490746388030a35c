"""The session: one run of a simulated robot on the rosbridge bridge, and ``harness serve``.

Two subpackages, split as websockets splits its protocol from its I/O:

- :mod:`harness.session.core`: the engine, :class:`SessionCore`, and everything it runs
  between two step boundaries: its bridge port, controllers, the robots' topics and ``/tf``,
  the ``/harness/*`` services, markers, options, resets and stepping. The rule: **core: no
  sockets, threads or wall clock** (nor file formats: it hands records to the recorder as the
  record types :mod:`harness.recording` exports). A live run, replay and re-simulation all
  drive this one engine.
- :mod:`harness.session.live`: the shell around one core: the :class:`Session` class, its
  loop thread, polling, realtime pacing, the heap, ports (the embedded server, client mode,
  ROS 2), start-up, teardown, waiting from Python, the recording file, ``harness serve``.

``live`` imports ``core``, never the other way; :mod:`harness.session.errors` is shared.
The command topics the core serves live in :mod:`harness.controllers.command_topics`.

The modules' old paths (``harness.session.core`` as a module, ``harness.session.options``,
``harness.session.session``, ...) still import, as aliases of the new modules with a
:class:`DeprecationWarning`, for one release (:mod:`harness._moved`).
"""

from harness._moved import alias_modules

# First, so that an old path imported while this package loads already resolves.
alias_modules(
    {
        **{
            f"harness.session.{name}": f"harness.session.core.{name}"
            for name in (
                "bridge",
                "channels",
                "control",
                "epochs",
                "frames",
                "markers",
                "options",
                "services",
                "stepping",
                "tf",
                "topics",
                "urdf_text",
                "wiring",
            )
        },
        **{
            f"harness.session.{name}": f"harness.session.live.{name}"
            for name in (
                "_cli",
                "assembly",
                "heap",
                "loopthread",
                "pacing",
                "polling",
                "ports",
                "recordfile",
                "session",
                "startup",
                "teardown",
                "upstream",
                "waiting",
            )
        },
        "harness.session.snapshot": "harness.recording.snapshot",
    }
)

from harness.controllers.command_topics import FORWARD_TOPICS, Trajectory  # noqa: E402
from harness.session.core import (  # noqa: E402
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
from harness.session.core.control import (  # noqa: E402
    controllers_from_metadata,
    controllers_option,
)
from harness.session.core.options import (  # noqa: E402
    SESSION_KEYWORDS,
    LoadOptions,
    RecordOptions,
    TransportOptions,
)
from harness.session.errors import (  # noqa: E402
    ClientTimeoutError,
    CommandRefused,
    SessionClosedError,
    SessionConfigError,
    SessionError,
    SimTimeoutError,
)
from harness.session.live import (  # noqa: E402
    CLOCK_MODES,
    ClockMode,
    LoggerFactory,
    Session,
    SessionTopics,
)

__all__ = [
    "CLOCK_MODES",
    "DEFAULT_MAX_STEP_REQUEST",
    "FAILURE_PREFIX",
    "FORWARD_TOPICS",
    "LOG_NAME",
    "MARKERS",
    "SESSION_KEYWORDS",
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
    "controllers_option",
    "is_marker",
]
