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
options objects (:mod:`harness.session.options`: ``rate``, ``namespace``, ``state_every``,
``joint_states_hz``, ``tf_hz``, ``clock_hz``, ``kinematic_limits``, ``seed``,
``joint_command_topic``, ``start``, ``controllers`` (a ros2_control controllers YAML, relative
to the test file's folder, or False), ``sensors``, ``robots``, ``objects``, ``robot_args`` (a
xacro robot's arguments, recorded in the metadata), ``self_collision`` (``auto|off|on|srdf``),
``base`` (``fixed|floating``), ``strict``, ...) except ``host``, ``port``, ``token`` and
``record_to``, which the plugin chooses (a free port, the test's recording).

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
``--harness-golden-dir`` (default ``recordings``). Control modes are
:class:`harness.vocabulary.ControlMode`: ``kinematic | position | velocity | effort``, with
``dynamic`` accepted at every boundary (marker, scenario, ``Session``) as ``position``.

On failure the report gets a ``harness`` section: the recording's path, the
``harness replay`` command, the collision/joint-limit/log event summary, bridge errors and the
first golden divergence.

This module imports only the standard library and pytest: MuJoCo, websockets and MCAP load
when a fixture is first used.
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import shlex
import shutil
import tempfile
from collections.abc import Callable, Generator, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from harness.vocabulary import ACTUATION_INPUTS, ACTUATIONS, Actuation, ClockMode, ControlMode

if TYPE_CHECKING:
    from harness.events import CollectingSink
    from harness.replay import DiffEntry, DiffReport
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

KEEP_CHOICES = ("always", "failed", "never")
MODE_CHOICES = ACTUATION_INPUTS
"""The deprecated ``--harness-mode``'s spellings (``position``/``dynamic`` mean ``servo``)."""
_MARKER_OWN = frozenset(
    {
        "robot",
        "scenario",  # a scenario file (Session's scenario= is its text, attached)
        "collisions",
        "joint_limits",
        "connect",  # the marker's spelling of Session(connect_to=)
        "world",  # a Gazebo world as the map: the same option as scene (harness serve --world)
    }
)
_NOT_MARKER = frozenset({"host", "port", "token", "record_to"})  # the plugin's own choice


@functools.cache
def marker_keys() -> frozenset[str]:
    """The keys ``@pytest.mark.harness`` and ``harness_session_factory`` accept: the
    session's options fields (:data:`harness.session.options.SESSION_KEYWORDS`) but where
    the plugin decides (the free port, the recording path), and the marker's own keys."""
    from harness.session.options import SESSION_KEYWORDS

    return frozenset((set(SESSION_KEYWORDS) - _NOT_MARKER) | _MARKER_OWN)


def __getattr__(name: str) -> Any:
    if name == "MARKER_KEYS":  # computed when asked: the plugin imports little at start
        return marker_keys()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


_DYNAMIC = (ControlMode.POSITION, ControlMode.VELOCITY, ControlMode.EFFORT)
_PLUGIN_MODULE = "harness.pytest_plugin"
_DEFAULT_RECORD_DIR = ".harness/recordings"
_DEFAULT_GOLDEN_DIR = "recordings"
_DEFAULT_MODE = "position"  # harness.models.load_robot's control default


class GoldenMismatch(AssertionError):
    """This test's recording differs from its golden beyond the tolerances."""


@dataclass(frozen=True)
class HarnessSettings:
    """The plugin's options, resolved (command line first, then ini)."""

    rootdir: Path
    record_dir: Path
    keep_recordings: str
    update_goldens: bool
    strict_bridge: bool
    actuation: Actuation | None
    golden_dir: Path
    plugin_args: tuple[str, ...]
    """Arguments that load this plugin when it is not installed as an entry point."""


_SETTINGS = pytest.StashKey[HarnessSettings]()
_GOLDENS_WRITTEN = pytest.StashKey[list[Path]]()


# ----------------------------------------------------------------------------- options


def _add(
    parser: pytest.Parser,
    group: pytest.OptionGroup,
    flag: str,
    ini: str,
    help: str,
    *,
    kind: str = "string",
    default: Any = None,
    choices: tuple[str, ...] | None = None,
) -> None:
    if kind == "bool":
        group.addoption(flag, action="store_true", dest=ini, default=None, help=help)
    else:
        group.addoption(flag, dest=ini, default=None, choices=choices, help=help)
    parser.addini(ini, f"{help} (ini twin of {flag})", type=kind, default=default)  # type: ignore[arg-type]


def pytest_addoption(parser: pytest.Parser) -> None:
    """Register the harness options and their ini twins."""
    group = parser.getgroup("harness", "harness: simulated robots on rosbridge, recorded")
    _add(
        parser,
        group,
        "--harness-record-dir",
        "harness_record_dir",
        f"where test recordings go (default: <rootdir>/{_DEFAULT_RECORD_DIR})",
        default="",
    )
    _add(
        parser,
        group,
        "--harness-keep-recordings",
        "harness_keep_recordings",
        "keep recordings of always, failed (default) or never any tests",
        default="failed",
        choices=KEEP_CHOICES,
    )
    _add(
        parser,
        group,
        "--harness-update-goldens",
        "harness_update_goldens",
        "write or overwrite golden recordings instead of comparing with them",
        kind="bool",
        default=False,
    )
    _add(
        parser,
        group,
        "--harness-strict-bridge",
        "harness_strict_bridge",
        "fail a test whose bridge answered a client with an error status",
        kind="bool",
        default=False,
    )
    _add(
        parser,
        group,
        "--harness-actuation",
        "harness_actuation",
        "run every session with every joint kinematic, or as a servo: every kinematic joint "
        "a position servo (velocity and effort joints kept)",
        default="",
        choices=ACTUATIONS,
    )
    _add(
        parser,
        group,
        "--harness-mode",
        "harness_mode",
        "deprecated spelling of --harness-actuation (position and dynamic mean servo)",
        default="",
        choices=MODE_CHOICES,
    )
    _add(
        parser,
        group,
        "--harness-golden-dir",
        "harness_golden_dir",
        f"where golden recordings are (default: <rootdir>/{_DEFAULT_GOLDEN_DIR})",
        default="",
    )


def _choice(config: pytest.Config, name: str, choices: tuple[str, ...], default: str) -> str:
    value = config.getoption(name)
    if value is None:
        value = str(config.getini(name)).strip() or default
        if value not in choices:
            raise pytest.UsageError(
                f"ini option {name} = {value!r}: must be one of {', '.join(choices)}"
            )
    return str(value)


def _actuation(config: pytest.Config) -> Actuation | None:
    """``--harness-actuation``, or the deprecated ``--harness-mode`` with a warning."""
    actuation = _choice(config, "harness_actuation", ("", *ACTUATIONS), "")
    old = _choice(config, "harness_mode", ("", *MODE_CHOICES), "")
    if old:
        new = Actuation.parse(old).value
        if actuation and actuation != new:
            raise pytest.UsageError(
                f"--harness-mode {old} and --harness-actuation {actuation} disagree "
                "(--harness-mode is the deprecated spelling: give only --harness-actuation)"
            )
        config.issue_config_time_warning(
            pytest.PytestDeprecationWarning(
                f"--harness-mode / harness_mode is deprecated: use --harness-actuation {new}"
            ),
            stacklevel=2,
        )
        actuation = new
    return Actuation(actuation) if actuation else None


def _flag(config: pytest.Config, name: str) -> bool:
    value = config.getoption(name)
    return bool(config.getini(name)) if value is None else bool(value)


def _folder(config: pytest.Config, name: str, default: str) -> Path:
    """A folder option: relative to the invocation directory on the command line, to the
    rootdir in the ini file."""
    value = config.getoption(name)
    if value is not None:
        return (config.invocation_params.dir / str(value)).resolve()
    return (config.rootpath / (str(config.getini(name)).strip() or default)).resolve()


def _worker_id(config: pytest.Config) -> str | None:
    workerinput = getattr(config, "workerinput", None)
    if isinstance(workerinput, dict):
        return str(workerinput.get("workerid", "gw"))
    return None


def pytest_configure(config: pytest.Config) -> None:
    """Register the marker and resolve the options (no harness module is imported)."""
    config.addinivalue_line(
        "markers",
        "harness(robot='demo', *, scenario=None, mode=None, clock='lockstep', ...): configure "
        "the harness_session fixture (see harness.pytest_plugin)",
    )
    actuation = _actuation(config)
    record_dir = _folder(config, "harness_record_dir", _DEFAULT_RECORD_DIR)
    worker = _worker_id(config)
    if worker is not None:
        record_dir = record_dir / worker
    from_entry_point = config.pluginmanager.get_plugin("harness") is not None
    config.stash[_SETTINGS] = HarnessSettings(
        rootdir=config.rootpath,
        record_dir=record_dir,
        keep_recordings=_choice(config, "harness_keep_recordings", KEEP_CHOICES, "failed"),
        update_goldens=_flag(config, "harness_update_goldens"),
        strict_bridge=_flag(config, "harness_strict_bridge"),
        actuation=actuation,
        golden_dir=_folder(config, "harness_golden_dir", _DEFAULT_GOLDEN_DIR),
        plugin_args=() if from_entry_point else ("-p", _PLUGIN_MODULE),
    )
    config.stash[_GOLDENS_WRITTEN] = []


# ----------------------------------------------------------------------------- per test


def _safe(name: str) -> str:
    return re.sub(r"[^\w.\-\[\]]+", "_", name).strip("_") or "test"


def _marker_options(item: pytest.Item) -> dict[str, Any]:
    """The merged ``harness`` markers (closest first wins); positional arg = robot."""
    options: dict[str, Any] = {}
    for mark in item.iter_markers("harness"):
        if len(mark.args) > 1:
            pytest.fail(
                f"{item.nodeid}: @pytest.mark.harness takes at most one positional argument "
                f"(the robot), got {len(mark.args)}",
                pytrace=False,
            )
        values = dict(mark.kwargs)
        if mark.args:
            values.setdefault("robot", mark.args[0])
        for key, value in values.items():
            options.setdefault(key, value)
    return options


def _check_keys(where: str, options: Mapping[str, Any]) -> None:
    known = marker_keys()
    unknown = sorted(set(options) - known)
    if unknown:
        pytest.fail(
            f"{where}: unknown harness option {unknown[0]!r} (known: {', '.join(sorted(known))})",
            pytrace=False,
        )


def parse_mode(mode: Any, where: str = "harness option 'mode'") -> Any:
    """A marker's ``mode`` (one mode or joint -> mode) with every spelling parsed
    (``dynamic`` is ``position``): :class:`~harness.vocabulary.ControlMode` members."""
    try:
        if isinstance(mode, Mapping):
            return {j: ControlMode.parse(m, f"{where}[{j!r}]") for j, m in mode.items()}
        return None if mode is None else ControlMode.parse(mode, where)
    except ValueError as exc:
        pytest.fail(str(exc), pytrace=False)


def _parse_load_options(opts: dict[str, Any], where: str) -> None:
    """The marker's ``self_collision``, ``base``, ``clock`` and ``kinematic_limits`` parsed in
    place (one spelling, from :mod:`harness.vocabulary`); a wrong value fails the test naming
    it."""
    from harness.vocabulary import ClockMode, LimitPolicy, RobotBase, SelfCollisionPolicy

    try:
        for key, vocabulary in (("clock", ClockMode), ("kinematic_limits", LimitPolicy)):
            if opts.get(key) is not None:
                opts[key] = vocabulary.parse(opts[key], f"{where}: harness option {key!r}")
        if opts.get("self_collision") is not None:
            opts["self_collision"] = SelfCollisionPolicy.parse(
                opts["self_collision"], f"{where}: harness option 'self_collision'"
            ).value
        if opts.get("base") is not None:
            opts["base"] = RobotBase.parse(opts["base"], f"{where}: harness option 'base'").value
    except ValueError as exc:
        pytest.fail(str(exc), pytrace=False)
    if "strict" in opts and not isinstance(opts["strict"], bool):
        pytest.fail(f"{where}: harness option 'strict' must be true or false", pytrace=False)


def suite_mode(mode: Any, suite: Actuation | str | None) -> Any:
    """The control mode a session runs in: the test's ``mode`` (parsed: ``dynamic`` is
    ``position``) unless the suite's actuation (``--harness-actuation``) makes every joint
    kinematic, or every kinematic joint a position servo (``servo``)."""
    mode = parse_mode(mode)
    if suite is None:
        return mode if mode is not None else ControlMode.POSITION
    if Actuation.parse(suite, "--harness-actuation") is Actuation.KINEMATIC:
        return ControlMode.KINEMATIC
    if isinstance(mode, Mapping):
        return {j: (m if m in _DYNAMIC else ControlMode.POSITION) for j, m in mode.items()}
    return mode if mode in _DYNAMIC else ControlMode.POSITION


def _resolve_path(value: Any, item: pytest.Item, rootdir: Path) -> Any:
    """A relative model/scenario path against the test's folder, then the rootdir."""
    if not isinstance(value, str | os.PathLike):
        return value
    text = os.fspath(value)
    if text.startswith("package://"):
        # the package search starts at the test's folder (else a load error names the search)
        from harness.errors import HarnessError
        from harness.models.resolve import resolve_uri

        try:
            return resolve_uri(text, base_dir=item.path.parent, what="robot file")
        except HarnessError:
            return value
    if not ("/" in text or os.sep in text or Path(text).suffix):
        return value  # a built-in name ("demo", "table")
    path = Path(text)
    if path.is_absolute():
        return path
    for base in (item.path.parent, rootdir):
        if (base / path).exists():
            return (base / path).resolve()
    return value


_ROBOT_KEYS = ("robot", "mode", "namespace", "robot_args", "self_collision", "base", "strict")
"""Marker keys that, with a scenario, apply to its first robot (``robots=`` replaces them all)."""


def _scenario_session(path: Path, folder: Path) -> Any:
    """The scenario's session (:func:`harness.scenario.session_options.scenario_session`: the
    translation ``harness run`` uses), with the marker's default clock (``lockstep``) when
    the file has no ``clock`` section; a bad file fails the test with its problems."""
    from harness.scenario import Scenario, ScenarioError
    from harness.scenario.scenario import Clock
    from harness.scenario.session_options import scenario_session

    try:
        return scenario_session(
            Scenario.load(path), folder, default_clock=Clock(ClockMode.LOCKSTEP)
        )
    except ScenarioError as exc:
        pytest.fail(str(exc), pytrace=False)


def _over_scenario(planned: Any, marker: dict[str, Any], where: str) -> dict[str, Any]:
    """The scenario's Session keywords with the marker's keys over them (the marker wins):
    world-level keys replace the scenario's; ``robots`` replaces its robots; ``robot``,
    ``mode``, ``namespace``, ``robot_args``, ``self_collision``, ``base`` and ``strict``
    apply to its first robot (a RobotSpec field each: ``source``, ``control``, ...)."""
    import dataclasses

    keywords = planned.keywords()
    keywords["port"] = 0  # a free port per test: xdist workers run side by side
    del keywords["record_to"]  # the test's own recording
    own = {k: marker.pop(k) for k in _ROBOT_KEYS if k in marker}
    if "robots" not in marker and own:
        if "mode" in own:
            own["mode"] = parse_mode(own["mode"], f"{where}: harness option 'mode'")
        _parse_load_options(own, where)
        names = {"robot": "source", "mode": "control"}
        first = keywords["robots"][0]
        if "robot" in own:  # another robot: the file's joint settings are not its
            first = dataclasses.replace(first, control="position", initial_positions={})
            first = dataclasses.replace(first, robot_args={})
        first = dataclasses.replace(first, **{names.get(k, k): v for k, v in own.items()})
        keywords["robots"] = [first, *keywords["robots"][1:]]
    elif own:
        pytest.fail(
            f"{where}: harness options {', '.join(sorted(own))} apply to robot=; with robots= "
            "give each RobotSpec its own",
            pytrace=False,
        )
    if "world" in marker and "scene" not in marker:
        keywords.pop("scene")
    if "clock" in marker and "start" not in marker:  # as the translation starts that clock
        keywords["start"] = "now" if marker["clock"] == "lockstep" else "paused"
    return {**keywords, **marker}


@dataclass
class _TestRun:
    """Everything the plugin holds for one test that uses a harness fixture."""

    item: pytest.Item
    settings: HarnessSettings
    sessions: list[Session] = field(default_factory=list)
    modes: list[Any] = field(default_factory=list)
    recordings: list[Path] = field(default_factory=list)
    snapshots: list[Path] = field(default_factory=list)
    folders: list[Path] = field(default_factory=list)
    """The folders of the worlds generated for scenario sessions (a ``scene.xml``)."""
    sinks: list[CollectingSink] = field(default_factory=list)
    divergence: str | None = None
    golden_note: str | None = None
    bridge_errors: list[str] = field(default_factory=list)
    close_errors: list[str] = field(default_factory=list)
    failed: bool = False
    closed: bool = False

    def recording_path(self, index: int) -> Path:
        nodepath = self.item.nodeid.split("::", 1)[0]
        folder = self.settings.record_dir / Path(nodepath).with_suffix("")
        name = _safe(self.item.name)
        return folder / (f"{name}.mcap" if index == 0 else f"{name}-{index + 1}.mcap")

    def session_mode(self) -> Any:
        """The control mode of this test's (first) session, or the one it will get."""
        if self.modes:
            return self.modes[0]
        options = _marker_options(self.item)
        mode = options.get("mode")
        scenario = options.get("scenario")
        if scenario is not None and "robots" not in options:
            file = Path(_resolve_path(scenario, self.item, self.settings.rootdir))
            with tempfile.TemporaryDirectory() as folder:
                planned = _scenario_session(file, Path(folder))
            keywords = _over_scenario(planned, dict(options), self.item.nodeid)
            return _one_mode(_suite_robots(keywords["robots"], self.settings.actuation)[1])
        return suite_mode(mode, self.settings.actuation)

    def golden_path(self) -> Path:
        module = Path(self.item.nodeid.split("::", 1)[0]).stem
        name = _safe(self.item.name)
        cls = getattr(self.item, "cls", None)
        if cls is not None:
            name = f"{cls.__name__}.{name}"
        return self.settings.golden_dir / module / f"{name}{mode_label(self.session_mode())}.mcap"

    def update_command(self) -> str:
        nodepath, _, rest = self.item.nodeid.partition("::")
        where = os.path.relpath(
            self.settings.rootdir / nodepath, self.item.config.invocation_params.dir
        )
        target = f"{where}::{rest}" if rest else where
        args = ["python", "-m", "pytest", target, "--harness-update-goldens"]
        return shlex.join([*args, *self.settings.plugin_args])

    def make_session(self, options: Mapping[str, Any]) -> Session:
        from harness.events import CollectingSink, CollisionLogger, JointLimitLogger
        from harness.events import velocity_limits as limits_of
        from harness.session import Session

        if self.closed:
            pytest.fail(f"{self.item.nodeid}: this test's sessions already ended", pytrace=False)
        rootdir = self.settings.rootdir
        opts = dict(options)
        scenario = opts.pop("scenario", None)
        index = len(self.recordings)
        path = self.recording_path(index)
        planned: Any = None
        if scenario is not None:
            file = Path(_resolve_path(scenario, self.item, rootdir))
            if "robot" in opts:
                opts["robot"] = _resolve_path(opts["robot"], self.item, rootdir)
            planned = _scenario_session(file, path.with_name(f"{path.stem}.world"))
            self.folders.append(path.with_name(f"{path.stem}.world"))
            opts = _over_scenario(planned, opts, self.item.nodeid)
        if "connect" in opts:  # the marker's spelling of Session(connect_to=)
            opts["connect_to"] = opts.pop("connect")
        if "world" in opts:
            if opts.get("scene") is not None:
                raise pytest.UsageError(
                    f"{self.item.nodeid}: harness marker: world= and scene= name the same "
                    "option (the map); give one"
                )
            opts["scene"] = opts.pop("world")
        robots = opts.pop("robots", None)
        default_robot = None if robots else "demo"
        robot = _resolve_path(opts.pop("robot", default_robot), self.item, rootdir)
        scene = _resolve_path(opts.pop("scene", None), self.item, rootdir)
        if "controllers" in opts:
            opts["controllers"] = _resolve_path(opts["controllers"], self.item, rootdir)
        mode = suite_mode(opts.pop("mode", None), self.settings.actuation)
        _parse_load_options(opts, self.item.nodeid)
        if robots is not None:
            if opts.get("mode") is not None:
                pytest.fail(
                    f"{self.item.nodeid}: harness option 'mode' applies to robot=; with "
                    "robots= give each RobotSpec its control",
                    pytrace=False,
                )
            robots, mode = _suite_robots(robots, self.settings.actuation)
            opts["robots"] = robots
        clock = opts.pop("clock", "lockstep")
        collisions: Any = opts.pop("collisions", True)
        joint_limits: Any = opts.pop("joint_limits", True)
        loggers: list[Callable[[Session], Any]] = []
        if planned is not None:
            # the scenario's loggers (added below), the marker's collisions/joint_limits
            # keys replacing the scenario's collision and joint-limit loggers
            collisions = collisions if "collisions" in options else None
            joint_limits = joint_limits if "joint_limits" in options else None
            if "robots" not in options:
                mode = _one_mode(mode)
        if collisions not in (False, None):
            kwargs = dict(collisions) if isinstance(collisions, Mapping) else {}
            loggers.append(lambda s: CollisionLogger(s.model, **kwargs))
        if joint_limits not in (False, None):
            jl = dict(joint_limits) if isinstance(joint_limits, Mapping) else {}
            loggers.append(
                lambda s: JointLimitLogger(
                    s.model,
                    # tolerance: the solver's soft-limit zone per joint unless the marker's
                    # joint_limits gives one (harness.events.solver_limit_tolerance)
                    **{"velocity_limits": limits_of(s.description), **jl},
                )
            )
        sink = CollectingSink()
        sinks: list[Any] = [sink, *(planned.sinks() if planned is not None else ())]
        path.parent.mkdir(parents=True, exist_ok=True)
        self.recordings.append(path)
        session = Session(
            robot,
            mode=None if robots is not None else mode,
            clock=clock,
            scene=scene,
            record_to=path,
            loggers=loggers,
            sinks=sinks,
            **opts,
        )
        self.sessions.append(session)
        if planned is not None:
            try:
                assert session.world is not None
                skip = {
                    kind
                    for key, kind in (
                        ("collisions", CollisionLogger),
                        ("joint_limits", JointLimitLogger),
                    )
                    if key in options
                }
                for logger in planned.loggers(session.world):
                    if type(logger) not in skip:
                        session.add_logger(logger)  # before the first step
            except BaseException:
                session.close()
                raise
        self.modes.append(mode)
        self.sinks.append(sink)
        return session

    def close_sessions(self) -> None:
        """End every session of the test (idempotent); close errors are kept and raised."""
        if self.closed:
            return
        self.closed = True
        errors: list[BaseException] = []
        for session in self.sessions:
            try:
                session.close()
            except Exception as exc:
                errors.append(exc)
                self.close_errors.append(f"{type(exc).__name__}: {exc}")
        if errors:
            raise errors[0]

    def find_bridge_errors(self) -> list[str]:
        """Error ``status`` frames the bridge sent to clients, from the recordings."""
        import json

        from harness.recording import Recording
        from harness.rosbridge import DIRECTION_OUT

        found: list[str] = []
        for path in self.recordings:
            if not path.is_file():
                continue
            with Recording(path) as rec:
                for frame in rec.bridge_frames():
                    if frame.op != "status" or frame.direction != DIRECTION_OUT:
                        continue
                    with contextlib.suppress(ValueError):
                        status = json.loads(frame.text)
                        if status.get("level") == "error":
                            found.append(
                                f"step {frame.step}, connection {frame.connection}: "
                                f"{status.get('msg', '')}"
                            )
        self.bridge_errors = found
        return found

    def describe(self) -> str:
        """The failure report section."""
        keep = self.settings.keep_recordings
        lines: list[str] = []
        for path in self.recordings:
            fate = "removed after the test" if keep == "never" else "kept"
            lines.append(f"recording: {path} ({fate}: --harness-keep-recordings={keep})")
            lines.append(f"replay:    {shlex.join(['harness', 'replay', str(path)])}")
        for path in self.snapshots:
            lines.append(f"snapshot:  {path} (what golden.check() compared)")
        for sink in self.sinks:
            summary = sink.report_lines(max_lines=20)
            lines.append(f"events:    {summary[0] or 'none'}")
            lines.extend(f"           {line}" for line in summary[1:])
        if self.bridge_errors:
            lines.append(f"bridge:    {len(self.bridge_errors)} error status frame(s)")
            lines.extend(f"           {e}" for e in self.bridge_errors[:20])
        if self.divergence:
            lines.append(f"golden:    first divergence: {self.divergence}")
        elif self.golden_note:
            lines.append(f"golden:    {self.golden_note}")
        lines.extend(f"close:     {e}" for e in self.close_errors)
        return "\n".join(lines)

    def teardown(self) -> None:
        """Close the sessions; keep or remove the recordings per --harness-keep-recordings."""
        try:
            self.close_sessions()
        finally:
            keep = self.settings.keep_recordings
            if keep == "never" or (keep == "failed" and not self.failed):
                for path in [*self.snapshots, *self.recordings]:
                    with contextlib.suppress(OSError):
                        path.unlink()
                    with contextlib.suppress(OSError):
                        path.parent.rmdir()  # only when empty
                for folder in self.folders:
                    shutil.rmtree(folder, ignore_errors=True)


_RUN = pytest.StashKey[_TestRun]()


def _run(request: pytest.FixtureRequest) -> _TestRun:
    item = request.node
    if not isinstance(item, pytest.Item):
        raise pytest.UsageError("harness fixtures are function-scoped")
    run = item.stash.get(_RUN, None)
    if run is None:
        run = _TestRun(item, item.config.stash[_SETTINGS])
        item.stash[_RUN] = run
        request.addfinalizer(run.teardown)
    return run


class SessionFactory:
    """``factory(**options) -> Session``: the marker's options overridden by ``options``."""

    def __init__(self, run: _TestRun) -> None:
        self._run = run

    def __call__(self, **options: Any) -> Session:
        item = self._run.item
        marked = _marker_options(item)
        _check_keys(f"{item.nodeid}: @pytest.mark.harness", marked)
        _check_keys(f"{item.nodeid}: harness_session_factory", options)
        return self._run.make_session({**marked, **options})


class Golden:
    """This test's golden recording: :attr:`path`, :meth:`check`."""

    def __init__(self, run: _TestRun) -> None:
        self._run = run

    @property
    def path(self) -> Path:
        """``<golden dir>/<test module>/<test name>[<mode>].mcap`` (the mode only when it is
        not the default; see the module docstring)."""
        return self._run.golden_path()

    def check(self, **tolerances: float) -> DiffReport:
        """Compare this test's recording so far (a snapshot: the session keeps running) with
        the golden (or write the golden under ``--harness-update-goldens``). ``tolerances``:
        per-quantity bounds (:class:`harness.replay.Tolerances` fields; default 0: exact).
        Raises :class:`GoldenMismatch` naming the first divergence."""
        from harness.replay import Tolerances, diff

        run = self._run
        unknown = sorted(set(tolerances) - set(Tolerances._fields))
        if unknown:
            raise TypeError(
                f"golden.check: unknown tolerance {unknown[0]!r} "
                f"(known: {', '.join(Tolerances._fields)})"
            )
        if not run.recordings:
            raise pytest.UsageError(
                f"{run.item.nodeid}: golden.check() needs this test's harness_session"
            )
        recording = run.recordings[0]
        session = run.sessions[0]
        if not session.closed:
            snapshot = recording.with_name(f"{recording.stem}.snapshot.mcap")
            session.snapshot(snapshot)
            if snapshot not in run.snapshots:
                run.snapshots.append(snapshot)
            recording = snapshot
        golden = self.path
        shown = _shown(golden, run.settings.rootdir)
        if run.settings.update_goldens:
            _write_atomically(recording, golden)
            run.item.config.stash[_GOLDENS_WRITTEN].append(golden)
            run.golden_note = f"written {shown}"
        elif not golden.is_file():
            run.golden_note = f"missing {shown}"
            pytest.fail(
                f"golden recording {shown} does not exist; create it with:\n"
                f"    {run.update_command()}",
                pytrace=False,
            )
        bounds: dict[str, Any] = dict(tolerances)
        report = diff(golden, recording, Tolerances(**bounds), ignore_after_last_step=True)
        if not report.same:
            first = _first(report.entries)
            run.divergence = _format_entry(first)
            raise GoldenMismatch(
                f"this run differs from golden {shown}: first divergence: {run.divergence}\n"
                f"{report.format()}\n"
                f"if the change is intended: {run.update_command()}"
            )
        return report


def _suite_robots(robots: Any, suite: Actuation | None) -> tuple[list[Any], Any]:
    """The marker's ``robots`` (RobotSpecs) with ``--harness-actuation`` applied to each, and
    the control mode the golden name carries (one mode, or MuJoCo joint name -> mode)."""
    import dataclasses

    specs = [dataclasses.replace(spec, control=suite_mode(spec.control, suite)) for spec in robots]
    controls = [spec.control for spec in specs]
    if all(isinstance(c, str) for c in controls) and len(set(controls)) == 1:
        return specs, controls[0]
    combined: dict[str, Any] = {}
    for spec in specs:
        prefix = f"{spec.namespace}/" if spec.namespace else ""
        if isinstance(spec.control, Mapping):
            combined.update({prefix + j: m for j, m in spec.control.items()})
        else:
            combined[prefix + "*"] = spec.control
    return specs, combined


def _one_mode(mode: Any) -> Any:
    """A scenario robot's modes (every controllable joint listed) as one mode when they are
    all the same (the golden name ``[kinematic]``, as for ``mode="kinematic"``)."""
    if isinstance(mode, Mapping) and len(set(mode.values())) == 1:
        return next(iter(mode.values()))
    return mode


def mode_label(mode: Any) -> str:
    """The golden-name suffix of a control mode: ``""`` for the default (every joint
    ``position``), ``"[kinematic]"``, or the joints that differ, ``"[j1=velocity,j2=effort]"``."""
    if isinstance(mode, Mapping):
        changed = sorted((str(j), str(m)) for j, m in mode.items() if m != _DEFAULT_MODE)
        return f"[{','.join(f'{j}={m}' for j, m in changed)}]" if changed else ""
    if mode is None or mode == _DEFAULT_MODE:
        return ""
    return f"[{mode}]"


def _shown(path: Path, rootdir: Path) -> str:
    with contextlib.suppress(ValueError):
        return str(path.relative_to(rootdir))
    return str(path)


def _first(entries: Iterable[DiffEntry]) -> DiffEntry:
    return min(entries, key=lambda e: (e.step < 0, e.step))


def _format_entry(e: DiffEntry) -> str:
    where = f" at step {e.step}" if e.step >= 0 else ""
    return (
        f"{e.quantity} {e.name}{where}: golden {e.a!r}, this run {e.b!r} "
        f"(max delta {e.max_delta:.6g} > tolerance {e.tolerance:g})"
    )


def _write_atomically(source: Path, target: Path) -> None:
    """Copy ``source`` to ``target`` through a temporary file in the same folder and a rename,
    so that a reader (or a second writer) never sees half a file."""
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as out, open(source, "rb") as src:
            shutil.copyfileobj(src, out)
            out.flush()
            os.fsync(out.fileno())
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a golden is a project file
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


# ----------------------------------------------------------------------------- fixtures


@pytest.fixture
def harness_session_factory(request: pytest.FixtureRequest) -> SessionFactory:
    """``factory(**options) -> Session``: sessions configured by the ``harness`` marker,
    overridden by keyword arguments; all end with the test body."""
    return SessionFactory(_run(request))


@pytest.fixture
def harness_session(harness_session_factory: SessionFactory) -> Session:
    """This test's session (simulation + rosbridge server + recorder + loggers), configured by
    ``@pytest.mark.harness(...)``; it ends with the test body."""
    return harness_session_factory()


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
    return _run(request).recording_path(0)


@pytest.fixture
def harness_events(harness_session: Session, request: pytest.FixtureRequest) -> CollectingSink:
    """The events (collisions, joint limits, log messages) of this test's session."""
    return _run(request).sinks[0]


@pytest.fixture
def golden(request: pytest.FixtureRequest) -> Golden:
    """This test's golden recording; ``golden.check(**tolerances)``."""
    return Golden(_run(request))


# ----------------------------------------------------------------------------- hooks


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item: pytest.Item) -> Generator[None, object, object]:
    """End the test's sessions with its body; ``--harness-strict-bridge`` fails it when its
    bridge answered an error."""
    try:
        result = yield
    except BaseException:
        run = item.stash.get(_RUN, None)
        if run is not None:
            with contextlib.suppress(Exception):
                run.close_sessions()
            if run.settings.strict_bridge:
                with contextlib.suppress(Exception):
                    run.find_bridge_errors()
        raise
    run = item.stash.get(_RUN, None)
    if run is None:
        return result
    run.close_sessions()
    if run.settings.strict_bridge and run.find_bridge_errors():
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
    run = item.stash.get(_RUN, None)
    if run is not None and report.failed:
        run.failed = True
        text = run.describe()
        if text:
            report.sections.append(("harness", text))
    return report


def pytest_terminal_summary(terminalreporter: Any, config: pytest.Config) -> None:
    """List the goldens written by ``--harness-update-goldens``."""
    written = config.stash.get(_GOLDENS_WRITTEN, [])
    if written:
        terminalreporter.section("harness goldens written")
        for path in written:
            terminalreporter.write_line(str(path))
