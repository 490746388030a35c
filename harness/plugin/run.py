"""One test's harness state (:class:`HarnessRun`: its sessions, recordings, events, golden
notes) and :class:`SessionFactory`, the ``harness_session_factory`` fixture's value: the marker's
options, the scenario translation and the suite's actuation turned into :class:`harness.Session`
keywords; the recordings kept or removed per ``--harness-keep-recordings`` at teardown.

This module imports only the standard library, pytest and :mod:`harness.vocabulary` at import
time; the session stack loads when the first session is made.
"""

from __future__ import annotations

import contextlib
import re
import shutil
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from harness.plugin.examples import current_example
from harness.plugin.markers import (
    check_keys,
    marker_options,
    one_mode,
    parse_load_options,
    resolve_path,
    suite_mode,
    suite_robots,
)
from harness.plugin.scenario import over_scenario, scenario_session
from harness.plugin.settings import SETTINGS, HarnessSettings

if TYPE_CHECKING:
    from harness.events import CollectingSink
    from harness.session import Session

__all__ = ["FAILURE_NOTE", "RUN", "HarnessRun", "SessionFactory", "harness_run", "safe_name"]

FAILURE_NOTE = "failure.txt"
"""In a failed test's folder: its node id and the ``harness`` report section (the commands)."""


def safe_name(name: str) -> str:
    """A test's name as a file name (recordings, goldens)."""
    return re.sub(r"[^\w.\-\[\]]+", "_", name).strip("_") or "test"


@dataclass
class HarnessRun:
    """Everything the plugin holds for one test that uses a harness fixture."""

    item: pytest.Item
    settings: HarnessSettings
    sessions: list[Session] = field(default_factory=list)
    modes: list[Any] = field(default_factory=list)
    recordings: list[Path] = field(default_factory=list)
    snapshots: list[Path] = field(default_factory=list)
    folders: list[Path] = field(default_factory=list)
    """The folders of the worlds generated for scenario sessions (a ``scene.xml``), and of
    the scenario runs of ``harness_scenario`` (client log, generated world)."""
    results: list[Any] = field(default_factory=list)
    """The ``harness_scenario`` runs' :class:`harness.scenario.IterationResult` (the report
    lists their failed verdicts)."""
    sinks: list[CollectingSink] = field(default_factory=list)
    divergence: str | None = None
    golden: Path | None = None
    """The golden :meth:`~harness.plugin.goldens.Golden.check` compared with."""
    golden_note: str | None = None
    bridge_errors: list[str] = field(default_factory=list)
    close_errors: list[str] = field(default_factory=list)
    failed: bool = False
    closed: bool = False
    example: object | None = None
    """The hypothesis example whose sessions these are (:mod:`harness.plugin.examples`)."""

    @property
    def folder(self) -> Path:
        """This test's own folder under the record dir, ``<test file>/[<class>.]<test name>/``:
        its recordings, snapshots and generated worlds (what a failed test leaves for CI to
        upload, one folder per test)."""
        nodepath = self.item.nodeid.split("::", 1)[0]
        name = safe_name(self.item.name)
        cls = getattr(self.item, "cls", None)
        if cls is not None:
            name = f"{cls.__name__}.{name}"
        return self.settings.record_dir / Path(nodepath).with_suffix("") / name

    def recording_path(self, index: int) -> Path:
        """The recording of the test's session ``index`` (0: its first) in :attr:`folder`."""
        name = safe_name(self.item.name)
        return self.folder / (f"{name}.mcap" if index == 0 else f"{name}-{index + 1}.mcap")

    def session_mode(self) -> Any:
        """The control mode of this test's (first) session, or the one it will get."""
        if self.modes:
            return self.modes[0]
        options = marker_options(self.item)
        mode = options.get("mode")
        scenario = options.get("scenario")
        if scenario is not None and "robots" not in options:
            file = Path(resolve_path(scenario, self.item, self.settings.rootdir))
            with tempfile.TemporaryDirectory() as folder:
                planned = scenario_session(file, Path(folder))
            keywords = over_scenario(planned, dict(options), self.item.nodeid)
            return one_mode(suite_robots(keywords["robots"], self.settings.actuation)[1])
        return suite_mode(mode, self.settings.actuation)

    def make_session(self, options: Mapping[str, Any]) -> Session:
        """A session of this test from the marker's keys (checked) over the scenario's."""
        from harness.events import CollectingSink, CollisionLogger, JointLimitLogger
        from harness.events import velocity_limits as limits_of
        from harness.session import Session

        if self.closed:
            pytest.fail(f"{self.item.nodeid}: this test's sessions already ended", pytrace=False)
        self.enter_example()
        rootdir = self.settings.rootdir
        opts = dict(options)
        if "resume" in opts:
            return self._resumed(opts.pop("resume"), opts)
        scenario = opts.pop("scenario", None)
        index = len(self.recordings)
        path = self.recording_path(index)
        planned: Any = None
        if opts.get("srdf") is not None:  # a path or package:// like robot=
            opts["srdf"] = resolve_path(opts["srdf"], self.item, rootdir)
        if scenario is not None:
            file = Path(resolve_path(scenario, self.item, rootdir))
            if "robot" in opts:
                opts["robot"] = resolve_path(opts["robot"], self.item, rootdir)
            planned = scenario_session(file, path.with_name(f"{path.stem}.world"))
            self.folders.append(path.with_name(f"{path.stem}.world"))
            opts = over_scenario(planned, opts, self.item.nodeid)
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
        robot = resolve_path(opts.pop("robot", default_robot), self.item, rootdir)
        scene = resolve_path(opts.pop("scene", None), self.item, rootdir)
        if isinstance(opts.get("controllers"), list | tuple):  # several files, merged in order
            opts["controllers"] = [resolve_path(c, self.item, rootdir) for c in opts["controllers"]]
        elif "controllers" in opts:
            opts["controllers"] = resolve_path(opts["controllers"], self.item, rootdir)
        mode = suite_mode(opts.pop("mode", None), self.settings.actuation)
        parse_load_options(opts, self.item.nodeid)
        if robots is not None:
            if opts.get("mode") is not None:
                pytest.fail(
                    f"{self.item.nodeid}: harness option 'mode' applies to robot=; with "
                    "robots= give each RobotSpec its control",
                    pytrace=False,
                )
            robots, mode = suite_robots(robots, self.settings.actuation)
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
                mode = one_mode(mode)
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

    def run_scenario(self, options: Mapping[str, Any]) -> Any:
        """The marker's ``scenario=`` run as ``harness run`` runs it (its first iteration:
        its ``script`` or ``client`` program, its criteria and verdicts), recorded as the
        test's recording; the :class:`harness.scenario.IterationResult`. Other marker keys
        do not apply (the file says everything ``harness run`` would run)."""
        import dataclasses

        where = f"{self.item.nodeid}: harness_scenario"
        if self.closed:
            pytest.fail(f"{where}: this test's sessions already ended", pytrace=False)
        scenario = options.get("scenario")
        if scenario is None:
            pytest.fail(
                f"{where} needs @pytest.mark.harness(scenario=FILE) (the scenario to run)",
                pytrace=False,
            )
        other = sorted(set(options) - {"scenario"})
        if other:
            pytest.fail(
                f"{where} runs {scenario} as `harness run` does: harness option(s) "
                f"{', '.join(other)} do not apply (put them in the scenario file)",
                pytrace=False,
            )
        from harness.scenario import (
            ScenarioError,
            iteration_specs,
            load_run_file,
            session_iteration_runner,
        )

        file = Path(resolve_path(scenario, self.item, self.settings.rootdir))
        if not file.is_file():
            pytest.fail(f"{where}: scenario file {file} not found", pytrace=False)
        try:
            config = load_run_file(file)
        except ScenarioError as exc:
            pytest.fail(f"{where}: {exc}", pytrace=False)
        path = self.recording_path(len(self.recordings))
        out = path.with_name(f"{path.stem}.run")
        spec = iteration_specs(config, out, iterations=1)[0]
        spec = dataclasses.replace(spec, out_dir=out, recording_path=path)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.recordings.append(path)
        self.folders.append(out)
        result = session_iteration_runner()(spec)
        self.results.append(result)
        return result

    def _resumed(self, resume: Any, opts: Mapping[str, Any]) -> Session:
        """A session continuing a recording (marker key ``resume``: a mapping with ``from``,
        the recording, and ``at`` (a step) or ``at_time`` (seconds), optionally ``edits`` and
        ``preroll``; ``Session.resume``), recorded as the test's."""
        from harness.events import CollectingSink
        from harness.session import Session

        where = f"{self.item.nodeid}: harness marker: resume="
        keys = {"from", "at", "at_time", "edits", "preroll"}
        if not isinstance(resume, Mapping) or "from" not in resume or set(resume) - keys:
            pytest.fail(
                f"{where} takes a mapping with 'from' (a recording) and 'at' (a step) or "
                f"'at_time' (seconds), optionally 'edits' and 'preroll'; got {resume!r}",
                pytrace=False,
            )
        other = sorted(opts)
        if other:
            pytest.fail(
                f"{where} continues what the recording simulated: {', '.join(other)} "
                "do(es) not apply",
                pytrace=False,
            )
        self.enter_example()
        path = self.recording_path(len(self.recordings))
        path.parent.mkdir(parents=True, exist_ok=True)
        self.recordings.append(path)
        sink = CollectingSink()
        session = Session.resume(
            resolve_path(resume["from"], self.item, self.settings.rootdir),
            step=resume.get("at"),
            at_time=resume.get("at_time"),
            edits=list(resume.get("edits", ())),
            preroll=float(resume.get("preroll", 0.0)),
            record_to=path,
            sinks=[sink],
        )
        self.sessions.append(session)
        self.modes.append(None)
        self.sinks.append(sink)
        return session

    def enter_example(self) -> None:
        """Under ``@given``: a session made in a new example ends the earlier example's
        sessions and removes their files (see :mod:`harness.plugin.examples`)."""
        example = current_example()
        if example is None or example is self.example:
            return
        earlier, self.example = self.example, example
        if earlier is None:
            return
        sessions, self.sessions = self.sessions, []
        try:
            for session in sessions:
                session.close()
        finally:
            self._remove_files()
            for kept in (self.snapshots, self.recordings, self.folders, self.modes, self.sinks):
                kept.clear()

    def _remove_files(self) -> None:
        """Remove the sessions' recordings, snapshots and generated worlds."""
        for path in [*self.snapshots, *self.recordings]:
            with contextlib.suppress(OSError):
                path.unlink()
        for folder in self.folders:
            shutil.rmtree(folder, ignore_errors=True)

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

    def teardown(self) -> None:
        """Close the sessions; keep or remove the recordings per --harness-keep-recordings."""
        try:
            self.close_sessions()
        finally:
            keep = self.settings.keep_recordings
            if keep == "never" or (keep == "failed" and not self.failed):
                self._remove_files()
                with contextlib.suppress(OSError):
                    (self.folder / FAILURE_NOTE).unlink()
                # the test's folder, then its test file's folders, each only when empty
                folder = self.folder
                while folder != self.settings.record_dir and folder.is_relative_to(
                    self.settings.record_dir
                ):
                    try:
                        folder.rmdir()
                    except OSError:
                        break
                    folder = folder.parent


RUN = pytest.StashKey[HarnessRun]()
"""Where a test's :class:`HarnessRun` is kept: ``item.stash[RUN]``."""


def harness_run(request: pytest.FixtureRequest) -> HarnessRun:
    """The test's :class:`HarnessRun`, made (with its teardown) by the first harness fixture."""
    item = request.node
    if not isinstance(item, pytest.Item):
        raise pytest.UsageError("harness fixtures are function-scoped")
    run = item.stash.get(RUN, None)
    if run is None:
        run = HarnessRun(item, item.config.stash[SETTINGS])
        item.stash[RUN] = run
        request.addfinalizer(run.teardown)
    return run


class SessionFactory:
    """``factory(**options) -> Session``: the marker's options overridden by ``options``."""

    def __init__(self, run: HarnessRun) -> None:
        self._run = run

    def __call__(self, **options: Any) -> Session:
        item = self._run.item
        marked = marker_options(item)
        check_keys(f"{item.nodeid}: @pytest.mark.harness", marked)
        check_keys(f"{item.nodeid}: harness_session_factory", options)
        return self._run.make_session({**marked, **options})
