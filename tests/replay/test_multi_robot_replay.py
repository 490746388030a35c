"""Replay of a recording of two robots: the world is rebuilt from the recording (robots,
namespaces, poses, control modes, initial positions, objects, scene), verify is bit-exact at
both levels, resimulate runs in both modes."""

from __future__ import annotations

import json

import pytest

from harness.models import RobotSpec, WorldObject
from harness.recording import Recording
from harness.replay import resimulate, verify
from harness.replay.errors import ModelAttachmentError
from harness.replay.source import rebuild_robot, rebuild_run, rebuild_world
from harness.session import Session


@pytest.fixture(scope="module")
def two_robot_recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("multi") / "two.mcap"
    robots = [
        RobotSpec(
            "demo",
            namespace="left",
            pose=[0.0, -0.45, 0.0, 0.0, 0.0, 0.3],
            initial_positions={"joint1": 0.2},
        ),
        RobotSpec("demo", namespace="right", pose=[0.0, 0.45, 0.0], control="kinematic"),
    ]
    objects = [WorldObject("crate", "box", (0.05, 0.05, 0.05), pose=[0.5, 0.0, 0.05], mass=0.2)]
    with Session(robots=robots, objects=objects, scene="empty", record_to=path) as session:
        session.step(20)
        session.set_positions({"left/joint2": -0.3, "right/joint1": -0.5})
        session.step(100)
        session.set_positions({"right/joint1": -0.2})
        session.step(80)
    return path


def test_the_metadata_describes_every_robot_and_object(two_robot_recording):
    with Recording(two_robot_recording) as rec:
        robots = json.loads(rec.metadata["robots"])
        objects = json.loads(rec.metadata["objects"])
        modes = json.loads(rec.metadata["control_modes"])
    assert [r["namespace"] for r in robots] == ["left", "right"]
    assert robots[0]["source"] == "model/left/demo_arm.urdf"
    assert robots[0]["initial_positions"] == {"joint1": 0.2}
    assert robots[1]["pose"] == [0.0, 0.45, 0.0, 1.0, 0.0, 0.0, 0.0]
    assert robots[1]["control"]["joint1"] == "kinematic"
    assert modes["left/joint1"] == "position"
    assert modes["right/joint1"] == "kinematic"
    assert objects == [
        {
            "mass": 0.2,
            "name": "crate",
            "pose": [0.5, 0.0, 0.05],
            "rgba": None,
            "shape": "box",
            "size": [0.05, 0.05, 0.05],
        }
    ]


def test_the_world_is_rebuilt_from_the_recording(two_robot_recording):
    with Recording(two_robot_recording) as rec:
        world = rebuild_world(rec)
        assert world.sha256 == rec.metadata["model_sha256"]
        assert rebuild_run(rec).sha256 == world.sha256
        with pytest.raises(ModelAttachmentError, match="rebuild_world"):
            rebuild_robot(rec)
        kinematic = rebuild_world(rec, "kinematic")
    assert [v.namespace for v in world.robots] == ["left", "right"]
    assert world.robot("left").placement.xyz == pytest.approx((0.0, -0.45, 0.0))
    assert world.robot("left").home["joint1"] == 0.2
    assert world.model.body("crate").id > 0
    assert set(kinematic.control.values()) == {"kinematic"}


def test_verify_reproduces_it_at_both_levels(two_robot_recording):
    physics = verify(two_robot_recording)
    assert physics.reproduced, physics.format()
    full = verify(two_robot_recording, level="full")
    assert full.reproduced, full.format()


@pytest.mark.parametrize("mode", ["kinematic", "servo"])
def test_resimulate_runs_a_two_robot_recording(two_robot_recording, mode):
    report = resimulate(two_robot_recording, mode)
    names = [j.joint for j in report.resimulated.joints]
    assert "left/joint1" in names
    assert "right/joint1" in names
    assert report.steps == 200
    by_name = {j.joint: j for j in report.recorded.joints}
    # The recorded run tracked its kinematic targets exactly.
    assert by_name["right/joint1"].max_tracking_error == 0.0
