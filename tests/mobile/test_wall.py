"""Driving the bundled robot into a wall of its room: the CollisionLogger names the wall's
model and link, and the robot stays on its side of the wall."""

from __future__ import annotations

import warnings
from typing import Any

from harness import Session
from harness.events import CollectingSink, CollisionBegin, CollisionLogger
from harness.models.mobile import GROUND_TRUTH_SENSOR, MOBILE_CONTROLLERS, load_mobile_bot
from harness.testing import connect

WALL_INNER_FACE = 2.0  # the east wall's inner face (x) in mobile_room.world
CHASSIS_FRONT = 0.09  # the chassis reaches this far ahead of base_link


def _twist(linear: float) -> dict[str, Any]:
    return {"linear": {"x": linear, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}


def test_driving_into_a_wall_is_reported_and_does_not_pass_through() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the base is set down onto the floor: a note
        robot = load_mobile_bot(pose=[1.4, 0.0, 0.0])
    sink = CollectingSink()
    session = Session(
        robot,
        controllers=MOBILE_CONTROLLERS,
        sensors=[GROUND_TRUTH_SENSOR],
        loggers=[
            lambda s: CollisionLogger(s.sim.model, robot_root="base_link", robot_vs_world_only=True)
        ],
        sinks=[sink],
    )
    with session, connect(session.url) as client:
        truth = client.subscribe("/ground_truth/odom", "nav_msgs/msg/Odometry")
        for _ in range(60):  # 3 s at 0.3 m/s: 0.9 m, the wall is 0.51 m ahead of the chassis
            client.publish("/cmd_vel", "geometry_msgs/msg/Twist", _twist(0.3))
            client.step(25)
        final_x = truth.messages[-1]["pose"]["pose"]["position"]["x"]
    begins = [e for e in sink.of_kind(CollisionBegin) if "room::" in e.body1 + e.body2]
    assert begins, [str(e) for e in sink.events]
    first = begins[0]
    assert {first.body1, first.body2} == {"room::east_wall", "base_link"}
    assert "room::east_wall/collision" in (first.geom1, first.geom2)
    assert final_x + CHASSIS_FRONT < WALL_INNER_FACE + 0.005
    assert final_x > 1.85  # it did reach the wall
