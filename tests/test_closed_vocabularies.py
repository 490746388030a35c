"""Closed vocabularies (issue 16): ``ClockMode``, ``LimitPolicy`` and ``Actuation`` parsed at
every boundary (marker, CLI, scenario file, Session) from one enum each; the JSON Schema's
enums are the vocabulary's; the whole-run switch is an actuation, not a control mode."""

from __future__ import annotations

import json
from importlib import resources
from importlib.metadata import entry_points
from pathlib import Path

import pytest

import harness.events
import harness.pytest_plugin
import harness.recording
import harness.replay
import harness.session
import harness.testing  # noqa: F401  (loaded before the inner pytest runs, as tests/plugin do)
from harness import cli
from harness.recording import Recording
from harness.replay import verify
from harness.scenario import Scenario, ScenarioError
from harness.scenario._validation import schema
from harness.session import SessionConfigError
from harness.session.core import CoreOptions
from harness.sim import ControlConfigError, Simulation
from harness.vocabulary import (
    ACTUATIONS,
    CLOCK_MODES,
    CONTROL_MODE_INPUTS,
    LIMIT_POLICIES,
    SCHEMA_ENUMS,
    Actuation,
    ClockMode,
    LimitPolicy,
    apply_schema_enums,
)

ROOT = Path(__file__).resolve().parents[1]
TWO_ARMS = ROOT / "recordings" / "scenarios" / "two-arms.mcap"
PLUGIN_ARGS = (
    ()
    if any(ep.value == "harness.pytest_plugin" for ep in entry_points(group="pytest11"))
    else ("-p", "harness.pytest_plugin")
)


def _scenario(**sections: object) -> Scenario:
    return Scenario.from_mapping({"robots": [{"robot": "demo"}], **sections})


# -- the enums ------------------------------------------------------------------------------


def test_each_vocabulary_parses_its_spellings_and_names_where_a_bad_one_was():
    assert ClockMode.parse("fast") is ClockMode.FAST
    assert LimitPolicy.parse("allow") is LimitPolicy.ALLOW
    assert Actuation.parse("servo") is Actuation.SERVO
    # the deprecated whole-run spellings are input aliases of servo, flagged for a warning
    assert Actuation.parse("dynamic") is Actuation.parse("position") is Actuation.SERVO
    assert Actuation.deprecated("dynamic")
    assert not Actuation.deprecated("servo")
    assert (CLOCK_MODES, LIMIT_POLICIES, ACTUATIONS) == (
        ("lockstep", "fast", "realtime"),
        ("clamp", "allow"),
        ("kinematic", "servo"),
    )
    with pytest.raises(ValueError, match=r"^marker: unknown clock mode 'wall' \(one of lockstep"):
        ClockMode.parse("wall", "marker")
    with pytest.raises(ValueError, match=r"unknown limit policy 'teleport' \(one of clamp, allow"):
        LimitPolicy.parse("teleport")
    with pytest.raises(ValueError, match=r"unknown actuation 'velocity' \(one of kinematic, servo"):
        Actuation.parse("velocity")
    # members are their strings: formatted, compared, hashed, JSON-encoded
    assert f"{ClockMode.FAST}" == "fast"
    assert {"allow": 1}[LimitPolicy.ALLOW] == 1
    assert json.dumps({"clock": ClockMode.REALTIME}) == '{"clock": "realtime"}'


def test_the_shipped_schema_lists_exactly_the_vocabularies():
    text = resources.files("harness.scenario").joinpath("scenario.schema.json").read_text()
    shipped = json.loads(text)
    for path, spellings in SCHEMA_ENUMS["scenario"].items():
        node = shipped
        for key in path:
            node = node[key]
        assert node["enum"] == list(spellings), path  # the file editors see is in sync
    assert apply_schema_enums("scenario", json.loads(text)) == shipped
    assert schema("scenario")["$defs"]["controller"]["properties"]["mode"]["enum"] == list(
        CONTROL_MODE_INPUTS
    )
    with pytest.raises(KeyError):  # a moved property fails loudly instead of going stale
        apply_schema_enums("scenario", {"properties": {}})


# -- scenario file --------------------------------------------------------------------------


def test_scenario_clock_and_limit_policy_become_members():
    assert _scenario().clock is None  # no section: each route applies its own default
    assert _scenario(clock={"mode": "lockstep"}).clock.mode is ClockMode.LOCKSTEP
    with pytest.raises(ScenarioError) as info:
        _scenario(clock={"mode": "wallclock"})
    (problem,) = info.value.problems
    assert problem == (
        "<scenario>: clock.mode: \"wallclock\" is not one of 'lockstep', 'fast', 'realtime'"
    )
    for key in ("kinematic_limits", "beyond_limits"):  # the earlier spelling is still read
        robot = {"robot": "demo", "modes": [{"mode": "dynamic", key: "allow"}]}
        controller = Scenario.from_mapping({"robots": [robot]}).robots[0].modes[0]
        assert controller.kinematic_limits is LimitPolicy.ALLOW
        assert controller.mode == "position"
    bad = {"robot": "demo", "modes": [{"mode": "kinematic", "kinematic_limits": "free"}]}
    with pytest.raises(ScenarioError, match=r"kinematic_limits: \"free\" is not one of 'clamp'"):
        Scenario.from_mapping({"robots": [bad]})


# -- Session options and the simulation ------------------------------------------------------


def test_core_options_and_simulation_parse_to_members(demo_robot):
    options = CoreOptions(clock="realtime", kinematic_limits="allow")  # type: ignore[arg-type]
    assert options.clock is ClockMode.REALTIME
    assert options.kinematic_limits is LimitPolicy.ALLOW
    assert CoreOptions().kinematic_limits is LimitPolicy.CLAMP
    with pytest.raises(SessionConfigError, match="clock must be one of lockstep, fast, realtime"):
        CoreOptions(clock="wallclock")  # type: ignore[arg-type]
    with pytest.raises(SessionConfigError) as info:
        CoreOptions(kinematic_limits="teleport")  # type: ignore[arg-type]
    assert str(info.value) == (
        "kinematic_limits: unknown limit policy 'teleport' (one of clamp, allow)"
    )
    assert Simulation(demo_robot, kinematic_limits="allow").kinematic_limits is LimitPolicy.ALLOW
    with pytest.raises(ControlConfigError, match="unknown limit policy 'beyond'"):
        Simulation(demo_robot, kinematic_limits="beyond")


@pytest.fixture(scope="module")
def demo_robot():
    from harness.models import load_robot

    return load_robot("demo", control="kinematic")


def test_a_session_takes_the_spellings_and_the_dynamic_alias(demo_robot):
    from harness.session import Session

    with Session("demo", mode="dynamic", clock="lockstep", kinematic_limits="allow") as session:
        assert session.clock is ClockMode.LOCKSTEP
        assert session.core.options.kinematic_limits is LimitPolicy.ALLOW
        assert session.sim.kinematic_limits is LimitPolicy.ALLOW
        assert set(session.robot.control.values()) == {"position"}


def test_an_existing_recording_still_loads_and_replays():
    """Recordings made before the enums (metadata ``kinematic_limits: clamp``, ``clock:
    fast``) read back as members and still replay bit for bit."""
    recording = Recording(TWO_ARMS)
    try:
        metadata = recording.all_metadata["harness"]
    finally:
        recording.close()
    assert (metadata["kinematic_limits"], metadata["clock"]) == ("clamp", "fast")
    options = CoreOptions.from_metadata(metadata)
    assert options.kinematic_limits is LimitPolicy.CLAMP
    assert options.clock is ClockMode.FAST
    assert verify(TWO_ARMS).reproduced


# -- CLI ------------------------------------------------------------------------------------


def test_serve_choices_come_from_the_vocabularies(capsys):
    with pytest.raises(SystemExit):
        cli.main(["serve", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--kinematic-limits {clamp,allow}" in text
    assert "--clock {lockstep,fast,realtime}" in text
    for option, value in (("--clock", "wallclock"), ("--kinematic-limits", "teleport")):
        with pytest.raises(SystemExit) as info:
            cli.main(["serve", option, value])
        assert info.value.code == 2
        assert f"invalid choice: '{value}'" in capsys.readouterr().err


def test_replay_actuation_and_its_deprecated_mode_spelling(tmp_path, capsys):
    with pytest.raises(SystemExit):
        cli.main(["replay", "--help"])
    assert "--actuation {kinematic,servo}" in " ".join(capsys.readouterr().out.split())
    with pytest.raises(SystemExit):  # the new option takes no control mode
        cli.main(["replay", str(TWO_ARMS), "--actuation", "position"])
    assert "invalid choice: 'position'" in capsys.readouterr().err
    old, new = tmp_path / "old.json", tmp_path / "new.json"
    cli.main(["replay", str(TWO_ARMS), "--mode", "dynamic", "--report", str(old)])
    err = capsys.readouterr().err
    warning = [line for line in err.splitlines() if "deprecated" in line]
    assert warning == ["harness replay: --mode is deprecated, use --actuation servo"]
    cli.main(["replay", str(TWO_ARMS), "--actuation", "servo", "--report", str(new)])
    assert "deprecated" not in capsys.readouterr().err
    old_report, new_report = json.loads(old.read_text()), json.loads(new.read_text())
    assert old_report["actuation"] == new_report["actuation"] == "servo"
    assert old_report["findings"] == new_report["findings"]


def test_resimulate_warns_on_a_control_mode_spelling():
    from harness.replay import resimulate
    from harness.replay.errors import LevelUnavailableError

    with pytest.warns(DeprecationWarning, match=r"actuation 'dynamic' is deprecated: use 'servo'"):
        report = resimulate(TWO_ARMS, "dynamic")
    assert report.actuation is Actuation.SERVO
    with pytest.raises(LevelUnavailableError, match="unknown actuation 'effort'"):
        resimulate(TWO_ARMS, "effort")


# -- the pytest marker and options ----------------------------------------------------------

_MARKED = """
import pytest
from harness.vocabulary import ClockMode, LimitPolicy

@pytest.mark.harness(clock="fast", kinematic_limits="allow", mode="dynamic")
def test_spelled(harness_session, request):
    assert harness_session.clock is ClockMode.FAST
    assert harness_session.core.options.kinematic_limits is LimitPolicy.ALLOW
    suite = request.config.getoption("harness_actuation") or request.config.getoption(
        "harness_mode"
    )
    expected = "kinematic" if suite == "kinematic" else "position"
    assert set(harness_session.robot.control.values()) == {expected}

@pytest.mark.harness(clock="wallclock")
def test_bad_clock(harness_session):
    pass

@pytest.mark.harness(kinematic_limits="teleport")
def test_bad_policy(harness_session):
    pass
"""


def test_marker_and_suite_switch_parse_through_the_vocabularies(pytester):
    pytester.makepyfile(test_marked=_MARKED)

    def run(*args: str) -> pytest.RunResult:
        return pytester.runpytest_inprocess(*PLUGIN_ARGS, "-p", "no:cacheprovider", *args)

    result = run()
    result.assert_outcomes(passed=1, errors=2)
    text = result.stdout.str()
    assert "harness option 'clock': unknown clock mode 'wallclock' (one of lockstep, fast" in text
    assert "harness option 'kinematic_limits': unknown limit policy 'teleport'" in text
    run("--harness-actuation=kinematic", "-k", "spelled").assert_outcomes(passed=1)
    old = run("--harness-mode=kinematic", "-k", "spelled")
    old.assert_outcomes(passed=1)
    assert "--harness-mode / harness_mode is deprecated: use --harness-actuation kinematic" in (
        old.stdout.str()
    )
    clash = run("--harness-mode=dynamic", "--harness-actuation=kinematic", "-k", "spelled")
    assert clash.ret == pytest.ExitCode.USAGE_ERROR
    assert "--harness-mode dynamic and --harness-actuation kinematic disagree" in (
        clash.stderr.str()
    )
