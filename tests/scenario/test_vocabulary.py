"""One vocabulary everywhere (issue 15): control modes with ``dynamic`` as an input alias of
``position``, and one validator (the JSON Schema) for the logging section in both spellings
of the Seq API key."""

import json

import pytest

from harness import cli
from harness.events import SeqSink, SinkSpec
from harness.models import load_robot
from harness.scenario import Scenario, ScenarioError, load_run_file
from harness.vocabulary import CONTROL_MODE_INPUTS, ControlMode


def _scenario(destination, mode="position"):
    return Scenario.from_mapping(
        {
            "robots": [{"robot": "demo", "modes": [{"mode": mode}]}],
            "logging": {"enable": True, "destination": destination},
        }
    )


def test_api_key_and_apikey_give_the_same_seq_sink():
    seq = {"type": "Seq", "endpoint": "http://127.0.0.1:9"}
    ours = _scenario({**seq, "api_key": "secret"}).logging
    original = _scenario({**seq, "apiKey": "secret"}).logging
    assert ours == original
    assert ours.destinations == (
        SinkSpec("seq", (("endpoint", "http://127.0.0.1:9"), ("api_key", "secret"))),
    )
    sinks = [*ours.create_sinks(), *original.create_sinks()]
    try:
        assert all(isinstance(s, SeqSink) for s in sinks)
        assert {s.url for s in sinks} == {"http://127.0.0.1:9/ingest/clef"}
    finally:
        for sink in sinks:
            sink.close()


def test_the_logging_section_is_refused_by_one_validator_with_its_key_path():
    with pytest.raises(ScenarioError) as info:
        _scenario({"type": "Seq", "api_key": "a", "apiKey": "b"})
    (problem,) = info.value.problems
    assert "logging.destination: give only one of 'api_key' and 'apiKey'" in problem
    with pytest.raises(ScenarioError, match=r"logging\.destination\.apikey: unknown key"):
        _scenario({"type": "Seq", "apikey": "a"})


def test_dynamic_is_position_in_every_layer():
    assert ControlMode.parse("dynamic") is ControlMode.POSITION
    assert set(CONTROL_MODE_INPUTS) == {"kinematic", "position", "velocity", "effort", "dynamic"}
    with pytest.raises(ValueError, match=r"marker: unknown control mode 'servo' \(one of "):
        ControlMode.parse("servo", "marker")
    scenario = _scenario({"type": "Logging"}, mode="dynamic")
    assert scenario.robots[0].modes[0].mode is ControlMode.POSITION
    robot = load_robot("demo", control="dynamic")
    assert set(robot.control.values()) == {ControlMode.POSITION}
    assert robot.sha256 == load_robot("demo", control="position").sha256


def test_serve_and_replay_accept_the_same_spellings(capsys):
    for command in ("serve", "replay"):
        with pytest.raises(SystemExit):
            cli.main([command, "--help"])
        text = capsys.readouterr().out
        assert "dynamic" in text
        assert "position" in text
    with pytest.raises(SystemExit) as info:
        cli.main(["serve", "--mode", "servo"])
    assert info.value.code == 2
    assert "invalid choice: 'servo'" in capsys.readouterr().err


def test_runner_wall_timeout_in_one_spelling_at_a_time(tmp_path):
    (tmp_path / "s.yaml").write_text("robots: [{robot: demo}]\n")
    sim = {"scenario": "s.yaml", "command": "true", "wall_timeout": 5, "wallTimeout": 6}
    (tmp_path / "run.json").write_text(json.dumps({"simulations": [sim]}))
    with pytest.raises(ScenarioError, match=r"give only one of 'wall_timeout' and 'wallTimeout'"):
        load_run_file(tmp_path / "run.json")


def test_kinematic_limits_is_spelled_as_in_session_marker_and_cli():
    for key in ("kinematic_limits", "beyond_limits"):
        doc = {"robots": [{"robot": "demo", "modes": [{"mode": "kinematic", key: "allow"}]}]}
        assert Scenario.from_mapping(doc).robots[0].modes[0].kinematic_limits == "allow"
    both = {"mode": "kinematic", "kinematic_limits": "allow", "beyond_limits": "clamp"}
    with pytest.raises(ScenarioError, match="give only one of 'kinematic_limits' and 'beyond_l"):
        Scenario.from_mapping({"robots": [{"robot": "demo", "modes": [both]}]})
