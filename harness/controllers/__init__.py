"""ros2_control's controllers, simulated: what sits between a ROS interface and the simulation's
inputs.

One module per controller kind, each sans-I/O (messages, goals and cancels in at a step
boundary, joint commands and messages out: :mod:`harness.controllers.base`):
:mod:`~harness.controllers.joint_trajectory` (``~/joint_trajectory`` and the
FollowJointTrajectory action, interpolation and tolerances in :mod:`~harness.controllers.spline`),
:mod:`~harness.controllers.forward_command`, :mod:`~harness.controllers.gripper_action`,
:mod:`~harness.controllers.broadcaster`; the controllers YAML (:mod:`~harness.controllers.config`)
and the controller manager with its services (:mod:`~harness.controllers.manager`). The session
binds them to the bridge (:mod:`harness.session.control`).
"""

from harness.controllers.base import (
    GOAL_ABORTED,
    GOAL_CANCELED,
    GOAL_SUCCEEDED,
    ActionEndpoint,
    BaseVelocity,
    Command,
    Controller,
    Feedback,
    JointReadings,
    LogLine,
    Output,
    Publication,
    Result,
    TopicEndpoint,
)
from harness.controllers.config import (
    ControllersConfig,
    ControllerSpec,
    default_controllers,
    load_controllers,
)
from harness.controllers.errors import ControllerError, ControllersConfigError
from harness.controllers.manager import SERVICES, ControllerManager, make_controller

__all__ = [
    "GOAL_ABORTED",
    "GOAL_CANCELED",
    "GOAL_SUCCEEDED",
    "SERVICES",
    "ActionEndpoint",
    "BaseVelocity",
    "Command",
    "Controller",
    "ControllerError",
    "ControllerManager",
    "ControllerSpec",
    "ControllersConfig",
    "ControllersConfigError",
    "Feedback",
    "JointReadings",
    "LogLine",
    "Output",
    "Publication",
    "Result",
    "TopicEndpoint",
    "default_controllers",
    "load_controllers",
    "make_controller",
]
