"""The pytest plugin, through pytester: inner test files run with the plugin, real sessions."""

from __future__ import annotations

import json
import re
import socket
import subprocess
import sys
import threading
import warnings

import pytest

from harness.pytest_plugin import suite_mode
from harness.recording import Recording

MOVE = """
import pathlib
import pytest
from harness.testing import connect

@pytest.mark.harness(state_every=5)
def test_move(harness_session, rosbridge_url, golden):
    target_file = pathlib.Path(__file__).with_name("target.txt")
    target = float(target_file.read_text()) if target_file.exists() else 0.05
    with connect(rosbridge_url) as client:
        client.publish(
            "/joint_command", "sensor_msgs/msg/JointState",
            {"name": ["joint1"], "position": [target]},
        )
        client.step(40)
    golden.check(**TOLERANCES)

TOLERANCES = {}
"""


def harness_threads() -> list[str]:
    return [t.name for t in threading.enumerate() if t.name.startswith("harness")]


def test_plugin_module_imports_almost_nothing():
    code = "import json, sys; import harness.pytest_plugin; print(json.dumps(sorted(sys.modules)))"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    loaded = set(json.loads(out))
    heavy = {"mujoco", "websockets", "mcap", "numpy", "rosbags", "harness.session"}
    assert not heavy & loaded, sorted(heavy & loaded)
    assert "harness.pytest_plugin" in loaded


def _loaded_by(statement: str) -> set[str]:
    code = f"import json, sys; {statement}; print(json.dumps(sorted(sys.modules)))"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    return set(json.loads(out))


def test_plugin_and_its_rooms_import_only_stdlib_pytest_and_the_vocabulary():
    # what the entry point loads beyond pytest itself: standard library modules and the
    # plugin's own harness modules (harness.plugin.*), nothing else of harness
    extra = _loaded_by("import pytest; import harness.pytest_plugin") - _loaded_by("import pytest")
    outside = sorted(
        name
        for name in extra
        if name.split(".")[0] not in sys.stdlib_module_names and name.split(".")[0] != "harness"
    )
    assert not outside, outside
    own = {name for name in extra if name.split(".")[0] == "harness"}
    allowed = {"harness", "harness._version", "harness.errors", "harness.vocabulary"}
    assert {"harness.pytest_plugin", "harness.plugin.run", "harness.plugin.goldens"} <= own
    assert not {
        name
        for name in own - allowed
        if name != "harness.pytest_plugin" and not name.startswith("harness.plugin")
    }, sorted(own)


def test_every_option_has_an_ini_twin(pytester, run):
    result = run("--help")
    text = result.stdout.str()
    for flag, ini in [
        ("--harness-record-dir", "harness_record_dir"),
        ("--harness-keep-recordings", "harness_keep_recordings"),
        ("--harness-update-goldens", "harness_update_goldens"),
        ("--harness-strict-bridge", "harness_strict_bridge"),
        ("--harness-actuation", "harness_actuation"),
        ("--harness-mode", "harness_mode"),
        ("--harness-golden-dir", "harness_golden_dir"),
        ("--harness-golden-sources", "harness_golden_sources"),
    ]:
        assert flag in text
        assert ini in text


@pytest.mark.slow
def test_fixtures_and_marker(pytester, run):
    pytester.makepyfile(
        test_fixtures="""
        import pytest

        pytestmark = pytest.mark.harness(robot="demo", state_every=3)

        @pytest.mark.harness(mode="kinematic", clock="lockstep")
        def test_marker(harness_session, rosbridge_url, harness_recording, harness_events):
            assert rosbridge_url == harness_session.url
            assert rosbridge_url.startswith("ws://127.0.0.1:")
            assert not rosbridge_url.endswith(":9090")
            assert harness_recording == harness_session.record_path
            assert harness_recording.name == "test_marker.mcap"
            assert harness_session.clock == "lockstep"
            assert set(harness_session.robot.control.values()) == {"kinematic"}
            assert harness_session.step(6) == 6
            assert harness_events is not None

        def test_factory(harness_session_factory, harness_recording):
            first = harness_session_factory(mode="velocity")
            second = harness_session_factory(clock="fast")
            assert set(first.robot.control.values()) == {"velocity"}
            assert second.clock == "fast"
            assert first.record_path == harness_recording
            assert second.record_path.name == "test_factory-2.mcap"
            assert first.url != second.url

        def test_module_marker_applies(harness_session):
            assert set(harness_session.robot.control.values()) == {"position"}
        """
    )
    result = run("--harness-keep-recordings=always")
    result.assert_outcomes(passed=3)
    folder = pytester.path / ".harness" / "recordings" / "test_fixtures"
    # one folder per test (issue 35: what CI uploads of a failed test)
    assert sorted(str(p.relative_to(folder)) for p in folder.rglob("*.mcap")) == [
        "test_factory/test_factory-2.mcap",
        "test_factory/test_factory.mcap",
        "test_marker/test_marker.mcap",
        "test_module_marker_applies/test_module_marker_applies.mcap",
    ]
    with Recording(folder / "test_marker" / "test_marker.mcap") as rec:
        assert [s.step for s in rec.physics_states()] == [0, 3, 6]


def test_unknown_marker_key_is_a_clear_error(pytester, run):
    pytester.makepyfile(
        """
        import pytest

        @pytest.mark.harness(robto="demo")
        def test_typo(harness_session):
            pass
        """
    )
    result = run()
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*unknown harness option 'robto'*"])


def test_missing_golden_fails_with_the_command_to_create_it(pytester, run):
    pytester.makepyfile(test_golden=MOVE)
    result = run()
    result.assert_outcomes(failed=1)
    command = "python -m pytest test_golden.py::test_move --harness-update-goldens"
    result.stdout.fnmatch_lines(
        [
            "*golden recording recordings/test_golden/test_move.mcap does not exist*",
            f"*{command}*",
        ]
    )
    assert not (pytester.path / "recordings").exists()


@pytest.mark.slow
def test_golden_update_then_match_then_mismatch(pytester, run):
    pytester.makepyfile(test_golden=MOVE)
    golden = pytester.path / "recordings" / "test_golden" / "test_move.mcap"

    updated = run("--harness-update-goldens")
    updated.assert_outcomes(passed=1)
    updated.stdout.fnmatch_lines(["*harness goldens written*", f"*{golden}"])
    with Recording(golden) as rec:
        assert rec.complete
        assert rec.last_step == 40

    run().assert_outcomes(passed=1)

    (pytester.path / "target.txt").write_text("0.1")
    mismatch = run()
    mismatch.assert_outcomes(failed=1)
    mismatch.stdout.fnmatch_lines(
        [
            "*GoldenMismatch: this run differs from golden recordings/test_golden/test_move.mcap:"
            " first divergence: joint_position * at step *",
            "*-- harness --*",
            "*recording: *test_move.mcap (kept*",
            "*golden:    first divergence: joint_position * at step *",
        ]
    )
    kept = pytester.path / ".harness/recordings/test_golden/test_move/test_move.mcap"
    assert kept.is_file()
    # The headline and the FIRST DIVERGENCE line name one row (issue 35: they named two
    # joints), and the headline says at which step each value is.
    out = mismatch.stdout.str()
    headline = re.search(r"first divergence: (\S+ \S+ at step \d+): golden (.*)", out)
    block = re.search(r"first state difference: (\S+ \S+ at step \d+) \(A", out)
    assert headline is not None
    assert block is not None
    assert headline[1] == block[1]
    assert headline[1].startswith("joint_position joint1 at step ")
    assert re.search(r"\(delta \S+ there > tolerance 0; max delta \S+ at step \d+\)$", headline[2])

    # Per-quantity tolerances wide enough for the change make it pass.
    pytester.makepyfile(
        test_golden=MOVE.replace(
            "TOLERANCES = {}",
            "TOLERANCES = dict(joint_position=1.0, joint_velocity=100.0, link_position=1.0,"
            " link_rotation=4.0, collision_time_ns=10**9)",
        )
    )
    run().assert_outcomes(passed=1)


FAIL_AND_PASS = """
def test_passes(harness_session):
    harness_session.step(2)

def test_fails(harness_session):
    harness_session.step(2)
    assert False
"""


@pytest.mark.parametrize(
    ("keep", "kept"),
    [("always", {"test_passes", "test_fails"}), ("failed", {"test_fails"}), ("never", set())],
)
def test_recordings_kept_or_removed_per_option(pytester, run, keep, kept):
    pytester.makepyfile(test_keep=FAIL_AND_PASS)
    run(f"--harness-keep-recordings={keep}").assert_outcomes(passed=1, failed=1)
    folder = pytester.path / ".harness" / "recordings" / "test_keep"
    found = {p.stem for p in folder.rglob("*.mcap")} if folder.exists() else set()
    assert found == kept
    # one folder per kept test, nothing else (empty folders of passed tests removed)
    assert ({p.name for p in folder.iterdir()} if folder.exists() else set()) == kept


def test_ini_twins_set_record_dir_and_keep(pytester, run):
    pytester.makeini(
        """
        [pytest]
        harness_record_dir = recs
        harness_keep_recordings = always
        """
    )
    pytester.makepyfile(test_keep=FAIL_AND_PASS)
    run().assert_outcomes(passed=1, failed=1)
    assert {p.stem for p in (pytester.path / "recs" / "test_keep").rglob("*.mcap")} == {
        "test_passes",
        "test_fails",
    }
    # The command line wins over the ini file.
    out = pytester.path / "elsewhere"
    run(f"--harness-record-dir={out}", "--harness-keep-recordings=never")
    assert not list(out.rglob("*.mcap"))


def test_bad_ini_value_is_a_usage_error_naming_the_key(pytester, run):
    pytester.makeini(
        """
        [pytest]
        harness_keep_recordings = sometimes
        """
    )
    pytester.makepyfile(test_keep=FAIL_AND_PASS)
    result = run()
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(
        ["*ini option harness_keep_recordings = 'sometimes': must be one of always, failed, never*"]
    )


BOGUS = """
from harness.testing import connect

def test_talks_nonsense(rosbridge_url):
    with connect(rosbridge_url) as client:
        client._send({"op": "no_such_op"})
        client.sync()
        assert client.statuses
"""


@pytest.mark.slow
def test_strict_bridge_fails_a_test_whose_bridge_answered_errors(pytester, run):
    pytester.makepyfile(test_bogus=BOGUS)
    run().assert_outcomes(passed=1)

    strict = run("--harness-strict-bridge")
    strict.assert_outcomes(failed=1)
    strict.stdout.fnmatch_lines(
        [
            "*--harness-strict-bridge: the bridge answered 1 error status frame(s)*",
            "*Unknown operation: no_such_op*",
        ]
    )

    pytester.makeini("[pytest]\nharness_strict_bridge = true\n")
    run().assert_outcomes(failed=1)


@pytest.mark.slow
def test_failure_report_section(pytester, run):
    pytester.makepyfile(
        test_report="""
        def test_fails(harness_session):
            harness_session.step(10)
            raise RuntimeError("the robot did something wrong")
        """
    )
    result = run()
    result.assert_outcomes(failed=1)
    path = pytester.path / ".harness/recordings/test_report/test_fails/test_fails.mcap"
    result.stdout.fnmatch_lines(
        [
            "*RuntimeError: the robot did something wrong*",
            "*-- harness --*",
            f"recording: {path} (kept: --harness-keep-recordings=failed)",
            # The box resting on the table is a contact: the logger reports it.
            "events:    collision_begin: 1*",
            "*collision began between table (table_top) and box (box)*",
            # the section ends with the commands (issue 35)
            "reproduce: python -m pytest test_report.py::test_fails*",
            f"replay:    harness replay {path}",
            f"open:      foxglove-studio {path}  # Foxglove desktop*",
        ]
    )
    section = result.stdout.str().split("-- harness --", 1)[1].split("short test summary")[0]
    assert section.strip().splitlines()[-2].startswith("open:      foxglove-studio ")
    # the failed test's folder explains itself (what CI uploads)
    note = (path.parent / "failure.txt").read_text()
    assert note.startswith("test_report.py::test_fails failed: RuntimeError: the robot did")
    assert f"replay:    harness replay {path}" in note
    replay = subprocess.run(
        [sys.executable, "-m", "harness", "replay", str(path)], capture_output=True, text=True
    )
    assert replay.returncode == 0, replay.stdout + replay.stderr


def test_teardown_after_a_failing_body_leaves_no_thread_or_socket(pytester, run):
    url_file = pytester.path / "url.txt"
    pytester.makepyfile(
        test_teardown=f"""
        from harness.testing import connect

        def test_fails_midway(rosbridge_url, harness_session):
            open({str(url_file)!r}, "w").write(rosbridge_url)
            client = connect(rosbridge_url)  # left open on purpose
            client.step(3)
            raise KeyError("midway")
        """
    )
    before = harness_threads()
    run().assert_outcomes(failed=1)
    url = url_file.read_text()
    host, port = url.removeprefix("ws://").rsplit(":", 1)
    with pytest.raises(ConnectionRefusedError), socket.create_connection((host, int(port))):
        pass
    leftover = [n for n in harness_threads() if n not in before]
    # The deliberately unclosed client's reader ends when the server closes the socket.
    assert leftover in ([], ["harness-test-client"])
    for thread in threading.enumerate():
        if thread.name == "harness-test-client" and thread.name not in before:
            thread.join(timeout=10)
    assert [n for n in harness_threads() if n not in before] == []


def test_suite_mode_rules():
    assert suite_mode(None, None) == "position"
    assert suite_mode("effort", None) == "effort"
    assert suite_mode("effort", "kinematic") == "kinematic"
    assert suite_mode("kinematic", "dynamic") == "position"
    assert suite_mode("velocity", "dynamic") == "velocity"
    assert suite_mode({"joint1": "kinematic", "joint2": "effort"}, "dynamic") == {
        "joint1": "position",
        "joint2": "effort",
    }


@pytest.mark.slow
def test_harness_mode_option_and_ini(pytester, run):
    pytester.makepyfile(
        test_mode="""
        import pytest

        @pytest.mark.harness(mode="kinematic")
        def test_modes(harness_session, request):
            expected = request.config.getoption("harness_mode") or "kinematic"
            expected = {"dynamic": "position"}.get(expected, expected)
            assert set(harness_session.robot.control.values()) == {expected}
        """
    )
    run().assert_outcomes(passed=1)
    run("--harness-mode=dynamic").assert_outcomes(passed=1)
    pytester.makeini("[pytest]\nharness_mode = dynamic\n")
    result = run()
    result.assert_outcomes(failed=1)  # the ini twin applies: position, not kinematic
    result.stdout.fnmatch_lines(["*assert {'position'} == {'kinematic'}*"])


def test_scenario_marker(pytester, run):
    pytester.makefile(
        ".yaml",
        arm="""
        name: arm-on-table
        environment: {map: table}
        robots:
          - robot: demo
            name: arm
            modes: [{type: JointController, mode: velocity}]
            loggers: [{type: CollisionLogger, ignore_pairs: [[box, table]]}]
        seed: 7
        recording: {state_every: 4}
        """,
    )
    pytester.makepyfile(
        test_scenario="""
        import pytest

        @pytest.mark.harness(scenario="arm.yaml")
        def test_from_scenario(harness_session, harness_events):
            # a scenario runs a world, as under harness run
            assert set(harness_session.world.robots[0].control.values()) == {"velocity"}
            harness_session.step(8)
            harness_session.close()
            assert harness_events.events == []  # box|table ignored
        """
    )
    run("--harness-keep-recordings=always").assert_outcomes(passed=1)
    path = (
        pytester.path / ".harness/recordings/test_scenario/test_from_scenario"
        / "test_from_scenario.mcap"
    )  # fmt: skip
    with Recording(path) as rec:
        assert [s.step for s in rec.physics_states()] == [0, 4, 8]
        assert rec.metadata["seed"] == "7"
        assert (
            "arm-on-table"
            in rec.attachment(next(n for n in rec.attachment_names if "scenario" in n)).decode()
        )


XDIST = """
import pytest
from harness.testing import connect

@pytest.mark.parametrize("target", [0.1, 0.2, 0.3, 0.4])
def test_moves(rosbridge_url, golden, target):
    with connect(rosbridge_url) as client:
        client.publish(
            "/joint_command", "sensor_msgs/msg/JointState",
            {"name": ["joint2"], "position": [target]},
        )
        client.step(20)
    golden.check()
"""


@pytest.mark.slow
def test_xdist_two_workers(pytester, plugin_args, run):
    pytester.makepyfile(test_par=XDIST)
    args = (*plugin_args, "-p", "no:cacheprovider", "-n", "2")
    first = pytester.runpytest_subprocess(
        *args, "--harness-update-goldens", "--harness-keep-recordings=always"
    )
    first.assert_outcomes(passed=4)
    goldens = sorted((pytester.path / "recordings" / "test_par").glob("*.mcap"))
    assert [g.name for g in goldens] == [f"test_moves[{t}].mcap" for t in (0.1, 0.2, 0.3, 0.4)]
    for path in goldens:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with Recording(path) as rec:
                assert rec.complete
                assert rec.last_step == 20
    workers = {p.name for p in (pytester.path / ".harness" / "recordings").iterdir()}
    assert workers == {"gw0", "gw1"}
    assert not list((pytester.path / "recordings").rglob("*.tmp"))
    run().assert_outcomes(passed=4)  # the goldens hold (compared in-process: one xdist run)


MODES = """
import pytest
from harness.testing import connect

def _move(session, url):
    with connect(url) as client:
        client.publish(
            "/joint_command", "sensor_msgs/msg/JointState",
            {"name": ["joint1"], "position": [0.2]},
        )
        client.step(20)

def test_default(harness_session, rosbridge_url, golden):
    _move(harness_session, rosbridge_url)
    golden.check()

@pytest.mark.harness(mode={"joint1": "velocity", "joint2": "position"})
def test_per_joint(harness_session, rosbridge_url, golden):
    _move(harness_session, rosbridge_url)
    golden.check()
"""


@pytest.mark.slow
def test_golden_names_carry_the_control_mode(pytester, run):
    pytester.makepyfile(test_modes=MODES)
    folder = pytester.path / "recordings" / "test_modes"
    run("--harness-update-goldens").assert_outcomes(passed=2)
    run("--harness-update-goldens", "--harness-mode=kinematic").assert_outcomes(passed=2)
    assert sorted(p.name for p in folder.glob("*.mcap")) == [
        "test_default.mcap",
        "test_default[kinematic].mcap",
        "test_per_joint[joint1=velocity].mcap",
        "test_per_joint[kinematic].mcap",
    ]
    with Recording(folder / "test_default[kinematic].mcap") as rec:
        assert "kinematic" in rec.metadata["control_modes"]
        assert "position" not in rec.metadata["control_modes"]
    # Each mode compares with its own golden: both suites pass again.
    run().assert_outcomes(passed=2)
    run("--harness-mode=kinematic").assert_outcomes(passed=2)
    # Without the kinematic goldens, the kinematic suite fails naming the mode's golden.
    (folder / "test_default[kinematic].mcap").unlink()
    missing = run("--harness-mode=kinematic", "-k", "test_default")
    missing.assert_outcomes(failed=1)
    missing.stdout.fnmatch_lines(
        ["*golden recording recordings/test_modes/test_default?kinematic?.mcap*"]
    )


MID_TEST = """
from harness.testing import connect

def test_mid(harness_session, rosbridge_url, golden, harness_recording):
    with connect(rosbridge_url) as client:
        client.publish(
            "/joint_command", "sensor_msgs/msg/JointState",
            {"name": ["joint1"], "position": [0.1]},
        )
        client.step(30)
        report = golden.check()
        assert report.steps_compared == 31
        assert golden.path.name == "test_mid.mcap"
        client.step(10)  # the session still runs after the check
    assert harness_session.step_index == 40
"""


def test_golden_check_mid_test_keeps_the_session_running(pytester, run):
    pytester.makepyfile(test_mid=MID_TEST)
    run("--harness-update-goldens").assert_outcomes(passed=1)
    golden = pytester.path / "recordings" / "test_mid" / "test_mid.mcap"
    with Recording(golden) as rec:
        assert rec.complete
        assert rec.last_step == 30
    run("--harness-keep-recordings=always").assert_outcomes(passed=1)
    kept = pytester.path / ".harness" / "recordings" / "test_mid" / "test_mid"
    assert sorted(p.name for p in kept.glob("*.mcap")) == [
        "test_mid.mcap",
        "test_mid.snapshot.mcap",
    ]
    with Recording(kept / "test_mid.mcap") as rec:
        assert rec.last_step == 40  # the full run, closed at the end of the test


def test_marker_mode_dynamic_is_the_position_session(pytester, run, tmp_path):
    """``mode="dynamic"`` (the product's word) gives the same session as ``mode="position"``:
    control modes, compiled model, recorded state and golden name."""
    out = tmp_path / "sessions.json"
    pytester.makepyfile(
        test_alias=f"""
        import json, pathlib
        import pytest

        SEEN = {{}}

        @pytest.mark.parametrize("mode", ["dynamic", "position"])
        def test_mode(harness_session_factory, golden, request, mode):
            session = harness_session_factory(mode=mode)
            session.step(20)
            SEEN[mode] = {{
                "control": sorted(set(session.robot.control.values())),
                "sha256": session.robot.sha256,
                "qpos": session.sim.data.qpos.tolist(),
                "golden": golden.path.name.replace(request.node.name, "<name>"),
            }}
            pathlib.Path({str(out)!r}).write_text(json.dumps(SEEN))
        """
    )
    run("test_alias.py").assert_outcomes(passed=2)
    seen = json.loads(out.read_text())
    assert seen["dynamic"] == seen["position"]
    assert seen["position"]["control"] == ["position"]
    assert seen["position"]["golden"] == "<name>.mcap"  # no mode label: the default mode
    pytester.makepyfile(
        test_bad="""
        import pytest

        @pytest.mark.harness(mode="servo")
        def test_bad(harness_session):
            pass
        """
    )
    result = run("test_bad.py")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*harness option 'mode': unknown control mode 'servo'*dynamic*"])
