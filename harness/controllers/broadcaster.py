"""``joint_state_broadcaster/JointStateBroadcaster`` and controllers of types the harness does not
implement.

The session itself publishes ``/joint_states`` (every joint's position, velocity, effort): at
``joint_states_hz`` with the harness's default set, at the broadcaster's update rate while it
is active with a YAML's (:class:`JointStateBroadcaster`). A controller
of any other unknown type is loaded and listed (``unconfigured``) but cannot be configured or
activated: a robot's YAML with, say, a vendor's IO controller still configures the session.
"""

from __future__ import annotations

from collections.abc import Sequence

from harness.controllers.base import Controller, ControllerBase
from harness.controllers.config import TYPE_JOINT_STATE_BROADCASTER, ControllerSpec
from harness.controllers.registry import RobotInterfaces, controller_type

__all__ = ["JointStateBroadcaster", "Unsupported"]


class JointStateBroadcaster(ControllerBase):
    """Lists the session's ``/joint_states`` publisher as a controller. In a set a YAML or
    robot file names, ``/joint_states`` is published while it is active, at its update rate
    (its own ``update_rate``, at most the manager's, else the manager's)."""

    publishes_joint_states = True
    """The session publishes the robot's ``/joint_states`` on its schedule."""

    def __init__(self, spec: ControllerSpec, joints: Sequence[str]) -> None:
        super().__init__(spec.name, spec.type)
        self.state_interfaces = tuple(
            f"{j}/{i}" for j in joints for i in ("position", "velocity", "effort")
        )


@controller_type(TYPE_JOINT_STATE_BROADCASTER)
def _joint_state_broadcaster(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return JointStateBroadcaster(spec, robot.joints)


class Unsupported(ControllerBase):
    """A controller type the harness does not implement: listed, never configured.
    ``reason``: the one line saying so (the type and the known ones)."""

    def __init__(self, spec: ControllerSpec, reason: str = "") -> None:
        super().__init__(spec.name, spec.type)
        self.reason = reason or f"type {spec.type} is not implemented by the harness"
