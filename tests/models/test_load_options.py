"""One spelling of the robot load options ``self_collision``, ``base`` and ``strict`` in
Python, the pytest marker, scenario files, ``harness serve``/``check-model``/``inspect-model``,
and in the recording's metadata (replay rebuilds the same model)."""

from __future__ import annotations

import argparse
import json
from importlib.metadata import entry_points
from typing import get_args

import pytest

from harness.cli import main
from harness.models import load_robot
from harness.models._cli import add_arguments as inspect_arguments
from harness.models.check._cli import add_arguments as check_arguments
from harness.models.world.records import BaseKind, SelfCollision
from harness.recording import Recording
from harness.replay.source import rebuild_robot, rebuild_run
from harness.scenario import Scenario, ScenarioError
from harness.scenario._validation import schema
from harness.session import Session
from harness.session._cli import add_arguments as serve_arguments
from harness.vocabulary import BASE_KINDS, SELF_COLLISION_POLICIES, RobotBase, SelfCollisionPolicy

from .conftest import DATA

ARM = DATA / "overlapping_arm.urdf"
PLUGIN_ARGS: tuple[str, ...] = (
    ()
    if any(ep.value == "harness.pytest_plugin" for ep in entry_points(group="pytest11"))
    else ("-p", "harness.pytest_plugin")
)


def _choices(add: object, dest: str) -> tuple[str, ...] | None:
    parser = argparse.ArgumentParser()
    add(parser)  # type: ignore[operator]
    for action in parser._actions:
        if action.dest == dest:
            return tuple(action.choices) if action.choices is not None else ()
    return None


def test_one_vocabulary_in_python_schema_and_cli():
    assert SELF_COLLISION_POLICIES == ("auto", "off", "on", "srdf")
    assert BASE_KINDS == ("fixed", "floating")
    assert get_args(SelfCollision) == SELF_COLLISION_POLICIES
    assert get_args(BaseKind) == BASE_KINDS
    robot = schema("scenario")["$defs"]["robot"]["properties"]
    assert tuple(robot["self_collision"]["enum"]) == SELF_COLLISION_POLICIES
    assert tuple(robot["base"]["enum"]) == BASE_KINDS
    assert robot["strict"]["type"] == "boolean"
    for add in (serve_arguments, check_arguments):
        assert _choices(add, "self_collision") == SELF_COLLISION_POLICIES
        assert _choices(add, "base") == BASE_KINDS
        assert _choices(add, "strict") == ()
    assert _choices(inspect_arguments, "strict") == ()
    with pytest.raises(ValueError, match=r"marker: unknown self_collision 'none' \(one of auto"):
        SelfCollisionPolicy.parse("none", "marker")
    with pytest.raises(ValueError, match=r"unknown base 'free' \(one of fixed, floating\)"):
        RobotBase.parse("free")
    # members are their strings: the Python API takes either
    assert load_robot(ARM, self_collision=SelfCollisionPolicy.OFF).self_collision.policy == "off"


def test_scenario_file_options_reach_the_loaded_world(tmp_path):
    from harness.scenario.world import build_world, plan_world

    (tmp_path / "arm.urdf").write_bytes(ARM.read_bytes())
    text = (
        "name: opts\nenvironment: {map: empty}\nrobots:\n"
        "  - {robot: arm.urdf, self_collision: 'off', base: floating, strict: true}\n"
    )
    path = tmp_path / "s.yaml"
    path.write_text(text)
    scenario = Scenario.load(path)
    spec = scenario.robots[0]
    assert (spec.self_collision, spec.base, spec.strict) == ("off", "floating", True)
    assert plan_world(scenario, tmp_path).robots[0].base == "floating"
    (view,) = build_world(scenario, tmp_path).robots
    assert view.self_collision.policy == "off"
    assert view.base == "floating"
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("'off'", "sometimes"))
    with pytest.raises(
        ScenarioError, match=r"robots\[0\]\.self_collision: .sometimes. is not one of"
    ):
        Scenario.load(bad)


def test_session_records_the_options_and_replay_rebuilds_the_same_model(tmp_path):
    path = tmp_path / "run.mcap"
    with Session(ARM, self_collision="on", base="floating", strict=True, record_to=path) as s:
        assert s.robot.self_collision.policy == "on"
        assert s.robot.base == "floating"
        sha = s.robot.sha256
        s.step(5)
    rec = Recording(path)
    assert json.loads(rec.metadata["self_collision"])["policy"] == "on"
    assert rec.metadata["base"] == "floating"
    rebuilt = rebuild_robot(rec)
    assert (rebuilt.self_collision.policy, rebuilt.base) == ("on", "floating")
    assert rebuilt.sha256 == sha
    # the defaults give another model: the options are what made it
    assert load_robot(ARM).sha256 != sha


def test_a_world_of_a_scenario_records_its_options_per_robot(tmp_path):
    from harness.models import RobotSpec

    path = tmp_path / "world.mcap"
    robots = [RobotSpec(ARM, namespace="a", self_collision="off", base="floating", strict=True)]
    with Session(robots=robots, record_to=path) as s:
        sha = s.world.sha256
        s.step(5)
    rec = Recording(path)
    (entry,) = json.loads(rec.metadata["robots"])
    assert entry["self_collision"]["policy"] == "off"
    assert entry["base"] == "floating"
    assert entry["strict"] is True
    assert rebuild_run(rec).sha256 == sha


def test_the_marker_takes_the_options_and_refuses_a_wrong_spelling(pytester):
    (pytester.path / "arm.urdf").write_bytes(ARM.read_bytes())
    pytester.makefile(
        ".yaml", cell="robots:\n  - {robot: arm.urdf, self_collision: 'off', base: floating}\n"
    )
    pytester.makepyfile(
        test_opts="""
        import pytest

        @pytest.mark.harness(robot="arm.urdf", self_collision="on", base="floating")
        def test_marker(harness_session):
            assert harness_session.robot.self_collision.policy == "on"
            assert harness_session.robot.base == "floating"

        @pytest.mark.harness(scenario="cell.yaml")
        def test_scenario(harness_session):
            assert harness_session.world.robots[0].self_collision.policy == "off"
            assert harness_session.world.robots[0].base == "floating"

        @pytest.mark.harness(robot="arm.urdf", self_collision="sometimes")
        def test_bad(harness_session):
            pass
        """
    )
    result = pytester.runpytest_inprocess(*PLUGIN_ARGS, "-p", "no:cacheprovider")
    result.assert_outcomes(passed=2, errors=1)
    result.stdout.fnmatch_lines(
        ["*harness option 'self_collision': unknown self_collision 'sometimes' (one of auto*"]
    )


def test_check_model_takes_the_options(capsys):
    assert main(["check-model", str(ARM), "--json", "--self-collision", "on"]) in (0, 1)
    report = json.loads(capsys.readouterr().out)
    assert report["self_collision"]["policy"] == "on"
    assert report["self_collision"]["origin"] == "argument"
    assert main(["inspect-model", str(ARM), "--strict", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["model"]
