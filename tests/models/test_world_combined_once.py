"""A world's combined description is made once (the simulation, the scenario's loggers and
the traces each ask for it, for every session and explore example), and a world made from
it with other robots makes its own."""

from __future__ import annotations

import dataclasses

from harness.models import LoadedWorld, Pose, RobotSpec, load_world


def test_combined_description_is_made_once_per_world() -> None:
    world = load_world(
        [
            RobotSpec("demo", namespace="left", pose=Pose((0.0, 0.4, 0.0))),
            RobotSpec("demo", namespace="right", pose=Pose((0.0, -0.4, 0.0))),
        ]
    )
    first = world.combined_description()
    assert world.combined_description() is first
    # equal to a fresh combination: the cache is not part of the world's value
    assert dataclasses.replace(world).combined_description() == first
    assert dataclasses.replace(world) == world
    # another world (one robot left): its own description, not the first one's
    alone: LoadedWorld = dataclasses.replace(world, robots=world.robots[:1])
    names = {link.name for link in alone.combined_description().links}
    assert names == {link.name for link in first.links if link.name.startswith("left/")}
    assert world.combined_description() is first
