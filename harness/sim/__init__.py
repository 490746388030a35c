"""The deterministic simulation core: fixed-step stepping, control modes per joint, state
capture and restore, applied inputs, contacts and joint-behaviour metrics."""

from harness.sim.bits import differing, same_bits
from harness.sim.collisions import (
    CollisionTracker,
    CollisionTransition,
    NearMissRecord,
    NearMissTracker,
    allowed_pairs,
    near_miss_candidates,
    subtree_bodies,
)
from harness.sim.commands import CommandField, Notice
from harness.sim.contacts import ContactSet, extract_contacts
from harness.sim.errors import (
    CommandError,
    ControlConfigError,
    InstabilityError,
    StateError,
    TimestepError,
)
from harness.sim.inputs import ARRAY_FIELDS, AppliedInput, advance, replay, write_input
from harness.sim.instability import warning_names
from harness.sim.metrics import energy
from harness.sim.robots import RobotJoints
from harness.sim.simulation import Observer, RobotLike, Simulation
from harness.sim.state import STATE_SPEC, qpos_qvel_slices

__all__ = [
    "ARRAY_FIELDS",
    "STATE_SPEC",
    "AppliedInput",
    "CollisionTracker",
    "CollisionTransition",
    "CommandError",
    "CommandField",
    "ContactSet",
    "ControlConfigError",
    "InstabilityError",
    "NearMissRecord",
    "NearMissTracker",
    "Notice",
    "Observer",
    "RobotJoints",
    "RobotLike",
    "Simulation",
    "StateError",
    "TimestepError",
    "advance",
    "allowed_pairs",
    "differing",
    "energy",
    "extract_contacts",
    "near_miss_candidates",
    "qpos_qvel_slices",
    "replay",
    "same_bits",
    "subtree_bodies",
    "warning_names",
    "write_input",
]
