"""``WorldBuild``: a world kept open gives what ``load_world`` gives for other robot poses and
initial positions, byte for byte, without reading or attaching the robots again."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from harness.models import ModelError, RobotSpec, WorldBuild, load_world


def _bytes(model: mujoco.MjModel) -> bytes:
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return buffer.tobytes()


pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

ROBOTS = [
    RobotSpec("demo", namespace="left", pose=[0.0, -0.5, 0.0]),
    RobotSpec("demo", namespace="right", pose=[0.0, 0.5, 0.0, 0.0, 0.0, 3.0]),
]


def test_placed_and_rekeyed_worlds_are_load_worlds() -> None:
    build = WorldBuild(ROBOTS, scene="floor")
    assert _bytes(build.world.model) == _bytes(load_world(ROBOTS, scene="floor").model)
    moved = [
        dataclasses.replace(ROBOTS[0], pose=[0.1234567890123, -0.4, 0.0, 0.0, 0.0, 0.3]),
        dataclasses.replace(ROBOTS[1], initial_positions={"joint2": 0.4}),
    ]
    placed = build.place(moved)
    cold = load_world(moved, scene="floor")
    assert _bytes(placed.model) == _bytes(cold.model)
    assert placed.mjcf == cold.mjcf
    assert [v.placement for v in placed.robots] == [v.placement for v in cold.robots]
    rekeyed = [moved[0], dataclasses.replace(moved[1], initial_positions={"joint2": -0.35})]
    build.rekey(rekeyed)
    model = build.world.spec.compile()
    cold = load_world(rekeyed, scene="floor")
    assert _bytes(model) == _bytes(cold.model)
    assert [dict(v.home) for v in build.views(model)] == [dict(v.home) for v in cold.robots]
    assert build.requests == tuple(rekeyed)


def test_only_poses_and_initial_positions_change() -> None:
    build = WorldBuild(ROBOTS, scene="floor")
    other = [dataclasses.replace(ROBOTS[0], control="velocity"), ROBOTS[1]]
    with pytest.raises(ModelError, match=r"robots\[0\] differs in more than its pose") as info:
        build.place(other)
    assert "\n" not in str(info.value)
    with pytest.raises(ModelError, match=r"robots given, the world has 2"):
        build.place(ROBOTS[:1])
    moved = [ROBOTS[0], dataclasses.replace(ROBOTS[1], pose=[0.0, 0.6, 0.0])]
    with pytest.raises(ModelError, match=r"robots\[1\] moved: place\(\) builds a new pose"):
        build.rekey(moved)
