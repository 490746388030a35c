"""The bundled mobile robot: a TurtleBot-class differential drive base
(``data/mobile_bot.urdf``), its room (``data/worlds/mobile_room.world``) and its controllers
YAML (``data/mobile_bot_controllers.yaml``: a ``diff_drive_controller`` on ``/cmd_vel`` with
odometry on ``/odom``). :func:`load_mobile_bot` loads it with a floating base set down on the
floor and velocity-driven wheels; :data:`GROUND_TRUTH_SENSOR` is the sensor declaration that
publishes its true pose on ``/ground_truth/odom``."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any

from harness.models.build.load import LoadedRobot, load_robot
from harness.models.bundled import DATA
from harness.models.world.records import PoseLike

__all__ = [
    "GROUND_TRUTH_SENSOR",
    "MOBILE_CONTROLLERS",
    "MOBILE_URDF",
    "MOBILE_WHEELS",
    "MOBILE_WORLD",
    "load_mobile_bot",
]

MOBILE_URDF = DATA / "mobile_bot.urdf"
MOBILE_WORLD = DATA / "worlds" / "mobile_room.world"
MOBILE_CONTROLLERS = DATA / "mobile_bot_controllers.yaml"
MOBILE_WHEELS = ("left_wheel_joint", "right_wheel_joint")
GROUND_TRUTH_SENSOR: Mapping[str, Any] = MappingProxyType(
    {
        "name": "ground_truth",
        "type": "ground_truth",
        "parent": "base_link",
        "topic": "/ground_truth/odom",
        "update_rate": 50.0,
    }
)


def load_mobile_bot(
    scene: str | Path | None = MOBILE_WORLD,
    *,
    pose: PoseLike = None,
    cache_dir: str | Path | None = None,
) -> LoadedRobot:
    """The bundled mobile robot in ``scene`` (default its room), its base at ``pose`` (set
    down on the floor), wheels velocity-driven."""
    return load_robot(
        MOBILE_URDF,
        control=dict.fromkeys(MOBILE_WHEELS, "velocity"),
        scene=scene,
        pose=pose,
        base="floating",
        cache_dir=cache_dir,
    )
