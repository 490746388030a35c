"""The command topics moved to :mod:`harness.controllers.command_topics` (re-exported here)."""

from harness.controllers.command_topics import (
    FORWARD_TOPICS,
    CommandTarget,
    Trajectory,
    apply_forward,
    apply_joint_state,
    parse_trajectory,
)

__all__ = [
    "FORWARD_TOPICS",
    "CommandTarget",
    "Trajectory",
    "apply_forward",
    "apply_joint_state",
    "parse_trajectory",
]
