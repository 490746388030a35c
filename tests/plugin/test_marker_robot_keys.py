"""With ``scenario=``, the marker's robot keys (every :class:`harness.models.RobotSpec` field the
marker accepts, :func:`harness.plugin.markers.first_robot_keys`) apply to the scenario's first
robot; an unknown key is still refused in one line."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

from harness.models import RobotSpec
from harness.plugin.markers import first_robot_keys, marker_keys
from harness.plugin.scenario import over_scenario, scenario_session
from harness.session.core.options import SESSION_KEYWORDS

TWO_LINK = Path(__file__).parents[1] / "data" / "scenario" / "robots" / "two_link.urdf"
SCENARIO = """
robots:
  - robot: two_link.urdf
    modes: [{type: JointController, mode: velocity}]
  - robot: demo
    name: second
"""

SAMPLES = {
    "robot": ("demo", "demo"),
    "mode": ("dynamic", "position"),  # parsed: one spelling
    "namespace": ("arm", "arm"),
    "robot_args": ({"prefix": "left_"}, {"prefix": "left_"}),
    "self_collision": ("off", "off"),
    "base": ("floating", "floating"),
    "strict": (True, True),
    "srdf": ("arm.srdf", "arm.srdf"),
    "pose": ((1.0, 2.0, 0.0), (1.0, 2.0, 0.0)),
}
"""Robot key -> (marker value, the first RobotSpec's value)."""


def test_the_robot_keys_are_the_robot_spec_fields_the_marker_accepts():
    spelled = {"source": "robot", "control": "mode"}  # Session(robot=, mode=)
    fields = {spelled.get(f.name, f.name): f.name for f in dataclasses.fields(RobotSpec)}
    assert dict(first_robot_keys()) == {k: v for k, v in fields.items() if k in marker_keys()}
    # today's keys, none lost: a RobotSpec field that is also a Session keyword joins them
    assert set(first_robot_keys()) == set(SAMPLES)
    for key, name in first_robot_keys().items():
        assert key in ("robot", "mode") or key in SESSION_KEYWORDS, key
        assert name in {f.name for f in dataclasses.fields(RobotSpec)}


def test_every_robot_key_applies_to_the_scenario_first_robot(tmp_path):
    shutil.copy(TWO_LINK, tmp_path)
    (tmp_path / "arm.yaml").write_text(SCENARIO)
    planned = scenario_session(tmp_path / "arm.yaml", tmp_path / "world")
    before = planned.keywords()["robots"]
    for key, (value, expected) in SAMPLES.items():
        marker = {key: value, "seed": 3}
        keywords = over_scenario(planned, marker, "test_x")
        first, second = keywords["robots"]
        assert getattr(first, first_robot_keys()[key]) == expected, key
        assert getattr(before[0], first_robot_keys()[key]) != expected, key  # a real change
        assert second == before[1]  # the other robots keep the file's settings
        assert marker == {"seed": 3}  # the robot key went into the first robot
        assert keywords["seed"] == 3


def test_the_marker_applies_its_robot_keys_over_a_scenario(pytester, run):
    shutil.copy(TWO_LINK, pytester.path)
    pytester.makefile(".yaml", arm=SCENARIO)
    pytester.makepyfile(
        test_keys="""
        import pytest

        @pytest.mark.harness(
            scenario="arm.yaml", robot="demo", mode="kinematic", namespace="arm",
            robot_args={}, self_collision="off", base="fixed", strict=True,
        )
        def test_first_robot(harness_session):
            first, second = harness_session.world.robots
            assert first.description.name == "demo_arm"
            assert (first.namespace, first.base) == ("arm", "fixed")
            assert set(first.control.values()) == {"kinematic"}
            assert first.self_collision.policy == "off"
            assert second.namespace == "second"

        @pytest.mark.harness(scenario="arm.yaml", positon=[1, 0, 0])
        def test_typo(harness_session):
            pass
        """
    )
    result = run()
    result.assert_outcomes(passed=1, errors=1)
    result.stdout.fnmatch_lines(["*test_typo*unknown harness option 'positon' (known: *"])
