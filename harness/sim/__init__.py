"""The deterministic simulation core: fixed-step stepping, control modes per joint, state
capture and restore, applied inputs, contacts and joint-behaviour metrics."""

from harness.sim.commands import CommandField, Notice
from harness.sim.contacts import ContactSet, extract_contacts
from harness.sim.errors import (
    CommandError,
    ControlConfigError,
    InstabilityError,
    StateError,
    TimestepError,
)
from harness.sim.inputs import AppliedInput, advance, replay
from harness.sim.instability import warning_names
from harness.sim.robots import RobotJoints
from harness.sim.simulation import Observer, RobotLike, Simulation
from harness.sim.state import STATE_SPEC

__all__ = [
    "STATE_SPEC",
    "AppliedInput",
    "CommandError",
    "CommandField",
    "ContactSet",
    "ControlConfigError",
    "InstabilityError",
    "Notice",
    "Observer",
    "RobotJoints",
    "RobotLike",
    "Simulation",
    "StateError",
    "TimestepError",
    "advance",
    "extract_contacts",
    "replay",
    "warning_names",
]
