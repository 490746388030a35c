"""What the recording sink hands to a recorder: one record per written message.

The recorder seam takes records, not keyword lists (as the session core's does with
:mod:`harness.recording.records`): a collision event as ``/harness/collisions`` holds it, a
``/rosout`` line as ``rcl_interfaces/msg/Log`` holds it. Plain values, so this module imports
nothing heavy and the recorder can name the types without importing the event machinery.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

__all__ = ["KIND_BEGIN", "KIND_END", "KIND_NEAR_MISS", "CollisionRecord", "RosoutRecord"]

KIND_BEGIN = 0
KIND_END = 1
KIND_NEAR_MISS = 2


class CollisionRecord(NamedTuple):
    """A collision begin (:data:`KIND_BEGIN`), end (:data:`KIND_END`) or near miss
    (:data:`KIND_NEAR_MISS`); fields as in ``harness_msgs/msg/CollisionEvent``."""

    step: int
    sim_time_ns: int
    kind: int
    robot: str
    body1: str
    body2: str
    geom1: str
    geom2: str
    penetration: float
    normal_force: float
    position: Sequence[float]
    normal: Sequence[float]
    duration_ns: int = 0
    distance: float = 0.0
    begin_step: int = 0
    end_step: int = 0


class RosoutRecord(NamedTuple):
    """A ``/rosout`` line (levels 10/20/30/40/50, as ``rcl_interfaces/msg/Log``)."""

    sim_time_ns: int
    level: int
    name: str
    msg: str
    file: str = ""
    function: str = ""
    line: int = 0
