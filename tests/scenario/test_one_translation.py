"""One scenario file, one world: ``harness run``, the pytest marker and a ``Session`` built
from :func:`harness.scenario.session_options.scenario_session` compile the same model, with
the same options and recording metadata (issue 16, item 1)."""

from __future__ import annotations

import json
from dataclasses import replace
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from harness import cli
from harness.recording import Recording
from harness.scenario import Scenario
from harness.scenario.session_options import scenario_session
from harness.session import Session

# Everything the marker used to ignore: objects, a timestep, initial joint positions, a robot
# pose, a second robot (a real Gazebo model, osrf/gazebo_models' simple_arm SDF), a subscriber's
# command topic, a clock and logging.
SIMPLE_ARM = Path(__file__).resolve().parents[1] / "data" / "gazebo_models" / "simple_arm"
SCENARIO_TEMPLATE = """
name: cell
environment: {map: empty}
timestep: 0.004
duration: 0.02
seed: 3
clock: {mode: fast, rate: 2}
objects:
  - {name: crate, shape: box, size: [0.05, 0.05, 0.05], position: [0.6, 0.3, 0.05], mass: 0.2}
robots:
  - robot: demo
    name: left
    position: [0.0, -0.4, 0.0]
    orientation: [0.0, 0.0, 0.5]
    initial_joint_positions: {joint2: 0.3}
    subscribers: [{type: JointStateSubscriber, topic: /left/arm_command}]
  - robot: {simple_arm}
    name: right
    position: [0.0, 0.4, 0.0]
    modes: [{type: JointController, mode: kinematic}]
logging:
  enable: true
  frequency: 50
  destination: {type: JsonLines, path: events.jsonl}
recording: {state_every: 2}
"""
SCENARIO = SCENARIO_TEMPLATE.replace("{simple_arm}", str(SIMPLE_ARM / "model.sdf"))


def _metadata(path: Path) -> dict[str, str]:
    with Recording(path) as rec:
        return dict(rec.metadata)


def _session_route(file: Path, tmp: Path) -> dict[str, str]:
    planned = scenario_session(Scenario.load(file), tmp / "world")
    record = tmp / "session.mcap"
    with Session(
        options=planned.options,
        transport=replace(planned.transport, port=0),
        record=replace(planned.record, record_to=record),
        load=planned.load,
        sinks=planned.sinks(),
    ) as session:
        assert session.world is not None
        for logger in planned.loggers(session.world):
            session.add_logger(logger)
        session.resume()
        session.run_until(lambda: session.step_index >= 5, sim_timeout=1.0)
    assert (tmp / "events.jsonl").read_text()
    return _metadata(record)


def _plugin_args() -> tuple[str, ...]:
    installed = any(ep.value == "harness.pytest_plugin" for ep in entry_points(group="pytest11"))
    return () if installed else ("-p", "harness.pytest_plugin")


MARKED_TEST = """
import json
import pytest

@pytest.mark.harness(scenario="cell.yaml")
def test_cell(harness_session):
    left, right = harness_session.world.robots
    assert (left.namespace, right.namespace) == ("left", "right")
    assert set(right.control.values()) == {"kinematic"}
    assert (harness_session.clock, harness_session.rate) == ("fast", 2.0)
    harness_session.resume()  # a scenario's free-running clock starts paused
    harness_session.run_until(lambda: harness_session.step_index >= 5, sim_timeout=1.0)
"""


def _marker_route(pytester: pytest.Pytester) -> dict[str, str]:
    pytester.makefile(".yaml", cell=SCENARIO)
    pytester.makepyfile(test_cell=MARKED_TEST)
    result = pytester.runpytest_inprocess(
        *_plugin_args(), "-p", "no:cacheprovider", "--harness-keep-recordings=always"
    )
    result.assert_outcomes(passed=1)
    events = pytester.path / "events.jsonl"
    assert events.read_text()  # the logging section's destination
    return _metadata(pytester.path / ".harness/recordings/test_cell/test_cell/test_cell.mcap")


def _run_route(file: Path, tmp: Path) -> dict[str, str]:
    out = tmp / "out"
    cli.main(["run", str(file), "--out", str(out), "--workers", "1"])
    (recording,) = out.glob("*/iteration-001/recording.mcap")
    assert (tmp / "events.jsonl").read_text()  # the logging section's destination
    return _metadata(recording)


@pytest.mark.slow
def test_one_file_one_world_through_run_marker_and_session(
    pytester: pytest.Pytester, tmp_path: Path
) -> None:
    file = tmp_path / "cell.yaml"
    file.write_text(SCENARIO)
    routes = {
        "harness run": _run_route(file, tmp_path),
        "marker": _marker_route(pytester),
        "Session": _session_route(file, tmp_path),
    }
    first = routes["harness run"]
    # the world: both robots posed and namespaced, the object, the timestep, the start pose
    robots = json.loads(first["robots"])
    assert [r["namespace"] for r in robots] == ["left", "right"]
    assert robots[0]["initial_positions"] == {"joint2": 0.3}
    assert first["timestep"] == "0.004"
    assert json.loads(first["joint_command_topic"])["left"] == "/left/arm_command"
    assert (first["clock"], first["rate"], first["start"]) == ("fast", "2.0", "paused")
    assert (first["seed"], first["state_every"]) == ("3", "2")
    for name, metadata in routes.items():
        assert metadata["model_sha256"] == first["model_sha256"], name
        assert metadata == first, name  # every key: the world, the options, the versions


MARKER_WINS = """
import pytest

@pytest.mark.harness(scenario="cell.yaml", clock="lockstep", seed=9, mode="velocity")
def test_marker_keys_win(harness_session):
    left, right = harness_session.world.robots
    assert set(left.control.values()) == {"velocity"}  # robot keys: the first robot
    assert set(right.control.values()) == {"kinematic"}
    assert harness_session.clock == "lockstep"
    assert harness_session.options.seed == 9
    assert harness_session.options.state_every == 2  # the file's, not overridden
    harness_session.step(2)
"""


def test_marker_keys_override_the_scenario(pytester: pytest.Pytester) -> None:
    pytester.makefile(".yaml", cell=SCENARIO)
    pytester.makepyfile(test_wins=MARKER_WINS)
    result = pytester.runpytest_inprocess(*_plugin_args(), "-p", "no:cacheprovider")
    result.assert_outcomes(passed=1)


def test_the_bridge_port_is_the_sessions_when_given(tmp_path: Path) -> None:
    file = tmp_path / "cell.yaml"
    file.write_text(SCENARIO + 'ros: {bridge: {ip: 127.0.0.1, port: "9091"}}\n')
    planned = scenario_session(Scenario.load(file), tmp_path / "world")
    assert (planned.transport.host, planned.transport.port) == ("127.0.0.1", 9091)
    file.write_text(SCENARIO)
    assert scenario_session(Scenario.load(file), tmp_path / "world").transport.port == 0
