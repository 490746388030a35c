"""``joint_state_broadcaster/JointStateBroadcaster`` and controllers of types the harness does not
implement.

The session itself publishes ``/joint_states`` (every joint's position, velocity, effort at
``joint_states_hz``): the broadcaster is the controller the manager lists for it. A controller
of any other unknown type is loaded and listed (``unconfigured``) but cannot be configured or
activated: a robot's YAML with, say, a vendor's IO controller still configures the session.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from harness.controllers.base import (
    ActionEndpoint,
    JointReadings,
    Output,
    TopicEndpoint,
)
from harness.controllers.config import ControllerSpec

__all__ = ["JointStateBroadcaster", "Unsupported"]


class _Passive:
    subscriptions: tuple[TopicEndpoint, ...] = ()
    publishers: tuple[TopicEndpoint, ...] = ()
    actions: tuple[ActionEndpoint, ...] = ()
    command_interfaces: tuple[str, ...] = ()

    def __init__(self, spec: ControllerSpec) -> None:
        self.name = spec.name
        self.type = spec.type
        self.active = False

    def activate(self, state: JointReadings) -> Output:
        self.active = True
        return Output()

    def deactivate(self, state: JointReadings) -> Output:
        self.active = False
        return Output()

    def on_message(
        self, topic: str, msg: Mapping[str, Any], connection: int, state: JointReadings
    ) -> Output:
        return Output()

    def on_goal(
        self, action: str, goal: int, values: Mapping[str, Any], state: JointReadings
    ) -> Output:
        return Output()

    def on_cancel(self, action: str, goal: int, state: JointReadings) -> Output:
        return Output()

    def update(self, state: JointReadings, period_ns: int) -> Output:
        return Output()


class JointStateBroadcaster(_Passive):
    """Lists the session's ``/joint_states`` publisher as a controller."""

    def __init__(self, spec: ControllerSpec, joints: Sequence[str]) -> None:
        super().__init__(spec)
        self.state_interfaces = tuple(
            f"{j}/{i}" for j in joints for i in ("position", "velocity", "effort")
        )


class Unsupported(_Passive):
    """A controller type the harness does not implement: listed, never configured."""

    state_interfaces: tuple[str, ...] = ()
