"""An SRDF wherever a robot is given (issue 34, finding 7): ``--srdf`` on ``check-model`` and
``serve``, ``srdf=`` on :class:`harness.session.Session` and the pytest marker, ``srdf:`` per
robot in a scenario, each by path or ``package://`` (a MoveIt config package). Its
``<disable_collisions>`` pairs are ignored (reason ``"srdf"``); a missing file is one line."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from harness.cli import main
from harness.scenario import Scenario, ScenarioError

DATA = Path(__file__).resolve().parents[1] / "data"
DESCRIPTIONS = DATA / "descriptions"
FER = DESCRIPTIONS / "franka_description/robots/fer/fer.urdf.xacro"
FER_SRDF = DESCRIPTIONS / "fer_moveit_config/config/fer.srdf"
DEMO_SRDF = DATA / "models/demo_arm.srdf"
# pairs the SRDF disables that neither adjacency nor the start pose would
FER_SRDF_ONLY = {("fer_link0", "fer_link2"), ("fer_link3", "fer_link7"), ("fer_link4", "fer_link6")}
DEMO_SRDF_PAIRS = {("link0", "link2"), ("link5", "link7")}


def _srdf_pairs(ignored: object) -> set[tuple[str, str]]:
    return {(p[0], p[1]) for p in ignored if p[2] == "srdf"}  # type: ignore[attr-defined]


@pytest.mark.parametrize("srdf", [str(FER_SRDF), "package://fer_moveit_config/config/fer.srdf"])
def test_check_model_takes_the_moveit_config_srdf(capsys, monkeypatch, srdf):
    monkeypatch.chdir(DESCRIPTIONS)  # the package search starts here, as in a workspace
    code = main(["check-model", str(FER), "--robot-arg", "hand:=true", "--srdf", srdf, "--json"])
    report = json.loads(capsys.readouterr().out)
    assert report["error"] is None
    assert code == 0
    collision = report["self_collision"]
    assert (collision["policy"], collision["origin"]) == ("srdf", "srdf")
    assert _srdf_pairs(collision["ignored"]) >= FER_SRDF_ONLY


def test_check_model_without_srdf_keeps_those_pairs(capsys):
    main(["check-model", str(FER), "--robot-arg", "hand:=true", "--json"])
    report = json.loads(capsys.readouterr().out)
    assert not _srdf_pairs(report["self_collision"]["ignored"])


def test_a_missing_srdf_is_one_line(capsys):
    code = main(["check-model", "demo", "--srdf", "no/such.srdf"])
    out = capsys.readouterr().out.strip()
    assert code == 2
    assert "\n" not in out
    assert "no/such.srdf" in out
    assert "srdf" in out


def test_serve_takes_srdf_as_a_load_option():
    from harness.cli import _build_parser
    from harness.models._cli import load_options
    from harness.session import _cli

    parser, subparsers = _build_parser()
    _cli.add_arguments(subparsers["serve"])
    args = parser.parse_args(["serve", "--srdf", "package://fer_moveit_config/config/fer.srdf"])
    assert load_options(args)["srdf"] == "package://fer_moveit_config/config/fer.srdf"


def test_session_takes_srdf():
    from harness.session import Session

    with Session(robot="demo", srdf=DEMO_SRDF, clock="lockstep") as session:
        report = session.robot.self_collision
        assert _srdf_pairs(report.as_dict()["ignored"]) == DEMO_SRDF_PAIRS


def test_scenario_robot_srdf_by_path_and_package(tmp_path):
    from harness.scenario.world import plan_world

    package = tmp_path / "demo_moveit_config"
    (package / "config").mkdir(parents=True)
    (package / "package.xml").write_text(
        "<package format='3'><name>demo_moveit_config</name></package>"
    )
    shutil.copy(DEMO_SRDF, package / "config" / "demo_arm.srdf")
    shutil.copy(DEMO_SRDF, tmp_path / "arm.srdf")
    for srdf in ("arm.srdf", "package://demo_moveit_config/config/demo_arm.srdf"):
        scenario = Scenario.from_mapping(
            {"robots": [{"robot": "demo", "srdf": srdf}]}, base_dir=tmp_path
        )
        assert Path(scenario.robots[0].srdf).is_file()  # type: ignore[arg-type]
        plan = plan_world(scenario, tmp_path / "world")
        assert plan.robots[0].srdf == scenario.robots[0].srdf


def test_scenario_robot_missing_srdf_names_the_key(tmp_path):
    with pytest.raises(ScenarioError) as info:
        Scenario.from_mapping(
            {"robots": [{"robot": "demo", "srdf": "gone.srdf"}]}, base_dir=tmp_path
        )
    assert "robots[0].srdf" in str(info.value)
    assert "gone.srdf" in str(info.value)
