"""A robot's initial joint positions and pose are values of a warm world.

``load_world`` derives the combined keyframes from a robot's initial positions, and the
servo gains, the placement on the floor, the ignored self-collision pairs and a floating
base's keyed position from its pose (:mod:`harness.models.world.rebuild`). A warm world
applies them as ``load_world`` does (:meth:`harness.models.WorldBuild.rekey`,
:meth:`~harness.models.WorldBuild.place`) instead of building the world again: the compiled
model is the cold build's byte for byte, the robots' views (placement, ``home``) are the
cold build's, a kept example's recording is a cold ``harness run``'s, and the value changes
the run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from harness.explore import KernelRunner, load_plan, run_scenario
from harness.explore.parameters import apply_values
from harness.explore.warm import WarmWorlds, cold_world, model_bytes
from harness.scenario import Scenario
from tests.explore.conftest import DATA, write_variant

ARM = {
    "robots": [
        {
            "robot": "demo",
            "name": "arm",
            "modes": [{"type": "JointController", "mode": "position"}],
            "initial_joint_positions": {"joint2": 0.0, "joint4": -1.0},
        }
    ],
    "explore": {
        "parameters": {
            "robots.0.initial_positions.joint2": {"low": -0.3, "high": 0.3},
        },
        "target": "min_clearance",
    },
}
POSED = {
    "explore": {
        "parameters": {
            "robots.0.position": {"low": [-0.05, -0.05, 0.0], "high": [0.05, 0.05, 0.0]},
            "robots.0.orientation": {"low": [0.0, 0.0, -0.4], "high": [0.0, 0.0, 0.4]},
        },
        "target": "min_clearance",
    },
}
MOBILE = {
    # the bundled diff-drive bot driven by its wheels from a script toward the wall: where
    # it starts and its heading decide whether and where it hits
    "robots": [
        {
            "robot": str((DATA / "../../../harness/models/data/mobile_bot.urdf").resolve()),
            "name": "mobile_bot",
            "base": "floating",
            "modes": [{"type": "JointController", "mode": "velocity"}],
        }
    ],
    "client": None,
    "controllers": None,
    "duration": 1.5,
    "criteria": {"allowed_collisions": [["*", "world"]]},
    "script": [{"at": 0.0, "velocities": {"left_wheel_joint": 12.0, "right_wheel_joint": 12.0}}],
    "explore": {
        "parameters": {
            "robots.0.position": {"low": [-0.2, -0.2, 0.0], "high": [0.2, 0.2, 0.0]},
            "robots.0.orientation": {"low": [0.0, 0.0, -0.5], "high": [0.0, 0.0, 0.5]},
        },
        "target": "min_clearance",
    },
}


def _cold_bytes(scenario: Path, out: Path) -> bytes:
    result = run_scenario(scenario, out)
    assert result.recording is not None
    return Path(result.recording).read_bytes()


def _check_values(
    tmp_path: Path, plan_file: Path, nominal: dict[str, Any], examples: list[dict[str, Any]]
) -> KernelRunner:
    """Run the nominal example (the topology's world), then each of ``examples`` on the warm
    world: the model and views are the cold build's, the kept recording a cold ``harness
    run``'s, and the examples' runs differ from each other."""
    plan = load_plan(plan_file)
    runner = KernelRunner(plan, tmp_path / "scratch")
    runner.run(nominal)
    runs = set()
    for i, values in enumerate(examples):
        doc = apply_values(plan.document, plan.parameters, values)
        scenario = Scenario.from_mapping(doc, base_dir=plan.source.parent, source=plan.source)
        _, warm, _ = runner.worlds.get(scenario, doc)
        _, cold = cold_world(scenario, tmp_path / f"world-{i}")
        assert model_bytes(warm.model) == model_bytes(cold.model), values
        assert [(v.placement, dict(v.home)) for v in warm.robots] == [
            (v.placement, dict(v.home)) for v in cold.robots
        ]
        kept = runner.run(values, keep=tmp_path / f"kept-{i}")
        assert kept.check == "identical", kept.check
        runs.add((kept.digest, kept.margins["min_clearance"]))
        folder = Path(kept.kept or "")
        explored = (folder / "recording.mcap").read_bytes()
        assert explored == _cold_bytes(folder / "scenario.yaml", tmp_path / f"cold-{i}")
    assert len(runs) == len(examples)  # the value changed the run
    assert len(runner.worlds.worlds) == 1  # one topology: applied, not rebuilt
    assert runner.worlds.notes == []
    assert runner.mismatches == []
    return runner


def test_initial_position_is_a_value_of_a_warm_world(tmp_path: Path) -> None:
    plan_file = write_variant(tmp_path, "initial.yaml", "sweep.yaml", ARM)
    path = "robots.0.initial_positions.joint2"
    runner = _check_values(
        tmp_path,
        plan_file,
        {path: 0.0},
        [{path: 0.2345678901234}, {path: -0.2876543210987}],
    )
    (entry,) = runner.worlds.worlds.values()
    assert entry.rekeyed == 2  # each new value once (the kept run repeats the value)
    assert entry.placed == 0


def test_robot_pose_is_a_value_of_a_warm_world(tmp_path: Path) -> None:
    plan_file = write_variant(tmp_path, "posed.yaml", "sweep.yaml", POSED)
    position, orientation = "robots.0.position", "robots.0.orientation"
    runner = _check_values(
        tmp_path,
        plan_file,
        {position: [0.0, 0.0, 0.0], orientation: [0.0, 0.0, 0.0]},
        [
            {position: [0.0312345678901, -0.0123456789012, 0.0], orientation: [0.0, 0.0, 0.3]},
            {position: [-0.04, 0.0456789012345, 0.0], orientation: [0.0, 0.0, -0.2345678901]},
        ],
    )
    (entry,) = runner.worlds.worlds.values()
    assert entry.placed == 2
    assert entry.rekeyed == 0


def test_mobile_robot_pose_is_a_value_of_a_warm_world(tmp_path: Path) -> None:
    """A floating base: set down on the floor at its new pose, its free joint keyed there."""
    plan_file = write_variant(tmp_path, "mobile.yaml", "approach.yaml", MOBILE)
    position, orientation = "robots.0.position", "robots.0.orientation"
    runner = _check_values(
        tmp_path,
        plan_file,
        {position: [0.0, 0.0, 0.0], orientation: [0.0, 0.0, 0.0]},
        [
            {position: [0.1234567890123, 0.05, 0.0], orientation: [0.0, 0.0, 0.4123456789]},
            {position: [-0.15, -0.1876543210987, 0.0], orientation: [0.0, 0.0, -0.25]},
        ],
    )
    (entry,) = runner.worlds.worlds.values()
    assert entry.placed == 2


@pytest.mark.parametrize("kind", ["initial", "pose"])
def test_robot_values_do_not_build_the_world_again(tmp_path: Path, kind: str) -> None:
    """Past the checked examples, a new value costs no cold build: one build for the
    topology, one per checked example, then none."""
    if kind == "initial":
        plan_file = write_variant(tmp_path, "v.yaml", "sweep.yaml", ARM)
        values = [{"robots.0.initial_positions.joint2": v / 10} for v in range(-3, 4)]
    else:
        plan_file = write_variant(tmp_path, "v.yaml", "sweep.yaml", POSED)
        values = [
            {"robots.0.position": [v / 100, 0.0, 0.0], "robots.0.orientation": [0.0, 0.0, v / 10]}
            for v in range(-3, 4)
        ]
    plan = load_plan(plan_file)
    worlds = WarmWorlds(tmp_path / "worlds")
    for v in values:
        doc = apply_values(plan.document, plan.parameters, v)
        worlds.get(Scenario.from_mapping(doc, base_dir=plan.source.parent, source=plan.source), doc)
    assert (worlds.builds, worlds.applied) == (1 + worlds.checks, len(values) - 1)
    assert worlds.notes == []
