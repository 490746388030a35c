"""Default verdicts pass a correct run (issue 15): the original framework's runner config and
scene on the built-in table, world-only contacts, the robot's resting contacts at the start,
the solver's joint-limit tolerance, and the settings printed with how to change them."""

import itertools
import json
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from harness.models import RobotSpec, load_world
from harness.scenario import (
    Criteria,
    Scenario,
    iteration_specs,
    judge,
    load_run_file,
    render_html,
    session_iteration_runner,
)
from harness.scenario.results import CollisionSummary, JointLimitSummary, criteria_settings

ORIGINAL = Path(__file__).parent.parent / "data" / "scenario" / "original"
# Fingers closed on the box from above it: the demo arm's hand really grasps the box.
ONTO_THE_BOX = "0.0 -0.076 0.0 -2.159 0.0 2.085 0.785 0.0"


def _run(folder: Path, command: str | None = None, iterations: int | None = None):
    """The runner config in ``folder`` run in this process, one iteration after the other."""
    if command is not None or iterations is not None:
        doc = json.loads((folder / "runner.json").read_text())
        sim = doc["simulations"][0]
        sim["command"] = command or sim["command"]
        sim["iterations"] = iterations or sim["iterations"]
        (folder / "runner.json").write_text(json.dumps(doc))
    config = load_run_file(folder / "runner.json")
    runner = session_iteration_runner()
    return [runner(spec) for spec in iteration_specs(config, folder / "out")]


@pytest.fixture
def original(tmp_path):
    folder = tmp_path / "original"
    shutil.copytree(ORIGINAL, folder)
    return folder


@pytest.mark.slow
def test_original_runner_config_on_the_table_passes_both_iterations(original):
    results = _run(original)
    assert len(results) == 2
    for result in results:
        assert result.passed, result.reason
        # The scene's own box resting on the scene's own table: recorded, not judged.
        (box,) = [c for c in result.collisions if {c.body1, c.body2} == {"table", "box"}]
        assert box.world
        collisions = next(v for v in result.verdicts if v.name == "collisions")
        assert "1 world or initial contact(s) recorded, not judged" in collisions.detail
        # The gripper holds at its own limit inside the solver's soft-limit zone.
        finger = next(j for j in result.joint_limits if j.joint == "finger_joint1")
        assert 0 < finger.max_excess < finger.tolerance == pytest.approx(0.001)
        assert any("criteria.world_collisions" in s for s in result.settings)
    page = render_html(results, original / "runner.json")
    assert "Verdict settings" in page
    assert "criteria.joint_limit_tolerance" in page


@pytest.mark.slow
def test_hitting_the_box_fails_naming_the_arm_link(original):
    (result,) = _run(original, f"python move_arm.py {ONTO_THE_BOX}", iterations=1)
    assert not result.passed
    collisions = next(v for v in result.verdicts if v.name == "collisions")
    assert not collisions.passed
    assert "_finger - box" in collisions.detail, collisions.detail
    first = collisions.detail.split("first ")[1].split(" - ")[0]
    assert first in ("left_finger", "right_finger")


def _lowest_finger_point() -> np.ndarray:
    """The lowest corner of the demo arm's finger pads in its home pose (world frame)."""
    world = load_world([RobotSpec("demo", namespace="arm")], scene="empty")
    model = world.model
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    corners = [
        data.geom_xpos[g] + data.geom_xmat[g].reshape(3, 3) @ (np.array(s) * model.geom_size[g])
        for g in range(model.ngeom)
        if model.geom(g).name.endswith("finger_pad")
        for s in itertools.product((-1, 1), repeat=3)
    ]
    return min(corners, key=lambda p: p[2])


def test_the_robots_resting_contacts_at_the_start_pass(tmp_path):
    # A fixed block under the gripper in its home pose, touching it 0.5 mm deep: the hand rests
    # on it from the first step (the solver's resting depth is 1 mm).
    low = _lowest_finger_point()
    block = {
        "name": "block",
        "shape": "box",
        "size": [0.03, 0.08, 0.01],
        "position": [float(low[0]), 0.0, float(low[2]) - 0.01 + 0.0005],
    }
    doc = {
        "environment": {"map": "empty"},
        "robots": [{"robot": "demo", "name": "arm"}],
        "objects": [block],
        "duration": 0.3,
        "clock": {"mode": "lockstep"},
    }
    (tmp_path / "resting.yaml").write_text(yaml.safe_dump(doc))
    config = load_run_file(tmp_path / "resting.yaml")
    (result,) = [session_iteration_runner()(s) for s in iteration_specs(config, tmp_path / "o")]
    on_block = [c for c in result.collisions if c.body2 == "block"]
    assert on_block, result.collisions
    assert all(c.initial and not c.world for c in on_block), result.collisions
    assert result.passed, result.reason
    # Judging initial contacts too (the documented switch) fails the same run.
    strict = Criteria(initial_contacts=True)
    assert not judge(strict, None, result.collisions, result.joint_limits)[0].passed


def test_judge_defaults_and_their_switches():
    world = CollisionSummary("table", "box", 0.004, None, 1e-4, 0.3, world=True)
    resting = CollisionSummary("link0", "table", 0.002, None, 1e-4, 20.0, initial=True)
    hit = CollisionSummary("hand", "box", 0.5, 0.6, 2e-3, 10.0)
    finger = JointLimitSummary("finger_joint1", 0.0, 0.04, 0.0, 0.04, 1.4e-6, 400, 0.001)
    ok = judge(Criteria(), None, [world, resting], [finger])
    assert all(v.passed for v in ok)
    bad = judge(Criteria(), None, [world, resting, hit], [finger])
    assert "first hand - box" in bad[0].detail
    assert not judge(Criteria(world_collisions=True), None, [world], [])[0].passed
    assert not judge(Criteria(joint_limit_tolerance=1e-7), None, [], [finger])[1].passed
    broken = JointLimitSummary("joint1", -1.0, 1.0, -1.0, 1.01, 0.01, 30, 0.001)
    assert (
        "worst joint1 by 0.01 (tolerance 0.001)" in judge(Criteria(), None, [], [broken])[1].detail
    )


def test_every_default_is_printed_with_how_to_change_it():
    lines = criteria_settings(Criteria())
    for key in (
        "no_collisions",
        "allowed_collisions",
        "world_collisions",
        "initial_contacts",
        "joint_limit_tolerance",
        "deterministic",
    ):
        assert any(f"criteria.{key}" in line for line in lines), key
    scenario = Scenario.from_mapping(
        {"robots": [{"robot": "demo"}], "criteria": {"joint_limit_tolerance": 0.01}}
    )
    assert scenario.criteria.joint_limit_tolerance == 0.01
    assert (
        Scenario.from_mapping({"robots": [{"robot": "demo"}]}).criteria.joint_limit_tolerance
        is None
    )
