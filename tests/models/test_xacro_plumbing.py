"""A xacro robot with arguments wherever a robot is named: the pytest marker, scenario files
(``robot_args:``, ``package://`` references), ``harness serve --robot-arg``."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from harness.recording import Recording
from harness.scenario import Scenario
from harness.scenario.errors import ScenarioError
from harness.scenario.world import build_world, plan_world

DESCRIPTIONS = Path(__file__).resolve().parents[1] / "data" / "descriptions"
PLUGIN_ARGS: tuple[str, ...] = (
    ()
    if any(ep.value == "harness.pytest_plugin" for ep in entry_points(group="pytest11"))
    else ("-p", "harness.pytest_plugin")
)

SCENARIO = """
name: ur-cell
environment: {map: empty}
robots:
  - robot: package://ur_description/urdf/ur_mocked.urdf.xacro
    robot_args: {ur_type: ur10e, name: ur, safety_limits: false}
    initial_joint_positions: {elbow_joint: 0.5}
"""


def test_marker_and_scenario_file_load_a_description_package(pytester):
    shutil.copytree(DESCRIPTIONS / "ur_description", pytester.path / "ur_description")
    pytester.makefile(".yaml", cell=SCENARIO)
    pytester.makepyfile(
        test_robot="""
        import pytest

        @pytest.mark.harness(
            robot="package://ur_description/urdf/ur_mocked.urdf.xacro",
            robot_args={"ur_type": "ur3e", "name": "ur"},
        )
        def test_marker(harness_session):
            assert harness_session.robot.description.xacro.args["ur_type"] == "ur3e"
            assert harness_session.sim.data.qpos[1] == pytest.approx(-1.57)
            harness_session.step(10)

        @pytest.mark.harness(scenario="cell.yaml")
        def test_scenario(harness_session):
            assert dict(harness_session.world.robots[0].description.xacro.args) == {
                "ur_type": "ur10e", "name": "ur", "safety_limits": "false"
            }
            harness_session.step(10)
        """
    )
    result = pytester.runpytest_inprocess(
        *PLUGIN_ARGS, "-p", "no:cacheprovider", "--harness-keep-recordings=always"
    )
    result.assert_outcomes(passed=2)
    folder = pytester.path / ".harness" / "recordings" / "test_robot"
    with Recording(folder / "test_marker" / "test_marker.mcap") as rec:
        assert json.loads(rec.metadata["robot_args"])["ur_type"] == "ur3e"
        assert rec.metadata["robot_xacro"].endswith("ur_mocked.urdf.xacro")
    with Recording(folder / "test_scenario" / "test_scenario.mcap") as rec:  # a world
        (entry,) = json.loads(rec.metadata["robots"])
        assert entry["robot_args"]["ur_type"] == "ur10e"
        assert entry["xacro"].endswith("ur_mocked.urdf.xacro")


def test_scenario_robot_args_reach_the_world(tmp_path):
    shutil.copytree(DESCRIPTIONS / "ur_description", tmp_path / "ur_description")
    path = tmp_path / "cell.yaml"
    path.write_text(SCENARIO)
    scenario = Scenario.load(path)
    assert scenario.robots[0].robot == tmp_path / "ur_description/urdf/ur_mocked.urdf.xacro"
    plan = plan_world(scenario, tmp_path)
    assert dict(plan.robots[0].robot_args) == {
        "ur_type": "ur10e",
        "name": "ur",
        "safety_limits": "false",
    }
    world = build_world(scenario, tmp_path)
    assert world.robots[0].home["elbow_joint"] == pytest.approx(0.5)  # the scenario's
    assert world.robots[0].home["shoulder_lift_joint"] == pytest.approx(-1.57)  # ros2_control


def test_scenario_names_a_missing_package_and_bad_arguments(tmp_path):
    path = tmp_path / "cell.yaml"
    path.write_text(SCENARIO.replace("ur_description", "gone_description", 1))
    with pytest.raises(ScenarioError, match=r"robots\[0\]\.robot.*unknown package"):
        Scenario.load(path)
    path.write_text(SCENARIO.replace("ur_type: ur10e", "ur_type: [ur10e]"))
    with pytest.raises(ScenarioError, match="robot_args"):
        Scenario.load(path)


@pytest.mark.slow
def test_serve_takes_robot_args(tmp_path):
    entry = DESCRIPTIONS / "ur_description" / "urdf" / "ur_mocked.urdf.xacro"
    process = subprocess.Popen(
        [sys.executable, "-m", "harness", "serve", "--robot", str(entry), "--port", "0",
         "--clock", "lockstep", "--robot-arg", "ur_type:=ur5e", "--robot-arg", "name:=cell_ur"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp_path,
    )  # fmt: skip
    try:
        assert process.stdout is not None
        first = process.stdout.readline()
    finally:
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=60)
    assert "robot cell_ur (position)" in first, first + err
    assert process.returncode == 0, err
