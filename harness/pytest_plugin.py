"""The harness pytest plugin (entry point ``pytest11``: ``harness = "harness.pytest_plugin"``).

Fixtures
--------
- ``harness_session``: a :class:`harness.Session` for this test (simulation + rosbridge server
  on a free port + recorder + collision and joint-limit loggers), configured by the marker
  ``@pytest.mark.harness(robot=..., scenario=..., mode=..., clock=..., ...)``.
- ``harness_session_factory``: ``factory(**options) -> Session`` with the same options as the
  marker (keyword arguments override it); the first session a test makes is *its* session.
- ``rosbridge_url``: ``harness_session.url``.
- ``harness_recording``: this test's recording path (under the record directory).
- ``harness_scenario``: the marker's ``scenario=`` run as ``harness run`` runs it (its
  ``script`` or ``client`` program, its criteria), the
  :class:`harness.scenario.IterationResult` (``passed``, ``reason``, ``verdicts``); recorded as
  the test's recording, kept when the test fails (``harness explore`` writes such a test).
- ``harness_events``: the :class:`~harness.events.CollectingSink` of this test's session (the
  collision, joint-limit and log events).
- ``golden``: ``golden.check(**tolerances)`` compares this test's recording so far (a
  :meth:`harness.Session.snapshot` of its first session, which keeps running: call it
  anywhere in the test, once) with ``recordings/<test module>/<test name>.mcap`` under the
  rootdir through :func:`harness.replay.diff` (tolerances are
  :class:`harness.replay.Tolerances` fields, e.g. ``joint_position=1e-9``;
  ``/harness/bridge`` frames after the last step are not counted: whether a client's frames
  sent at the very end arrive in time is wall-clock timing). A missing golden fails with the
  command that creates it; ``--harness-update-goldens`` writes or overwrites it (written to
  a temporary file, then renamed: concurrent workers never leave half a golden). The snapshot
  is kept next to the recording (``<test>.snapshot.mcap``) like the recording.

Golden names carry every input that affects them besides the test's own code (dm_control
style): when the session's control mode differs from the robot's default (every joint
``position``), the mode is part of the name: ``--harness-actuation=kinematic`` (or
``@pytest.mark.harness(mode="kinematic")``) compares ``<test name>[kinematic].mcap``; a
per-joint mode names the joints that differ, ``<test name>[joint1=velocity].mcap``. One test
thus has one golden per mode, and switching modes never compares against the other's.

A test's sessions end with its body (the recording is complete when the report is built);
fixtures that use a session tear down after it closed.

Marker keys (:func:`marker_keys`): ``robot`` (``"demo"``, a model path; relative paths
resolve against the test file's folder), ``scenario`` (a scenario file, see below), ``mode``
(a control mode or joint -> mode), ``clock`` (default ``lockstep``), ``scene`` (or ``world``),
``collisions`` (``CollisionLogger`` keyword arguments, or False), ``joint_limits``
(``JointLimitLogger`` keyword arguments, or False; its default ``tolerance`` is the solver's
soft-limit zone of each joint, :func:`harness.events.solver_limit_tolerance`, as in ``harness
run``'s verdicts), ``connect`` (``connect_to``), and every other field of the session's
options objects (:mod:`harness.session.core.options`: ``rate``, ``namespace``, ``state_every``,
``joint_states_hz``, ``tf_hz``, ``clock_hz``, ``kinematic_limits``, ``seed``,
``joint_command_topic``, ``start``, ``controllers`` (a ros2_control controllers YAML, relative
to the test file's folder, a list of them merged in order, or False), ``controllers_args`` (its
``$(var NAME)`` values), ``sensors``, ``robots``, ``objects``, ``robot_args`` (a
xacro robot's arguments, recorded in the metadata), ``self_collision`` (``auto|off|on|srdf``),
``base`` (``fixed|floating``), ``strict``, ``mesh_collision`` (``decompose|hull``), ...) except
``host``, ``port``, ``token`` and ``record_to``, which the plugin chooses (a free port, the
test's recording).

``scenario=``: the session ``harness run`` would start for the file
(:func:`harness.scenario.session_options.scenario_session`: every robot with its pose, control
modes, initial joint positions and namespace, the map with its objects and timestep, the
subscribers' command topics, the clock, the recording settings, the seed, the controllers and
sensors, the logging sinks and the robots' loggers), the test's session being a world
(``harness_session.world``) as under ``harness run``. Marker keys win: world-level keys replace
the file's; ``robots`` replaces its robots; ``robot``, ``mode``, ``namespace``, ``robot_args``,
``self_collision``, ``base`` and ``strict`` apply to its first robot; ``collisions`` and
``joint_limits`` replace its collision and joint-limit loggers. A file without a ``clock``
section runs ``lockstep`` (``harness run``: ``realtime``); a free-running clock starts paused
(``harness_session.resume()``).
Markers on the module/class/function merge, the closest wins.

Options (each with an ini twin): ``--harness-record-dir`` (``harness_record_dir``; default
``.harness/recordings`` under the rootdir; one sub-folder per xdist worker),
``--harness-keep-recordings {always,failed,never}`` (default ``failed``),
``--harness-update-goldens``, ``--harness-strict-bridge`` (a test whose bridge answered a
client with an error ``status`` fails), ``--harness-actuation {kinematic,servo}`` (run
every session with every joint kinematic, or as a servo: ``servo`` keeps a test's own dynamic
modes and turns kinematic ones into position control; :class:`harness.vocabulary.Actuation`;
``--harness-mode`` with ``kinematic|position|dynamic`` is its deprecated spelling),
``--harness-golden-dir`` (default ``recordings``), ``--harness-golden-sources
{carry,project}`` (default ``carry``: a golden carries its robot's sources, each file once,
without ``model.mjb`` when they rebuild to it; ``project``: it refers to the project's files by
path and SHA-256 instead, resolved only by the golden check: :mod:`harness.plugin.golden_sources`).
Control modes are
:class:`harness.vocabulary.ControlMode`: ``kinematic | position | velocity | effort``, with
``dynamic`` accepted at every boundary (marker, scenario, ``Session``) as ``position``.

On failure the report gets a ``harness`` section: the recordings' paths, the
collision/joint-limit/log event summary, bridge errors and the first golden divergence, ending
with the commands that reproduce the test (``python -m pytest <test>``), compare it with its
golden (``harness diff``), replay (``harness replay``) and open its recordings (Foxglove).

Recordings are laid out one folder per test, ``<record dir>/<test file>/[<class>.]<test
name>/``: its recordings (``<test name>.mcap``, ``<test name>-2.mcap`` for its second
session), golden snapshots and generated worlds, and for a failed test ``failure.txt`` (its
node id, the error and the ``harness`` section). With ``--harness-keep-recordings=failed``
(the default) the record dir then holds exactly one folder per failed test: what CI uploads
(the README's CI line).

This module is the entry point: the options, the marker, the fixtures and the hooks. The work is
done in :mod:`harness.plugin` (``settings``: the options and :class:`HarnessSettings`;
``markers``: the marker's keys and values; ``scenario``: ``scenario=`` under the marker;
``run``: one test's sessions and recordings; ``goldens``; ``report``: the failure section),
whose public names are importable from here too.

This module imports only the standard library, pytest and :mod:`harness.vocabulary` (through
:mod:`harness.plugin`): MuJoCo, websockets and MCAP load when a fixture is first used.
"""

from __future__ import annotations

import contextlib
from collections.abc import Generator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from harness.plugin.goldens import (
    GOLDENS_UNKNOWN_PLATFORM,
    GOLDENS_WRITTEN,
    Golden,
    GoldenMismatch,
    mode_label,
)
from harness.plugin.markers import check_keys, marker_keys, marker_options, parse_mode, suite_mode
from harness.plugin.report import bridge_errors, report_section, write_failure_note
from harness.plugin.run import RUN, SessionFactory, harness_run
from harness.plugin.settings import (
    KEEP_CHOICES,
    MODE_CHOICES,
    SETTINGS,
    HarnessSettings,
    add_options,
    resolve_settings,
)

if TYPE_CHECKING:
    from harness.events import CollectingSink
    from harness.scenario import IterationResult
    from harness.session import Session

__all__ = [
    "KEEP_CHOICES",
    "MODE_CHOICES",
    "Golden",
    "GoldenMismatch",
    "HarnessSettings",
    "SessionFactory",
    "marker_keys",
    "mode_label",
    "parse_mode",
    "suite_mode",
]


def __getattr__(name: str) -> Any:
    if name == "MARKER_KEYS":  # computed when asked: the plugin imports little at start
        return marker_keys()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# ----------------------------------------------------------------------------- options


def pytest_addoption(parser: pytest.Parser) -> None:
    """Register the harness options and their ini twins."""
    add_options(parser)


def pytest_configure(config: pytest.Config) -> None:
    """Register the marker and resolve the options (no harness module is imported)."""
    config.addinivalue_line(
        "markers",
        "harness(robot='demo', *, scenario=None, mode=None, clock='lockstep', ...): configure "
        "the harness_session fixture (see harness.pytest_plugin)",
    )
    config.stash[SETTINGS] = resolve_settings(config)
    config.stash[GOLDENS_WRITTEN] = []
    config.stash[GOLDENS_UNKNOWN_PLATFORM] = []


# ----------------------------------------------------------------------------- fixtures


@pytest.fixture
def harness_session_factory(request: pytest.FixtureRequest) -> SessionFactory:
    """``factory(**options) -> Session``: sessions configured by the ``harness`` marker,
    overridden by keyword arguments; all end with the test body."""
    return SessionFactory(harness_run(request))


@pytest.fixture
def harness_session(harness_session_factory: SessionFactory) -> Session:
    """This test's session (simulation + rosbridge server + recorder + loggers), configured by
    ``@pytest.mark.harness(...)``; it ends with the test body."""
    return harness_session_factory()


@pytest.fixture
def harness_scenario(request: pytest.FixtureRequest) -> IterationResult:
    """The marker's ``scenario=`` run as ``harness run`` runs it (its script or client
    program, its criteria): the :class:`harness.scenario.IterationResult` (``passed``,
    ``reason``, ``verdicts``, ``recording``); the recording is the test's."""
    item = request.node
    options = marker_options(item)
    check_keys(f"{item.nodeid}: @pytest.mark.harness", options)
    result: IterationResult = harness_run(request).run_scenario(options)
    return result


@pytest.fixture
def rosbridge_url(harness_session: Session) -> str:
    """The ``ws://127.0.0.1:<port>`` URL of this test's rosbridge server (a free port)."""
    return harness_session.url


@pytest.fixture
def ros_domain_id(harness_session: Session) -> int:
    """The private ``ROS_DOMAIN_ID`` of this test's ROS 2 side (``@pytest.mark.harness(
    ros2=True)``): run ROS 2 nodes on it (see :mod:`harness.ros2.testing`)."""
    if harness_session.ros_domain_id is None:
        pytest.fail("ros_domain_id needs @pytest.mark.harness(ros2=True)", pytrace=False)
    return harness_session.ros_domain_id


@pytest.fixture
def harness_recording(request: pytest.FixtureRequest) -> Path:
    """This test's recording path (kept per ``--harness-keep-recordings``)."""
    return harness_run(request).recording_path(0)


@pytest.fixture
def harness_events(harness_session: Session, request: pytest.FixtureRequest) -> CollectingSink:
    """The events (collisions, joint limits, log messages) of this test's session."""
    return harness_run(request).sinks[0]


@pytest.fixture
def golden(request: pytest.FixtureRequest) -> Golden:
    """This test's golden recording; ``golden.check(**tolerances)``."""
    return Golden(harness_run(request))


# ----------------------------------------------------------------------------- hooks


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item: pytest.Item) -> Generator[None, object, object]:
    """End the test's sessions with its body; ``--harness-strict-bridge`` fails it when its
    bridge answered an error."""
    try:
        result = yield
    except BaseException:
        run = item.stash.get(RUN, None)
        if run is not None:
            with contextlib.suppress(Exception):
                run.close_sessions()
            if run.settings.strict_bridge:
                with contextlib.suppress(Exception):
                    run.bridge_errors = bridge_errors(run.recordings)
        raise
    run = item.stash.get(RUN, None)
    if run is None:
        return result
    run.close_sessions()
    if run.settings.strict_bridge:
        run.bridge_errors = bridge_errors(run.recordings)
        if run.bridge_errors:
            shown = "\n".join(f"  {e}" for e in run.bridge_errors[:20])
            pytest.fail(
                f"--harness-strict-bridge: the bridge answered {len(run.bridge_errors)} "
                f"error status frame(s):\n{shown}",
                pytrace=False,
            )
    return result


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(
    item: pytest.Item, call: pytest.CallInfo[None]
) -> Generator[None, pytest.TestReport, pytest.TestReport]:
    """Mark the test failed (recordings kept) and add the ``harness`` report section."""
    report = yield
    run = item.stash.get(RUN, None)
    if run is not None and report.failed:
        run.failed = True
        text = report_section(run)
        if text:
            report.sections.append(("harness", text))
            headline = ""
            if call.excinfo is not None:
                message = str(call.excinfo.value).strip().splitlines()
                headline = f"{call.excinfo.typename}: {message[0] if message else ''}"
            with contextlib.suppress(OSError):
                write_failure_note(run, text, headline)
    return report


def pytest_terminal_summary(terminalreporter: Any, config: pytest.Config) -> None:
    """List the goldens written by ``--harness-update-goldens``, and once the goldens checked
    that carry no platform fingerprint."""
    written = config.stash.get(GOLDENS_WRITTEN, [])
    if written:
        terminalreporter.section("harness goldens written")
        for path in written:
            terminalreporter.write_line(str(path))
    checked: list[Path] = config.stash.get(GOLDENS_UNKNOWN_PLATFORM, [])
    unknown = sorted(set(checked))
    if unknown:
        terminalreporter.section("harness goldens without a platform fingerprint")
        terminalreporter.write_line(
            f"{len(unknown)} golden(s) written by an older harness: checked as if recorded on "
            "this platform; --harness-update-goldens records it"
        )
        for path in unknown:
            terminalreporter.write_line(str(path))
