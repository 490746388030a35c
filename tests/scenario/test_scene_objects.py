"""A scenario's objects are :class:`harness.models.WorldObject` records: their orientation
reaches the generated scene as URDF roll-pitch-yaw; a bad entry is one line naming file and
object."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from harness.models import RobotSpec, WorldObject, load_world
from harness.models.description import Pose
from harness.scenario import Scenario, ScenarioError
from harness.scenario.world import scene_for

TWO_LINK = Path(__file__).parents[1] / "data" / "scenario" / "robots" / "two_link.urdf"


def test_object_orientation_is_fixed_axis_roll_pitch_yaw(tmp_path):
    rpy = [0.3, -0.2, 1.1]
    scenario = Scenario.from_mapping(
        {
            "robots": [{"robot": str(TWO_LINK)}],
            "environment": {"map": "empty"},
            "objects": [
                {
                    "name": "crate",
                    "shape": "box",
                    "size": [0.05, 0.05, 0.05],
                    "position": [0.3, 0.1, 1.0],
                    "orientation": rpy,
                }
            ],
        }
    )
    model = mujoco.MjModel.from_xml_path(str(scene_for(scenario, tmp_path)))
    expected = np.zeros(4)
    # Independent oracle: MuJoCo's own Euler conversion, extrinsic x then y then z.
    mujoco.mju_euler2Quat(expected, np.array(rpy), "XYZ")
    crate = model.body("crate")
    np.testing.assert_allclose(crate.pos, [0.3, 0.1, 1.0])
    np.testing.assert_allclose(crate.quat, expected, atol=1e-6)  # XML keeps ~7 digits


def test_objects_are_world_objects_posed_by_position_and_orientation(tmp_path):
    scenario = Scenario.from_mapping(
        {
            "robots": [{"robot": "demo"}],
            "objects": [
                {
                    "name": "post",
                    "shape": "cylinder",
                    "size": [0.02, 0.3],
                    "position": [0.6, -0.3, 0.3],
                },
                {
                    "name": "crate",
                    "shape": "box",
                    "size": [0.05, 0.05, 0.05],
                    "position": [0.3, 0.1, 1.0],
                    "orientation": [0.0, 0.0, 0.5],
                    "mass": 0.2,
                    "rgba": [1, 0, 0, 1],
                },
            ],
        }
    )
    post, crate = scenario.objects
    assert post == WorldObject("post", "cylinder", (0.02, 0.3), pose=Pose((0.6, -0.3, 0.3)))
    assert crate == WorldObject(
        "crate",
        "box",
        (0.05, 0.05, 0.05),
        pose=Pose.from_xyz_rpy((0.3, 0.1, 1.0), (0.0, 0.0, 0.5)),
        mass=0.2,
        rgba=(1.0, 0.0, 0.0, 1.0),
    )
    # the scenario's objects load as load_world(objects=...) loads them
    world = load_world([RobotSpec("demo")], objects=scenario.objects)
    model = mujoco.MjModel.from_xml_path(str(scene_for(scenario, tmp_path)))
    for name in ("post", "crate"):
        np.testing.assert_allclose(model.body(name).pos, world.model.body(name).pos)
        np.testing.assert_allclose(model.body(name).quat, world.model.body(name).quat, atol=1e-6)
        np.testing.assert_allclose(model.geom(name).size, world.model.geom(name).size)
    assert world.model.joint("crate_joint").type == model.joint("crate_joint").type


@pytest.mark.parametrize(
    ("entry", "fragment"),
    [
        (
            {"name": "pill", "shape": "capsule", "size": [0.02, 0.1]},
            """objects[0].shape: "capsule" is not one of 'box', 'sphere', 'cylinder'""",
        ),
        (
            {"name": "ball", "shape": "sphere", "size": [0.1, 0.2]},
            "objects[0].size: [0.1, 0.2] needs 1 number(s) for a sphere",
        ),
        (
            {"name": "ball", "shape": "sphere", "size": [-0.1]},
            "objects[0].size[0]: -0.1 must be greater than 0",
        ),
    ],
)
def test_a_bad_object_is_one_line_naming_the_file_and_the_object(tmp_path, entry, fragment):
    path = tmp_path / "objects.yaml"
    path.write_text(yaml.safe_dump({"robots": [{"robot": "demo"}], "objects": [entry]}))
    with pytest.raises(ScenarioError) as info:
        Scenario.load(path)
    (problem,) = info.value.problems
    assert problem.startswith(f"{path}: ")
    assert fragment in problem
    assert "\n" not in problem


def test_object_friction_reaches_the_scene_and_the_recording(tmp_path):
    """``friction`` (sliding, torsional, rolling; those left out keep MuJoCo's defaults) is the
    object geom's in the generated scene, and a world rebuilt from a recording's metadata has
    it too."""
    from types import SimpleNamespace

    from harness.recording.describe import world_metadata

    scenario = Scenario.from_mapping(
        {
            "robots": [{"robot": str(TWO_LINK)}],
            "environment": {"map": "empty"},
            "objects": [
                {"name": "puck", "shape": "cylinder", "size": [0.05, 0.01], "mass": 0.1,
                 "position": [0.5, 0.0, 0.02], "friction": [0.3]},
                {"name": "pad", "shape": "box", "size": [0.1, 0.1, 0.01],
                 "position": [-0.5, 0.0, 0.01], "friction": [0.9, 0.02, 0.003]},
                {"name": "plain", "shape": "sphere", "size": [0.02], "position": [0, 0.5, 0.02]},
            ],
        }
    )  # fmt: skip
    model = mujoco.MjModel.from_xml_path(str(scene_for(scenario, tmp_path)))
    np.testing.assert_allclose(model.geom("puck").friction, [0.3, 0.005, 0.0001])
    np.testing.assert_allclose(model.geom("pad").friction, [0.9, 0.02, 0.003])
    np.testing.assert_allclose(model.geom("plain").friction, [1.0, 0.005, 0.0001])
    no_robots = SimpleNamespace(robots=[])
    listed = yaml.safe_load(world_metadata(no_robots, None, scenario.objects)["objects"])
    assert [o.get("friction") for o in listed] == [[0.3], [0.9, 0.02, 0.003], None]
    assert "friction" not in listed[2]  # a run without it keeps its metadata as it was


@pytest.mark.parametrize(
    ("friction", "expected"),
    [
        ([-0.1], "objects[0].friction[0]: -0.1 must be at least 0"),
        ([1, 2, 3, 4], "objects[0].friction: [1, 2, 3, 4] has the wrong length"),
        ([], "objects[0].friction: [] has the wrong length"),
    ],
)
def test_a_bad_object_friction_is_one_line(friction, expected):
    with pytest.raises(ScenarioError) as info:
        Scenario.from_mapping(
            {
                "robots": [{"robot": "demo"}],
                "objects": [{"name": "b", "shape": "sphere", "size": [0.02], "friction": friction}],
            }
        )
    problems = info.value.problems
    assert len(problems) == 1
    assert "\n" not in problems[0]
    assert expected in problems[0], problems


def test_a_world_object_with_bad_friction_is_refused():
    from harness.models import ModelError

    with pytest.raises(ModelError, match=r"crate: friction \[1.0, -2.0\] must be"):
        WorldObject("crate", "box", (0.1, 0.1, 0.1), friction=(1.0, -2.0)).check("crate")
