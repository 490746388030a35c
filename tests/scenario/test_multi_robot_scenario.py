"""Scenarios of several robots: namespaces (given or derived from the model names), poses
through load_world, each robot's subscribers under its namespace, `harness run` end to end with
a client driving one of two robots, and the recording replayed at both levels."""

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from harness import cli
from harness.recording import Recording
from harness.replay import verify
from harness.replay.source import rebuild_run
from harness.scenario import Scenario
from harness.scenario.world import build_world, plan_world, robot_namespaces
from tests.scenario.scenario_testlib import DATA

LOCKSTEP = DATA / "clients" / "lockstep.py"
TWO_LINK = DATA / "robots" / "two_link.urdf"


def _original_two_robots(tmp_path: Path, **extra) -> Path:
    """The original scene format: robots[] without names, one subscriber topic each."""
    shutil.copy(TWO_LINK, tmp_path / "two_link.urdf")
    robot = {
        "robot": "two_link.urdf",
        "subscribers": [{"type": "JointStateSubscriber", "topic": "/arm/cmd"}],
        "modes": [{"type": "JointController", "mode": "position"}],
    }
    doc = {
        "environment": {"map": "empty"},
        "robots": [
            {**robot, "position": [-0.5, 0, 0]},
            {**robot, "position": [0.5, 0, 0], "orientation": [0, 0, 1.0]},
        ],
        "ros": {"bridge": {"ip": "127.0.0.1", "port": "9090"}},
        "duration": 0.5,
        "clock": {"mode": "lockstep"},
        **extra,
    }
    path = tmp_path / "two.json"
    path.write_text(json.dumps(doc))
    return path


def test_namespaces_are_given_names_or_unique_model_names(tmp_path):
    doc = {
        "robots": [
            {"robot": "demo"},
            {"robot": "demo", "name": "demo_arm"},
            {"robot": "demo", "position": [1, 0, 0]},
        ]
    }
    path = tmp_path / "three.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert robot_namespaces(Scenario.load(path)) == ("demo_arm_1", "demo_arm", "demo_arm_2")
    one = tmp_path / "one.yaml"
    one.write_text(yaml.safe_dump({"robots": [{"robot": "demo", "name": "arm"}]}))
    assert robot_namespaces(Scenario.load(one)) == ("",)  # a lone robot keeps global topics


def test_the_world_plan_places_each_robot_through_load_world(tmp_path):
    scenario = Scenario.load(_original_two_robots(tmp_path))
    plan = plan_world(scenario, tmp_path / "iteration")
    assert [r.namespace for r in plan.robots] == ["two_link", "two_link_1"]
    assert plan.command_topics == {"two_link": "arm/cmd", "two_link_1": "arm/cmd"}
    world = build_world(scenario, tmp_path / "iteration")
    left, right = world.robots
    assert left.placement.xyz == pytest.approx((-0.5, 0.0, 0.0))
    assert right.placement.quat == pytest.approx((np.cos(0.5), 0.0, 0.0, np.sin(0.5)))
    data_x = world.model.body("two_link_1/base").pos
    assert data_x[0] == pytest.approx(0.5)


@pytest.mark.slow
def test_harness_run_drives_one_of_two_robots_over_its_namespace(tmp_path):
    client = [sys.executable, str(LOCKSTEP), "0.5", "shoulder", "/two_link_1/arm/cmd"]
    path = _original_two_robots(tmp_path, client={"command": client, "readiness_timeout": 20})
    out = tmp_path / "out"
    assert cli.main(["run", str(path), "--out", str(out)]) == 0
    (result,) = json.loads((out / "results.json").read_text())["results"]
    assert result["steps"] == 250
    traces = {t["joint"]: t for t in result["traces"]["joints"]}
    assert set(traces) == {"two_link/shoulder", "two_link_1/shoulder"}
    moved = np.array(traces["two_link_1/shoulder"]["position"])
    held = np.array(traces["two_link/shoulder"]["position"])
    assert np.ptp(moved) > 0.3
    assert np.ptp(held) < 1e-3
    recording = Path(result["recording"])
    with Recording(recording) as rec:
        assert {"/two_link/joint_states", "/two_link_1/joint_states"} <= set(rec.topics)
        frames = [f for f in rec.bridge_frames() if f.direction == 0 and f.op == "publish"]
        assert {f.topic for f in frames} == {"/two_link_1/arm/cmd"}
        robots = json.loads(rec.metadata["robots"])
        assert [r["namespace"] for r in robots] == ["two_link", "two_link_1"]
        assert robots[0]["pose"][:3] == [-0.5, 0.0, 0.0]
        assert rebuild_run(rec).sha256 == rec.metadata["model_sha256"]
    assert verify(recording).reproduced
    full = verify(recording, level="full")
    assert full.reproduced, full.format()
